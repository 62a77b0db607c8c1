"""Residual-augmented space: shapes decomposed as ``S = phi_1(T) + delta`` (paper, eq. 4).

When the logarithm of a space is inexact -- LDDMM registration is regularised
and never matches exactly -- the registration residual ``delta = S - Exp_T(Log_T S)``
can be carried along as a Euclidean component of the tangent vector. With it:

* ``exp_T((v, delta)) = Exp_T(v) + delta``;
* ``log_T(S) = (Log_T S, S - Exp_T(Log_T S))``, so ``exp_T(log_T S) = S``;
* the midpoint is ``Exp_T(1/2 Log_T S) + 1/2 delta`` (eq. 5);
* the symmetry is ``s_T(S) = Exp_T(-Log_T S) - delta`` (eq. 6).

The last two are not special code: they are the generic
:meth:`~manifolds.Connection.midpoint` and :meth:`~manifolds.Connection.symmetry`
applied to this ``exp`` and ``log``. With ``use_residuals=False`` the residual is
dropped (``delta = 0``) and the space behaves as the wrapped one, so both
variants of the paper run through the same generic ladders and estimators.
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Real

import numpy as np

from .connection import Connection
from .validation import check_array

__all__ = ["ResidualTangent", "ResidualAugmented"]


@dataclass(frozen=True)
class ResidualTangent:
    """Tangent vector ``(v, delta)`` of a :class:`ResidualAugmented` space.

    Supports the linear operations used by generic algorithms: ``-u``,
    ``u + w``, ``u - w``, ``c * u``, ``u * c`` and ``u / c``.

    Attributes
    ----------
    tangent : tangent vector of the wrapped space (e.g. LDDMM momenta)
    residual : array, shape ``point_shape``
        The displacement ``delta`` between corresponding points.
    """

    tangent: np.ndarray
    residual: np.ndarray

    # Make numpy defer to these operators (``array * u`` raises instead of
    # building an object array).
    __array_ufunc__ = None

    def __neg__(self) -> ResidualTangent:
        return ResidualTangent(-self.tangent, -self.residual)

    def __add__(self, other: ResidualTangent) -> ResidualTangent:
        if not isinstance(other, ResidualTangent):
            return NotImplemented
        return ResidualTangent(self.tangent + other.tangent, self.residual + other.residual)

    def __sub__(self, other: ResidualTangent) -> ResidualTangent:
        if not isinstance(other, ResidualTangent):
            return NotImplemented
        return ResidualTangent(self.tangent - other.tangent, self.residual - other.residual)

    def __mul__(self, scalar) -> ResidualTangent:
        if not isinstance(scalar, Real | np.floating | np.integer):
            return NotImplemented
        return ResidualTangent(scalar * self.tangent, scalar * self.residual)

    __rmul__ = __mul__

    def __truediv__(self, scalar) -> ResidualTangent:
        if not isinstance(scalar, Real | np.floating | np.integer):
            return NotImplemented
        return ResidualTangent(self.tangent / scalar, self.residual / scalar)


class ResidualAugmented(Connection):
    """A space whose points carry the residual of an inexact ``log`` (paper, Section 2.3).

    Parameters
    ----------
    base : Connection
        The wrapped space (typically :class:`manifolds.LDDMMLandmarks`). If it
        has a method ``log_with_residual(point, other) -> (tangent, residual)``
        it is used (so the residual comes from the same registration);
        otherwise the residual is ``other - base.exp(point, base.log(point, other))``.
    use_residuals : bool, default True
        If False, residuals are set to zero: the space is then the wrapped space
        with tangents written as ``ResidualTangent(v, 0)``.

    Notes
    -----
    For the Euclidean point-distribution model and any ``log`` that shrinks
    the displacement (the ``alpha -> infinity`` limit of LDDMM, where the
    momenta vanish), ``delta -> S - T`` and the symmetry tends to ``2T - S``.
    """

    def __init__(self, base: Connection, use_residuals: bool = True):
        if not isinstance(base, Connection):
            raise TypeError(f"base: expected a manifolds.Connection, got {type(base).__name__}")
        self.base = base
        self.use_residuals = bool(use_residuals)
        self.point_shape = tuple(base.point_shape)
        self.is_symmetric = base.is_symmetric
        self.supports_batch = False
        self.atol = base.atol

    def __repr__(self) -> str:
        return f"ResidualAugmented({self.base!r}, use_residuals={self.use_residuals})"

    def _as_tangent(self, tangent, name: str = "tangent") -> ResidualTangent:
        if isinstance(tangent, ResidualTangent):
            residual = check_array(
                tangent.residual, self.point_shape, f"{self.name}: {name}.residual"
            )
            return ResidualTangent(tangent.tangent, residual)
        # A bare tangent of the wrapped space: zero residual.
        return ResidualTangent(tangent, np.zeros(self.point_shape))

    def exp(self, point, tangent):
        """``Exp_T((v, delta)) = Exp_T(v) + delta`` (eq. 4).

        Parameters
        ----------
        point : array, shape ``point_shape``
        tangent : ResidualTangent, or a bare tangent of the wrapped space (``delta = 0``)
        """
        t = self._as_tangent(tangent)
        return self.base.exp(point, t.tangent) + t.residual

    def log(self, point, other) -> ResidualTangent:
        """``Log_T(S) = (v, delta)`` with ``delta = S - Exp_T(v)`` (zero if residuals are off)."""
        other = check_array(other, self.point_shape, f"{self.name}: other")
        tangent, residual = self.log_with_residual(point, other)
        if not self.use_residuals:
            residual = np.zeros_like(residual)
        return ResidualTangent(tangent, residual)

    def log_near(self, point, other, start) -> ResidualTangent:
        """``Log_T(S)`` with the wrapped space's ``log`` started from ``start``'s tangent part.

        The residual is that of the warm-started ``log`` (zero if residuals are off).
        """
        other = check_array(other, self.point_shape, f"{self.name}: other")
        guess = self._as_tangent(start, "start").tangent
        tangent = self.base.log_near(point, other, guess)
        if not self.use_residuals:
            return ResidualTangent(tangent, np.zeros(self.point_shape))
        residual = np.asarray(other, dtype=float) - self.base.exp(point, tangent)
        return ResidualTangent(tangent, residual)

    def symmetry_near(self, center, point, start):
        """``s_M(S) = Exp_M(-Log_M S) - delta`` (eq. 6) with ``Log_M`` started from ``start``."""
        return self.exp(center, -self.log_near(center, point, start))

    def log_with_residual(self, point, other):
        """Tangent of the wrapped space and the residual, from a single ``log``."""
        hook = getattr(self.base, "log_with_residual", None)
        if hook is not None:
            tangent, residual = hook(point, other)
            return tangent, np.asarray(residual, dtype=float)
        tangent = self.base.log(point, other)
        return tangent, np.asarray(other, dtype=float) - self.base.exp(point, tangent)

    def random_point(self, rng: np.random.Generator, n_samples: int | None = None):
        return self.base.random_point(rng, n_samples)

    def random_tangent(self, point, rng: np.random.Generator, scale: float = 1.0):
        tangent = self.base.random_tangent(point, rng, scale)
        if not self.use_residuals:
            return ResidualTangent(tangent, np.zeros(self.point_shape))
        return ResidualTangent(tangent, 0.1 * scale * rng.standard_normal(self.point_shape))

    def belongs(self, point, atol: float | None = None):
        return self.base.belongs(point, atol)

    def is_tangent(self, point, vector, atol: float | None = None):
        """Whether ``vector`` is a :class:`ResidualTangent` (or a bare tangent of the
        wrapped space) whose tangent part is tangent there and whose residual is a
        finite displacement of shape ``point_shape``."""
        if not isinstance(vector, ResidualTangent):
            return self.base.is_tangent(point, vector, atol)
        residual = np.asarray(vector.residual, dtype=float)
        residual_ok = residual.shape == self.point_shape and bool(np.isfinite(residual).all())
        return residual_ok and bool(np.all(self.base.is_tangent(point, vector.tangent, atol)))

    def inner(self, point, u, v):
        """Product metric: the wrapped space's inner product plus the Euclidean one on residuals."""
        u, v = self._as_tangent(u, "u"), self._as_tangent(v, "v")
        return self.base.inner(point, u.tangent, v.tangent) + float(np.sum(u.residual * v.residual))
