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
from .kernels import GaussianKernel
from .lddmm import LDDMMLandmarks
from .metric_field import MetricField
from .poincare_half_plane import PoincareHalfPlane
from .registration import RegistrationResult, inverse_consistency, register
from .residual import ResidualAugmented, ResidualTangent
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
    "GaussianKernel",
    "LDDMMLandmarks",
    "RegistrationResult",
    "inverse_consistency",
    "register",
    "ResidualAugmented",
    "ResidualTangent",
    "ConvergenceError",
    "ConvergenceWarning",
    "CutLocusError",
    "ManifoldError",
    "NotOnManifoldError",
    "NotTangentError",
]
