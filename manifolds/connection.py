"""Abstract manifold with an affine connection.

A concrete space implements four things: :meth:`Connection.exp`,
:meth:`Connection.log`, :meth:`Connection.random_point` and
:meth:`Connection.random_tangent` (plus the attribute ``point_shape``).
Every other operation -- geodesic, midpoint, geodesic symmetry, transvection --
has a default derived from ``exp`` and ``log`` and may be overridden where a
closed form exists.

Notation follows the paper (Section 2.2): the geodesic symmetry at ``M`` is
``s_M(S) = Exp_M(-Log_M(S))`` and a transvection is ``s_M o s_A``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable

import numpy as np

from .errors import NotOnManifoldError, NotTangentError
from .validation import check_array

__all__ = ["Connection"]


class Connection(ABC):
    """A manifold equipped with an affine connection, known through ``exp`` and ``log``.

    Attributes
    ----------
    point_shape : tuple of int
        Shape of a single point, e.g. ``(n + 1,)`` for the sphere ``S^n`` embedded
        in ``R^{n+1}``, ``(n, n)`` for SPD matrices, ``(k, d)`` for landmarks.
    is_symmetric : bool
        True when the connection is (locally) symmetric, i.e. ``nabla R = 0``:
        the pole ladder is then exact (a transvection).
    supports_batch : bool
        True when ``exp``/``log``/... accept leading batch axes and broadcast.
    atol : float
        Default absolute tolerance of the membership checks.
    """

    point_shape: tuple[int, ...] = ()
    is_symmetric: bool = False
    supports_batch: bool = False
    atol: float = 1e-8

    # ------------------------------------------------------------------ required
    @abstractmethod
    def exp(self, point, tangent):
        """Exponential map ``Exp_point(tangent)``.

        Parameters
        ----------
        point : array, shape ``(..., *point_shape)``
        tangent : array, same shape as ``point`` (or broadcastable)

        Returns
        -------
        array, shape ``(..., *point_shape)``
        """

    @abstractmethod
    def log(self, point, other):
        """Logarithm map ``Log_point(other)``, the inverse of ``exp`` near ``point``.

        Parameters
        ----------
        point, other : array, shape ``(..., *point_shape)``

        Returns
        -------
        tangent : array at ``point``
        """

    @abstractmethod
    def random_point(self, rng: np.random.Generator, n_samples: int | None = None):
        """Draw a point (or ``n_samples`` points) with the generator ``rng``."""

    @abstractmethod
    def random_tangent(self, point, rng: np.random.Generator, scale: float = 1.0):
        """Draw a tangent vector at ``point`` of typical size ``scale``."""

    # ------------------------------------------------------------------ checks
    @property
    def name(self) -> str:
        """Class name used in error messages."""
        return type(self).__name__

    def check_point(self, point, name: str = "point", atol: float | None = None):
        """Return ``point`` as a float64 array or raise naming ``name``.

        Checks the trailing shape, finiteness and, via :meth:`belongs`,
        membership within ``atol``.
        """
        arr = check_array(point, self.point_shape, f"{self.name}: {name}")
        tol = self.atol if atol is None else atol
        ok = np.asarray(self.belongs(arr, atol=tol))
        if not ok.all():
            where = "" if ok.ndim == 0 else f" at batch index {np.argwhere(~ok)[0].tolist()}"
            raise NotOnManifoldError(
                f"{self.name}: {name} does not lie on the manifold{where} "
                f"(tolerance {tol:g}){self._belongs_hint(arr)}"
            )
        return arr

    def check_tangent(self, point, tangent, name: str = "tangent", atol: float | None = None):
        """Return ``tangent`` as a float64 array or raise naming ``name``."""
        arr = check_array(tangent, self.point_shape, f"{self.name}: {name}")
        tol = self.atol if atol is None else atol
        ok = np.asarray(self.is_tangent(point, arr, atol=tol))
        if not ok.all():
            raise NotTangentError(
                f"{self.name}: {name} is not tangent at the given point (tolerance {tol:g})"
            )
        return arr

    def _belongs_hint(self, point) -> str:
        return ""

    def _finite_with_point_shape(self, arr):
        """Per batch entry: trailing shape ``point_shape`` and finite entries."""
        arr = np.asarray(arr, dtype=float)
        nd = len(self.point_shape)
        if arr.ndim < nd or arr.shape[arr.ndim - nd :] != tuple(self.point_shape):
            return False
        return np.isfinite(arr).all(axis=tuple(range(arr.ndim - nd, arr.ndim)))

    def belongs(self, point, atol: float | None = None):
        """Whether ``point`` lies on the manifold (default: right shape, finite)."""
        return self._finite_with_point_shape(point)

    def is_tangent(self, point, vector, atol: float | None = None):
        """Whether ``vector`` is tangent at ``point`` (default: right shape, finite).

        The default never asks :meth:`belongs` about the vector: on an open subset
        of ``R^n`` (e.g. the half-plane) every finite vector is tangent, also one
        that points out of the subset.
        """
        return self._finite_with_point_shape(vector)

    # ------------------------------------------------------------------ derived
    def geodesic(self, a, b) -> Callable[[float | np.ndarray], np.ndarray]:
        """Geodesic from ``a`` to ``b`` as a callable ``t -> Exp_a(t Log_a(b))``.

        ``t`` may be a scalar or a 1-D array of times; for an array the result
        has the times as a new leading axis.
        """
        v = self.log(a, b)

        def path(t):
            t = np.asarray(t, dtype=float)
            if t.ndim == 0:
                return self.exp(a, float(t) * v)
            return np.stack([self.exp(a, float(ti) * v) for ti in t])

        return path

    def midpoint(self, a, b):
        """Midpoint ``Exp_a(1/2 Log_a(b))`` shot from ``a`` (paper, Section 2.3)."""
        return self.exp(a, 0.5 * self.log(a, b))

    def symmetry(self, center, point):
        """Geodesic symmetry ``s_center(point) = Exp_center(-Log_center(point))``."""
        return self.exp(center, -self.log(center, point))

    def log_near(self, point, other, start):
        """``Log_point(other)`` computed from the guess ``start``, a tangent at ``point``.

        A space whose ``log`` is an iterative solve (a registration, a shooting)
        uses ``start`` as the solver's initial value; the default ignores it and
        calls :meth:`log`. Generic algorithms pass a guess they know to be close
        (e.g. a symmetric counterpart, ``-Log_M(S')`` for ``Log_M(s_M(S'))``).
        """
        return self.log(point, other)

    def symmetry_near(self, center, point, start):
        """``s_center(point)`` with ``Log_center(point)`` computed from the guess ``start``.

        The default is :meth:`symmetry` (closed forms keep theirs); spaces with an
        iterative ``log`` return ``Exp_center(-log_near(center, point, start))``.
        """
        return self.symmetry(center, point)

    def transvection(self, m, a) -> Callable:
        """Transvection ``s_m o s_a`` as a callable on points.

        In a symmetric space ``s_m o s_a`` translates along the geodesic through
        ``a`` and ``m`` by twice their distance, and its differential is the
        parallel transport along that geodesic.
        """

        def tau(point):
            return self.symmetry(m, self.symmetry(a, point))

        return tau

    # ------------------------------------------------------------------ optional
    def parallel_transport(self, point, end, tangent):
        """Exact parallel transport of ``tangent`` from ``point`` to ``end`` along the geodesic.

        Approximations (pole ladder, Schild's ladder, fanning) live in :mod:`ladders`.
        """
        raise NotImplementedError(
            f"{self.name} has no exact parallel_transport; use a ladder from `ladders`"
        )

    def dist(self, a, b):
        """Geodesic distance (metric spaces only)."""
        raise NotImplementedError(f"{self.name} has no metric: dist is not available")

    def inner(self, point, u, v):
        """Inner product of tangent vectors (metric spaces only)."""
        raise NotImplementedError(f"{self.name} has no metric: inner is not available")

    def curvature(self, point, u, v, w):
        """Riemann curvature tensor ``R(u, v) w`` at ``point``."""
        raise NotImplementedError(f"{self.name} does not provide the curvature tensor")

    def curvature_derivative(self, point, x, u, v, w):
        """Covariant derivative ``(nabla_x R)(u, v) w`` at ``point``."""
        raise NotImplementedError(
            f"{self.name} does not provide the covariant derivative of the curvature"
        )

    # ------------------------------------------------------------------ helpers
    def __repr__(self) -> str:
        return f"{self.name}(point_shape={self.point_shape})"
