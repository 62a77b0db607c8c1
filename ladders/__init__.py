"""Generic algorithms on spaces with an affine connection.

Everything here uses only the connection API of :mod:`manifolds` (``exp``,
``log``, ``midpoint``, ``symmetry``, ``transvection``), so it runs unchanged on
every space: the pole ladder and Schild's ladder (one rung driver), the fanning
scheme, the weighted Fréchet (Karcher) mean, the paper's symmetry errors, log-log
convergence studies and the ``nabla R`` expansion of transvections; and the one reader
of the input tables (:func:`read_table`: CSV files refused, in one line naming the file,
the line and the column, where they cannot be used).

The paper's application (cohorts, mesh I/O, area strain, the Section 3 study,
its report and the ``symladders`` command line) lives in :mod:`ladders.study`,
which this package never imports.
"""

from .convergence import ConvergenceCurve, ladder_convergence, loglog_slope
from .fanning import (
    FanningResult,
    MomentumFlowSpace,
    NoMomentumFlowError,
    fanning_scheme,
    fanning_transport,
)
from .frechet_mean import FrechetMeanResult, frechet_mean
from .pole_ladder import pole_ladder
from .rungs import LadderTrajectory
from .schild_ladder import schild_ladder
from .symmetry_errors import (
    SymmetryErrors,
    centrality_error,
    involutivity_error,
    midpoint_distance,
    symmetry_errors,
    transvectivity_error,
)
from .tables import Column, Table, TableDict, TableError, locate, read_table
from .transvection_expansion import NABLA_R_COEFFICIENTS, transvection_expansion

__all__ = [
    "LadderTrajectory",
    "pole_ladder",
    "schild_ladder",
    "SymmetryErrors",
    "centrality_error",
    "involutivity_error",
    "midpoint_distance",
    "symmetry_errors",
    "transvectivity_error",
    "ConvergenceCurve",
    "ladder_convergence",
    "loglog_slope",
    "FanningResult",
    "MomentumFlowSpace",
    "NoMomentumFlowError",
    "fanning_scheme",
    "fanning_transport",
    "FrechetMeanResult",
    "frechet_mean",
    "NABLA_R_COEFFICIENTS",
    "transvection_expansion",
    "Column",
    "Table",
    "TableError",
    "TableDict",
    "locate",
    "read_table",
]
