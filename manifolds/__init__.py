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
from .hyperbolic import Hyperbolic, minkowski_inner
from .hypersphere import Hypersphere
from .residual import ResidualAugmented, ResidualTangent
from .riemannian import RiemannianManifold
from .spd import SPDMatrices

__all__ = [
    "Connection",
    "RiemannianManifold",
    "Euclidean",
    "Hypersphere",
    "Hyperbolic",
    "minkowski_inner",
    "SPDMatrices",
    "ResidualAugmented",
    "ResidualTangent",
    "ConvergenceError",
    "ConvergenceWarning",
    "CutLocusError",
    "ManifoldError",
    "NotOnManifoldError",
    "NotTangentError",
]
