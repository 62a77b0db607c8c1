"""Euclidean space of point sets: the point-distribution model (PDM)."""

from __future__ import annotations

import numpy as np

from .riemannian import RiemannianManifold
from .validation import check_array

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
        self.point_shape = (int(shape),) if np.isscalar(shape) else tuple(int(s) for s in shape)
        if any(s <= 0 for s in self.point_shape):
            raise ValueError(f"Euclidean: shape must be positive, got {self.point_shape}")

    def _axes(self, arr):
        nd = len(self.point_shape)
        return tuple(range(arr.ndim - nd, arr.ndim))

    def exp(self, point, tangent):
        point = check_array(point, self.point_shape, f"{self.name}: point")
        tangent = check_array(tangent, self.point_shape, f"{self.name}: tangent")
        return point + tangent

    def log(self, point, other):
        point = check_array(point, self.point_shape, f"{self.name}: point")
        other = check_array(other, self.point_shape, f"{self.name}: other")
        return other - point

    def inner(self, point, u, v):
        prod = np.asarray(u, dtype=float) * np.asarray(v, dtype=float)
        return prod.sum(axis=self._axes(prod))

    def dist(self, a, b):
        diff = np.asarray(b, dtype=float) - np.asarray(a, dtype=float)
        return np.sqrt((diff**2).sum(axis=self._axes(diff)))

    def midpoint(self, a, b):
        return 0.5 * (np.asarray(a, dtype=float) + np.asarray(b, dtype=float))

    def symmetry(self, center, point):
        return 2.0 * np.asarray(center, dtype=float) - np.asarray(point, dtype=float)

    def parallel_transport(self, point, end, tangent):
        """Identity: the flat connection transports vectors unchanged."""
        return np.array(tangent, dtype=float)

    def curvature(self, point, u, v, w):
        return np.zeros_like(np.asarray(w, dtype=float))

    def curvature_derivative(self, point, x, u, v, w):
        return np.zeros_like(np.asarray(w, dtype=float))

    def random_point(self, rng: np.random.Generator, n_samples: int | None = None):
        size = self.point_shape if n_samples is None else (n_samples, *self.point_shape)
        return rng.standard_normal(size)

    def random_tangent(self, point, rng: np.random.Generator, scale: float = 1.0):
        shape = np.shape(point)
        return scale * rng.standard_normal(shape)
