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
from .metric_field import MetricField
from .poincare_half_plane import PoincareHalfPlane
from .riemannian import RiemannianManifold
from .spd import SPDMatrices
from .warped_surface import WarpedSurface

__all__ = [
    "Connection",
    "RiemannianManifold",
    "Euclidean",
    "Hypersphere",
    "Hyperbolic",
    "minkowski_inner",
    "SPDMatrices",
    "MetricField",
    "PoincareHalfPlane",
    "WarpedSurface",
    "ResidualAugmented",
    "ResidualTangent",
    "ConvergenceError",
    "ConvergenceWarning",
    "CutLocusError",
    "ManifoldError",
    "NotOnManifoldError",
    "NotTangentError",
]
