"""Poincare half-plane ``{(x, y): y > 0}`` with ``g = (dx^2 + dy^2) / y^2``."""

from __future__ import annotations

import autograd.numpy as anp
import numpy as np

from .metric_field import MetricField

__all__ = ["PoincareHalfPlane"]


def _half_plane_metric(x):
    return anp.eye(2) / x[1] ** 2


def _upper(x) -> bool:
    return bool(x[1] > 0.0)


def _half_plane_jet(x, order: int):
    y = float(x[1])
    eye = np.eye(2)
    g = eye / y**2
    dg = np.zeros((2, 2, 2))
    dg[:, :, 1] = -2.0 * eye / y**3
    if order == 1:
        return g, dg
    d2g = np.zeros((2, 2, 2, 2))
    d2g[:, :, 1, 1] = 6.0 * eye / y**4
    return g, dg, d2g


class PoincareHalfPlane(MetricField):
    """The hyperbolic plane (``K = -1``) in the Poincare half-plane model.

    Geometry is computed generically from the metric ``g = I / y^2`` (geodesic
    ODE, shooting, autograd curvature); the closed forms of the hyperbolic
    plane serve as a check. The space is symmetric (``nabla R = 0``), so the
    pole ladder is exact up to the ODE accuracy.

    Christoffel symbols: ``Gamma^x_xy = Gamma^x_yx = -1/y``, ``Gamma^y_xx = 1/y``,
    ``Gamma^y_yy = -1/y``, all others zero.

    Parameters
    ----------
    **kwargs
        Passed to :class:`~manifolds.metric_field.MetricField` (``integrator``,
        ``shooting``, ``sampling_box``; default box ``[-1, 1] x [0.5, 2]``).
    """

    is_symmetric = True

    def __init__(self, **kwargs):
        kwargs.setdefault("sampling_box", (np.array([-1.0, 0.5]), np.array([1.0, 2.0])))
        super().__init__(_half_plane_metric, 2, domain=_upper, metric_jet=_half_plane_jet, **kwargs)

    def __repr__(self) -> str:
        return "PoincareHalfPlane()"
