"""Shared structure of the quadric models of constant curvature ``K = +-1``.

The sphere ``{<x, x> = 1}`` and the hyperboloid ``{<x, x>_L = -1, x_0 > 0}`` are
level sets of a bilinear form of ``R^{n+1}`` (Euclidean or Minkowski). Written with
that form, their symmetry, curvature tensor, input checks and public wrappers are
the same formulas with the sign ``K``; a subclass supplies the form, membership,
tangency and the closed-form ``_exp``/``_log``.
"""

from __future__ import annotations

from abc import abstractmethod

import numpy as np

from .riemannian import RiemannianManifold
from .validation import (
    as_float_array,
    check_batch_shapes,
    check_finite,
    check_finite_result,
    check_int,
    check_shape,
)

__all__ = ["ConstantCurvatureQuadric"]


def ratio(num, den):
    """``num / den`` where ``den > 0`` and ``1`` where ``den == 0`` (a sinc-like limit)."""
    pos = den > 0
    return np.where(pos, num / np.where(pos, den, 1.0), 1.0)


class ConstantCurvatureQuadric(RiemannianManifold):
    """Space ``{x in R^{n+1} : <x, x>_form = 1 / K}`` with the induced metric.

    Subclasses set ``sectional_curvature`` (``K``) and implement ``form``,
    ``_on_manifold`` and ``_tangent_ok`` (membership and tangency tests),
    ``_tangent`` (validated, projected tangent and
    its squared norm), ``_exp(x, v, vv)``, ``_log(x, y)`` and ``_transport(x, y, u)``.

    Curvature convention: ``R(u, v) w = nabla_u nabla_v w - nabla_v nabla_u w -
    nabla_[u,v] w``; for constant curvature ``R(u, v) w = K (<v, w> u - <u, w> v)``.
    """

    is_symmetric = True
    supports_batch = True
    sectional_curvature = 1.0

    def __init__(self, n: int):
        self.dim = check_int(n, f"{type(self).__name__}: n", minimum=1)
        self.point_shape = (self.dim + 1,)

    def __repr__(self) -> str:
        return f"{self.name}({self.dim})"

    @staticmethod
    @abstractmethod
    def form(a, b):
        """The ambient bilinear form over the last axis (broadcasting)."""

    def accurate_form(self, a, b):
        """The form where cancellation matters (the symmetry); default :meth:`form`."""
        return self.form(a, b)

    @abstractmethod
    def _on_manifold(self, arr, tol):
        """Per batch entry: does ``arr`` (right shape) lie on the quadric within ``tol``?"""

    @abstractmethod
    def _tangent_ok(self, x, v, tol):
        """Per batch entry: is ``v`` tangent at ``x`` within ``tol``?"""

    @abstractmethod
    def _tangent(self, x, v, name: str = "tangent"): ...

    @abstractmethod
    def _exp(self, x, v, vv): ...

    @abstractmethod
    def _log(self, x, y): ...

    @abstractmethod
    def _project(self, x):
        """Put points computed by a closed form back on the quadric (round-off drift)."""

    @abstractmethod
    def _transport(self, x, y, u):
        """Closed-form transport of the tangent ``u`` from ``x`` to ``y`` (validated inputs)."""

    def belongs(self, point, atol: float | None = None):
        """Whether ``point`` lies on the quadric within ``atol`` (default ``self.atol``)."""
        arr = np.asarray(point, dtype=float)
        if arr.ndim < 1 or arr.shape[-1:] != self.point_shape:
            return False
        return self._on_manifold(arr, self.atol if atol is None else atol)

    def is_tangent(self, point, vector, atol: float | None = None):
        """Whether ``vector`` is tangent at ``point`` within ``atol`` (default ``self.atol``)."""
        v = np.asarray(vector, dtype=float)
        if v.ndim < 1 or v.shape[-1:] != self.point_shape:
            return False
        return self._tangent_ok(
            np.asarray(point, dtype=float), v, self.atol if atol is None else atol
        )

    def _point(self, point, name: str) -> np.ndarray:
        """Validated point: one fused membership test, the full diagnosis only on failure."""
        label = f"{self.name}: {name}"
        arr = as_float_array(point, label)
        check_shape(arr, self.point_shape, label)
        if not self._on_manifold(arr, self.atol).all():
            return self.check_point(arr, name)
        return arr

    def _vector(self, vector, name: str) -> np.ndarray:
        label = f"{self.name}: {name}"
        arr = as_float_array(vector, label)
        check_shape(arr, self.point_shape, label)
        return check_finite(arr, label)

    def _batch(self, **arrays) -> None:
        """Raise a named error if the batch axes of ``arrays`` do not broadcast."""
        check_batch_shapes(1, self.name, **arrays)

    def exp(self, point, tangent):
        """Exponential map in closed form (accurate for tiny vectors).

        Parameters
        ----------
        point : array, shape ``(..., n + 1)``
        tangent : array, shape ``(..., n + 1)``, tangent at ``point`` (broadcast)

        Returns
        -------
        array, shape ``(..., n + 1)``
        """
        x = self._point(point, "point")
        v = self._vector(tangent, "tangent")
        self._batch(point=x, tangent=v)
        v, vv = self._tangent(x, v)
        with np.errstate(over="ignore", invalid="ignore"):
            out = self._exp(x, v, vv)
        check_finite_result(
            out,
            f"{self.name}: tangent",
            f"too large for exp in float64 (largest entry {np.max(np.abs(v)):.4g})",
        )
        return self._project(out)

    def log(self, point, other):
        """Logarithm map in closed form, accurate for nearby points.

        Parameters
        ----------
        point, other : array, shape ``(..., n + 1)``

        Returns
        -------
        array, shape ``(..., n + 1)``, tangent at ``point`` of norm ``dist(point, other)``
        """
        x, y = self._point(point, "point"), self._point(other, "other")
        self._batch(point=x, other=y)
        return self._log(x, y)

    def inner(self, point, u, v):
        """The ambient form restricted to tangent vectors, shape ``(...)``."""
        x = self._point(point, "point")
        u, v = self._vector(u, "u"), self._vector(v, "v")
        self._batch(point=x, u=u, v=v)
        return self.form(u, v)

    def parallel_transport(self, point, end, tangent):
        """Exact transport of ``tangent`` along the geodesic ``point -> end`` (closed form).

        Parameters
        ----------
        point, end : array, shape ``(..., n + 1)``
        tangent : array, shape ``(..., n + 1)``, tangent at ``point``

        Returns
        -------
        array, shape ``(..., n + 1)``, tangent at ``end``
        """
        x = self._point(point, "point")
        y = self._point(end, "end")
        u = self._vector(tangent, "tangent")
        self._batch(point=x, end=y, tangent=u)
        u, _ = self._tangent(x, u)
        return self._transport(x, y, u)

    def squared_dist(self, a, b):
        """Squared geodesic distance."""
        return self.dist(a, b) ** 2

    def symmetry(self, center, point):
        """Geodesic symmetry ``s_m(z) = 2 K <m, z> m - z``.

        Computed as ``2 <m, z> / <m, m> m - z``, the reflection through the line of
        ``m``: an exact linear involution that preserves the quadric, so it is not
        projected (projecting would break ``s_m o s_m = id`` by more than it gains).
        """
        m = self._point(center, "center")
        z = self._point(point, "point")
        self._batch(center=m, point=z)
        # 2 <m, z> / <m, m> = 2 K <m, z> on the quadric; dividing by the computed
        # <m, m> makes the map an exact linear involution even when m is off the
        # quadric by round-off (which far from the origin is amplified by |<m, z>|).
        form = self.accurate_form
        out = (2.0 * form(m, z) / form(m, m))[..., None] * m - z
        return check_finite_result(out, f"{self.name}: point", "too far from center for float64")

    def curvature(self, point, u, v, w):
        """``R(u, v) w = K (<v, w> u - <u, w> v)`` (convention in the class doc)."""
        self._point(point, "point")
        u, v, w = (self._vector(a, n) for a, n in ((u, "u"), (v, "v"), (w, "w")))
        self._batch(u=u, v=v, w=w)
        k = self.sectional_curvature
        return k * (self.form(v, w)[..., None] * u - self.form(u, w)[..., None] * v)

    def curvature_derivative(self, point, x, u, v, w):
        """``(nabla_x R)(u, v) w = 0``: a constant-curvature space is symmetric."""
        arrays = [self._point(point, "point")]
        arrays += [self._vector(a, n) for a, n in ((x, "x"), (u, "u"), (v, "v"), (w, "w"))]
        return np.zeros(np.broadcast_shapes(*(a.shape for a in arrays)))
