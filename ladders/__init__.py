"""Generic algorithms on spaces with an affine connection, and the paper's study.

Ladders and symmetry errors use only the connection API of :mod:`manifolds`
(``exp``, ``log``, ``midpoint``, ``symmetry``), so they run unchanged on every space.
"""

from ._rungs import LadderTrajectory
from .area_strain import area_strain, area_strain_error, cell_areas
from .benchmark_shapes import bent_ellipsoid
from .cohort import Cohort, CohortError, MeshFolderError, Subject
from .convergence import ConvergenceCurve, ladder_convergence, loglog_slope
from .fanning import FanningResult, fanning_scheme, fanning_transport
from .mesh_io import MESH_EXTENSIONS, read_cohort, read_mesh, write_cohort, write_mesh
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
from .synthetic_lv import SubjectParameters, SyntheticLVModel, make_synthetic_cohort
from .vtk_io import read_vtk, write_vtk

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
    "ConvergenceCurve",
    "ladder_convergence",
    "loglog_slope",
    "FanningResult",
    "fanning_scheme",
    "fanning_transport",
    "area_strain",
    "area_strain_error",
    "cell_areas",
    "bent_ellipsoid",
    "Cohort",
    "CohortError",
    "MeshFolderError",
    "Subject",
    "SubjectParameters",
    "SyntheticLVModel",
    "make_synthetic_cohort",
    "MESH_EXTENSIONS",
    "read_cohort",
    "read_mesh",
    "write_cohort",
    "write_mesh",
    "read_vtk",
    "write_vtk",
]
