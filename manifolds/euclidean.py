"""Euclidean space of point sets: the point-distribution model (PDM)."""

from __future__ import annotations

import numpy as np

from .errors import ManifoldError
from .riemannian import RiemannianManifold
from .validation import (
    check_array,
    check_batch_shapes,
    check_finite_result,
    check_float,
    check_int,
    check_n_samples,
    check_rng,
)

__all__ = ["Euclidean"]


class Euclidean(RiemannianManifold):
    """Flat space ``R^shape`` with straight-line geodesics.

    With ``shape = (k, d)`` this is the point-distribution model of ``k``
    landmarks in ``R^d``: the ``alpha -> infinity`` limit of the LDDMM space
    (paper, Section 2.1). The symmetry is ``s_m(x) = 2m - x``.

    Parameters
    ----------
    shape : int or tuple of int
        Shape of one point, e.g. ``3`` or ``(k, d)``.
    """

    is_symmetric = True
    supports_batch = True

    def __init__(self, shape):
        dims = (shape,) if np.isscalar(shape) else tuple(shape)
        if len(dims) == 0:
            raise ManifoldError("Euclidean: shape: expected a positive int or tuple, got ()")
        self.point_shape = tuple(check_int(s, "Euclidean: shape", minimum=1) for s in dims)

    def _axes(self, arr):
        nd = len(self.point_shape)
        return tuple(range(arr.ndim - nd, arr.ndim))

    def _arrays(self, **arrays) -> list[np.ndarray]:
        """Validated float arrays (shape, finiteness) whose batch axes broadcast."""
        out = {k: check_array(a, self.point_shape, f"{self.name}: {k}") for k, a in arrays.items()}
        check_batch_shapes(len(self.point_shape), self.name, **out)
        return list(out.values())

    def exp(self, point, tangent):
        point, tangent = self._arrays(point=point, tangent=tangent)
        with np.errstate(over="ignore"):
            out = point + tangent
        return check_finite_result(
            out, f"{self.name}: tangent", "too large: point + tangent overflows"
        )

    def log(self, point, other):
        point, other = self._arrays(point=point, other=other)
        with np.errstate(over="ignore"):
            out = other - point
        return check_finite_result(
            out, f"{self.name}: other", "too far from point: other - point overflows"
        )

    def inner(self, point, u, v):
        _, u, v = self._arrays(point=point, u=u, v=v)
        prod = u * v
        return check_finite_result(
            prod.sum(axis=self._axes(prod)), f"{self.name}: u, v", "overflow"
        )

    def dist(self, a, b):
        a, b = self._arrays(a=a, b=b)
        diff = b - a
        scale = np.max(np.abs(diff), axis=self._axes(diff), keepdims=True)
        scale = np.where(scale > 0, scale, 1.0)
        red = (diff / scale) ** 2
        return np.squeeze(scale, axis=self._axes(scale)) * np.sqrt(red.sum(axis=self._axes(red)))

    def midpoint(self, a, b):
        a, b = self._arrays(a=a, b=b)
        return 0.5 * a + 0.5 * b

    def symmetry(self, center, point):
        center, point = self._arrays(center=center, point=point)
        with np.errstate(over="ignore"):
            out = 2.0 * center - point
        return check_finite_result(
            out, f"{self.name}: point", "too far from center: 2 center - point"
        )

    def parallel_transport(self, point, end, tangent):
        """Identity: the flat connection transports vectors unchanged."""
        point, end, tangent = self._arrays(point=point, end=end, tangent=tangent)
        shape = np.broadcast_shapes(point.shape, end.shape, tangent.shape)
        return np.array(np.broadcast_to(tangent, shape), dtype=float)

    def curvature(self, point, u, v, w):
        arrays = self._arrays(point=point, u=u, v=v, w=w)
        return np.zeros(np.broadcast_shapes(*(a.shape for a in arrays)))

    def curvature_derivative(self, point, x, u, v, w):
        arrays = self._arrays(point=point, x=x, u=u, v=v, w=w)
        return np.zeros(np.broadcast_shapes(*(a.shape for a in arrays)))

    def random_point(self, rng: np.random.Generator, n_samples: int | None = None):
        n_samples = check_n_samples(n_samples)
        size = self.point_shape if n_samples is None else (n_samples, *self.point_shape)
        return check_rng(rng).standard_normal(size)

    def random_tangent(self, point, rng: np.random.Generator, scale: float = 1.0):
        (point,) = self._arrays(point=point)
        check_rng(rng)
        scale = check_float(scale, f"{self.name}: scale", minimum=0.0)
        return scale * rng.standard_normal(point.shape)
