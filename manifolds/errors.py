"""Exceptions and warnings raised by spaces and numerical methods."""

from __future__ import annotations

__all__ = [
    "ManifoldError",
    "NotOnManifoldError",
    "NotTangentError",
    "CutLocusError",
    "ConvergenceError",
    "ConvergenceWarning",
]


class ManifoldError(ValueError):
    """Base class for invalid input given to a space (shape, NaN, domain)."""


class NotOnManifoldError(ManifoldError):
    """A point does not belong to the manifold within the tolerance used."""


class NotTangentError(ManifoldError):
    """A vector is not tangent to the manifold at the given point."""


class CutLocusError(ManifoldError):
    """``log`` was asked at (or numerically too close to) a cut point."""


class ConvergenceError(RuntimeError):
    """An iterative method (shooting, registration, transport) did not converge."""


class ConvergenceWarning(UserWarning):
    """An iterative method stopped before meeting its convergence criterion."""
