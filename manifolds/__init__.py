"""Spaces with an affine connection, known through ``exp`` and ``log``."""

from .connection import Connection
from .errors import (
    ConvergenceError,
    ConvergenceWarning,
    CutLocusError,
    ManifoldError,
    NotOnManifoldError,
    NotTangentError,
)
from .euclidean import Euclidean
from .riemannian import RiemannianManifold

__all__ = [
    "Connection",
    "RiemannianManifold",
    "Euclidean",
    "ConvergenceError",
    "ConvergenceWarning",
    "CutLocusError",
    "ManifoldError",
    "NotOnManifoldError",
    "NotTangentError",
]
