"""Tangent vectors of the LDDMM landmark space that carry their own control points.

When the registration optimises the control points with the momenta (paper,
eq. 3 over ``c`` and ``mu``), ``Log_T(S)`` is the pair ``(c, mu)``: the
momenta only make sense at the control points they were optimised with.
:class:`LandmarkTangent` keeps the two together. Its linear operations act on
the momenta at fixed control points, which is what the generic algorithms
(midpoint, symmetry, ladders) need: ``-u``, ``t * u``, ``u / t`` and ``u + w``,
``u - w`` for tangents with identical control points.
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Real

import numpy as np

from ..errors import ManifoldError

__all__ = ["LandmarkTangent"]

_SCALARS = (Real, np.floating, np.integer)


@dataclass(frozen=True)
class LandmarkTangent:
    """Momenta ``mu`` at control points ``c``: a tangent vector of :class:`LDDMMLandmarks`.

    Attributes
    ----------
    control_points : array, shape ``(n_cp, d)``
    momenta : array, shape ``(n_cp, d)``
    """

    control_points: np.ndarray
    momenta: np.ndarray

    # Make numpy defer to these operators (``array * u`` raises instead of
    # building an object array).
    __array_ufunc__ = None

    def __post_init__(self):
        c = np.asarray(self.control_points, dtype=float)
        mu = np.asarray(self.momenta, dtype=float)
        if c.ndim != 2 or mu.shape != c.shape:
            raise ManifoldError(
                "LandmarkTangent: control_points and momenta must have the same shape "
                f"(n_cp, d), got {c.shape} and {mu.shape}"
            )
        object.__setattr__(self, "control_points", c)
        object.__setattr__(self, "momenta", mu)

    @property
    def shape(self) -> tuple:
        """Shape ``(n_cp, d)`` of the momenta."""
        return self.momenta.shape

    def _same_points(self, other: LandmarkTangent, op: str) -> None:
        if other.control_points is self.control_points:
            return
        if other.control_points.shape != self.control_points.shape or not np.array_equal(
            other.control_points, self.control_points
        ):
            raise ManifoldError(
                f"LandmarkTangent: cannot {op} tangents at different control points "
                f"(shapes {self.control_points.shape} and {other.control_points.shape}); "
                "express one at the other's control points first"
            )

    def with_momenta(self, momenta) -> LandmarkTangent:
        """The tangent ``momenta`` at the same control points."""
        return LandmarkTangent(self.control_points, momenta)

    def __neg__(self) -> LandmarkTangent:
        return self.with_momenta(-self.momenta)

    def __add__(self, other) -> LandmarkTangent:
        if not isinstance(other, LandmarkTangent):
            return NotImplemented
        self._same_points(other, "add")
        return self.with_momenta(self.momenta + other.momenta)

    def __sub__(self, other) -> LandmarkTangent:
        if not isinstance(other, LandmarkTangent):
            return NotImplemented
        self._same_points(other, "subtract")
        return self.with_momenta(self.momenta - other.momenta)

    def __mul__(self, scalar) -> LandmarkTangent:
        if not isinstance(scalar, _SCALARS):
            return NotImplemented
        return self.with_momenta(scalar * self.momenta)

    __rmul__ = __mul__

    def __truediv__(self, scalar) -> LandmarkTangent:
        if not isinstance(scalar, _SCALARS):
            return NotImplemented
        return self.with_momenta(self.momenta / scalar)
