"""Generic algorithms on spaces with an affine connection: ladders and symmetry errors."""

from ._rungs import LadderTrajectory
from .pole_ladder import pole_ladder
from .schild_ladder import schild_ladder
from .symmetry_errors import (
    SymmetryErrors,
    centrality_error,
    involutivity_error,
    l2_distance,
    midpoint_distance,
    symmetry_errors,
    transvectivity_error,
)

__all__ = [
    "LadderTrajectory",
    "pole_ladder",
    "schild_ladder",
    "SymmetryErrors",
    "centrality_error",
    "involutivity_error",
    "l2_distance",
    "midpoint_distance",
    "symmetry_errors",
    "transvectivity_error",
]
