"""Warped-product surface ``g = dx^2 + f(x)^2 dy^2``: a non-symmetric test space."""

from __future__ import annotations

from collections.abc import Callable

import autograd.numpy as anp
import numpy as np
from autograd import grad

from .metric_field import MetricField

__all__ = ["WarpedSurface"]


def _default_f(x):
    return 1.0 + x**2


def _default_df(x):
    return 2.0 * x


def _default_d2f(x):
    return 2.0 + 0.0 * x


class WarpedSurface(MetricField):
    """The plane ``R^2`` with the warped metric ``g = dx^2 + f(x)^2 dy^2``.

    Its Gaussian curvature is ``K(x) = -f''(x) / f(x)``. With the default
    ``f(x) = 1 + x^2``, ``K = -2 / (1 + x^2)`` varies with ``x``, so
    ``nabla R != 0``: the space is not (locally) symmetric and the pole ladder
    is only third order. With ``f = cosh`` it is the hyperbolic plane
    (``K = -1``), a symmetric control case.

    Christoffel symbols: ``Gamma^x_yy = -f f'``, ``Gamma^y_xy = Gamma^y_yx = f' / f``,
    all others zero.

    Parameters
    ----------
    f : callable, optional
        Positive warping function of one real variable, written with
        :mod:`autograd.numpy` (e.g. ``autograd.numpy.cosh``). Default ``1 + x^2``.
    df, d2f : callable, optional
        ``f'`` and ``f''`` in closed form, used by the geodesic ODEs for speed;
        by default obtained from ``f`` by autograd (slower).
    **kwargs
        Passed to :class:`~manifolds.metric_field.MetricField` (``integrator``,
        ``shooting``, ``sampling_box``).
    """

    def __init__(
        self,
        f: Callable | None = None,
        df: Callable | None = None,
        d2f: Callable | None = None,
        **kwargs,
    ):
        if f is None:
            if df is not None or d2f is not None:
                raise ValueError("df, d2f: only meaningful together with a custom f")
            f, df, d2f = _default_f, _default_df, _default_d2f
        if not callable(f):
            raise TypeError("f: expected a callable of one real variable")
        self.f = f
        self.df = grad(f) if df is None else df
        self.d2f = grad(self.df) if d2f is None else d2f

        def metric_matrix(x):
            fx = f(x[0])
            return anp.array([[1.0, 0.0], [0.0, fx * fx]])

        kwargs.setdefault("sampling_box", (np.array([-1.0, -1.0]), np.array([1.0, 1.0])))
        super().__init__(
            metric_matrix, 2, domain=self._positive_f, metric_jet=self._jet_closed, **kwargs
        )

    def _positive_f(self, x) -> bool:
        return bool(self.f(float(x[0])) > 0.0)

    def _jet_closed(self, x, order: int):
        f0 = float(self.f(x[0]))
        f1 = float(self.df(x[0]))
        g = np.array([[1.0, 0.0], [0.0, f0 * f0]])
        dg = np.zeros((2, 2, 2))
        dg[1, 1, 0] = 2.0 * f0 * f1
        if order == 1:
            return g, dg
        d2g = np.zeros((2, 2, 2, 2))
        d2g[1, 1, 0, 0] = 2.0 * (f1 * f1 + f0 * float(self.d2f(x[0])))
        return g, dg, d2g

    def gaussian_curvature(self, point) -> float:
        """Closed form ``K = -f''(x) / f(x)`` at ``point = (x, y)``."""
        x = self._point(point)
        return -float(self.d2f(x[0])) / float(self.f(x[0]))

    def __repr__(self) -> str:
        return f"WarpedSurface(f={getattr(self.f, '__name__', repr(self.f))})"
