"""The flags of ``symladders study``: the cohort, the deformation model and the run."""

from __future__ import annotations

from .cli_types import existing_file, existing_folder, positive_float, positive_int
from .common_arguments import (
    RECOMMENDED_ALPHA2,
    add_alpha2,
    add_batch_arguments,
    add_output,
    add_seed,
)
from .plugin_arguments import deformation_list, registered_names
from .preparation_arguments import add_units_arguments, mesh_file

__all__ = [
    "add_study_arguments",
    "REGISTRATION_FLAGS",
    "DEFAULT_ALPHA2",
    "FULL_ALPHA2",
    "DEFAULT_SUBJECTS",
    "FULL_SUBJECTS",
    "DEFAULT_VERTICES",
]

FULL_ALPHA2 = (0.01, 0.1, 1.0, 10.0, 33.0, 100.0, 1089.0)
DEFAULT_ALPHA2 = FULL_ALPHA2
DEFAULT_SUBJECTS = 20
FULL_SUBJECTS = 138
DEFAULT_VERTICES = 1009


def add_study_arguments(p) -> None:
    """Add the flags of ``symladders study`` to the parser ``p``."""
    _add_input_arguments(p)
    add_units_arguments(  # the built-in cohort is in mm
        p,
        reference="the atlas's (taken to be in mm)",
        note=" (with --meshes or --cohort; the built-in cohort is in mm)",
        pose="accept subjects far from the atlas's pose (the study does not align them; "
        "symladders correspond does)",
    )
    _add_model_arguments(p)
    _add_run_arguments(p)


def _add_input_arguments(p) -> None:
    """Flags choosing the cohort and the output folder."""
    add_output(p, "symladders-output/study", "results folder")
    source = p.add_mutually_exclusive_group()
    source.add_argument(
        "--meshes",
        type=existing_folder,
        default=None,
        help="folder of meshes (atlas.<ext>, <subject>_ed.<ext>, <subject>_es.<ext>; "
        "PLY/OBJ/STL/OFF/VTK/VTU/VTP) instead of the built-in synthetic cohort",
    )
    source.add_argument(
        "--cohort",
        type=existing_file,
        default=None,
        metavar="TABLE",
        help="CSV table with the columns subject, ed, es (mesh paths relative to the table) "
        "instead of the built-in synthetic cohort",
    )
    p.add_argument(
        "--atlas",
        type=mesh_file,
        default=None,
        help="atlas mesh (with --meshes or --cohort); default: atlas.<ext> in the folder "
        "or next to the table",
    )
    p.add_argument(
        "--subjects",
        type=positive_int,
        default=None,
        help=f"number of subjects: {DEFAULT_SUBJECTS} of the built-in cohort ({FULL_SUBJECTS} with "
        "--full), or the first N of --meshes or --cohort (default: all of them; more than "
        "they hold is an error)",
    )
    p.add_argument(
        "--full",
        action="store_true",
        help=f"the paper's setting: {FULL_SUBJECTS} subjects and the 7-value alpha^2 sweep",
    )
    add_alpha2(
        p,
        None,
        "alpha^2 values of the registrations (eq. 3); default: the paper's sweep "
        f"{','.join(f'{a:g}' for a in DEFAULT_ALPHA2)} (its Table 1). Group statistics on the "
        f"transported motion ('symladders analyze') use one value, alpha^2 = "
        f"{RECOMMENDED_ALPHA2:g} (docs/population.md, 'Which to use when'): to transport "
        f"for them only, --alpha2 {RECOMMENDED_ALPHA2:g}",
    )
    p.add_argument(
        "--vertices",
        type=positive_int,
        default=DEFAULT_VERTICES,
        help="vertices of the built-in meshes, rounded to their grid of 1 + n_longitude x "
        "n_latitude vertices (the count used is printed)",
    )
    add_seed(p)


#: Flags that set a field of the study's registration settings (flag dest -> field).
REGISTRATION_FLAGS = (
    "sigma",
    "control_points",
    "control_point_spacing",
    "optimize_control_points",
    "integrator",
    "n_steps",
    "solver",
    "stopping",
    "shape_tol",
    "ftol",
    "max_iter",
    "kernel_backend",
)


def _add_model_arguments(p) -> None:
    """Flags of the deformation model, the registration and the transports.

    The registration flags default to the study's :data:`DEFAULT_REGISTRATION`
    (their help shows its values); a flag left out keeps the default's field.
    """
    from manifolds.numerics.solvers import SOLVERS

    from ..running.pipeline import DEFAULT_REGISTRATION as d

    p.add_argument(
        "--sigma", type=positive_float, default=d.sigma, help="kernel width (mesh units, mm)"
    )
    p.add_argument(
        "--control-points",
        choices=("vertices", "grid", "finegrid", "dense"),
        default=d.control_points,
        help="control points: a subset of the atlas's vertices (farthest-point sample, spacing "
        "0.7 sigma), the same vertices on every shape; a grid of spacing sigma or sigma/2 "
        "over each shape's bounding box; or every vertex",
    )
    p.add_argument(
        "--control-point-spacing",
        type=positive_float,
        default=d.control_point_spacing,
        metavar="MM",
        help="spacing of the 'vertices', 'grid' and 'finegrid' control points (mesh units); "
        "default: the policy's multiple of sigma",
    )
    p.add_argument(
        "--optimize-control-points",
        action="store_true",
        help="optimise the control points with the momenta (eq. 3), starting from the "
        "--control-points policy",
    )
    p.add_argument(
        "--distance",
        choices=("rms", "frobenius", "mean"),
        default="rms",
        help="unit of the errors: per-vertex RMS (the paper's mm), Frobenius or mean distance",
    )
    p.add_argument(
        "--integrator",
        choices=("euler", "rk2", "rk4"),
        default=d.integrator,
        help="time integrator of the flows, used by the registrations, the shooting and the "
        "fanning scheme",
    )
    p.add_argument(
        "--n-steps", type=positive_int, default=d.n_steps, help="time steps of the shooting"
    )
    p.add_argument(
        "--solver",
        choices=sorted(SOLVERS),
        default=d.solver,
        help="optimiser of the registrations (docs/lddmm.md, 'Solvers')",
    )
    p.add_argument(
        "--stopping",
        choices=("shape", "objective"),
        default=d.stopping,
        help="stopping rule: 'shape' stops when the deformed template no longer moves by "
        "more than --shape-tol (per-vertex RMS, mesh units); 'objective' on the relative "
        "decrease of the objective (--ftol)",
    )
    p.add_argument(
        "--shape-tol",
        type=positive_float,
        default=d.shape_tol,
        help="tolerance of the 'shape' stopping rule (mesh units, per-vertex RMS)",
    )
    p.add_argument(
        "--ftol",
        type=positive_float,
        default=d.ftol,
        help="tolerance of the 'objective' stopping rule (relative decrease of the objective)",
    )
    p.add_argument(
        "--max-iter",
        type=positive_int,
        default=d.max_iter,
        help="iteration limit of each registration",
    )
    p.add_argument(
        "--warm-starts",
        action="store_true",
        help="start Log_M(s_M(S')) from -Log_M(S') (docs/developer_notes.md, 'Warm starts')",
    )
    p.add_argument(
        "--fanning-steps", type=positive_int, default=10, help="steps of the fanning scheme"
    )
    p.add_argument(
        "--deformation",
        type=deformation_list,
        default="lddmm",
        metavar="NAME[,NAME...]",
        help="deformation model, a registered name (" + ", ".join(registered_names()) + "; "
        "lddmm: LDDMM geodesics, svf: stationary velocity fields, docs/svf.md), or several "
        "comma-separated (each run into OUTPUT/NAME, compared with the first in "
        "OUTPUT/comparison.md); 'both' is lddmm,svf. A model of your own: --plugin "
        "(docs/add_your_own_space.md)",
    )
    p.add_argument(
        "--kernel-backend",
        choices=("auto", "numpy", "numba"),
        default=d.kernel_backend,
        help="kernel sums: 'auto' uses numba when it imports, else numpy (the reference)",
    )


def _add_run_arguments(p) -> None:
    """Flags of the execution: kernels, parallelism, progress, mesh outputs."""
    add_batch_arguments(p)
    p.add_argument(
        "--no-meshes",
        action="store_true",
        help="do not write the .vtu meshes (M, s_M(S'), T' and strain maps) under OUTPUT/meshes",
    )
