"""Spaces with an affine connection, known through ``exp`` and ``log``.

The abstract classes (:class:`Connection`, :class:`RiemannianManifold`) derive the
geodesic, midpoint, geodesic symmetry and transvection from ``exp`` and ``log``.
Concrete spaces: :class:`Euclidean`, the closed-form symmetric spaces
(:class:`Hypersphere`, :class:`Hyperbolic`, :class:`SPDMatrices`), metric-matrix
fields (:class:`MetricField`, :class:`PoincareHalfPlane`, :class:`WarpedSurface`),
the LDDMM and SVF landmark spaces (subpackage :mod:`manifolds.lddmm`) and the
residual-augmented space :class:`ResidualAugmented`. Numerical methods live in
:mod:`manifolds.numerics`; the contract tests for a new space in
:mod:`manifolds.testing`.
"""

from .connection import Connection
from .data_terms import CurrentDistance, DataTerm, SquaredDistance, VarifoldDistance
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
from .lddmm import (
    GaussianKernel,
    LandmarkTangent,
    LDDMMLandmarks,
    RegistrationResult,
    RegistrationSettings,
    StationaryFlow,
    SVFLandmarks,
    register,
    register_svf,
)
from .metric_field import MetricField
from .poincare_half_plane import PoincareHalfPlane
from .point_distance import DISTANCES, point_distance
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
    "LandmarkTangent",
    "RegistrationResult",
    "RegistrationSettings",
    "DataTerm",
    "SquaredDistance",
    "CurrentDistance",
    "VarifoldDistance",
    "register",
    "SVFLandmarks",
    "StationaryFlow",
    "register_svf",
    "point_distance",
    "DISTANCES",
    "ResidualAugmented",
    "ResidualTangent",
    "ConvergenceError",
    "ConvergenceWarning",
    "CutLocusError",
    "ManifoldError",
    "NotOnManifoldError",
    "NotTangentError",
]
