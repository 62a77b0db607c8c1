"""``symladders atlas``: the LDDMM atlas (Karcher mean) of a cohort's end-diastolic meshes.

It parses the flags and calls
:func:`~ladders.study.preparation.atlas_run.build_atlas` (the start, the data term,
the estimate, the record and the interruption are there). It prints the objective per iteration, writes the atlas (format
from the extension of ``--output``) and next to it ``<name>.json``: convergence,
objectives, data term, start, units, settings, input files. Interrupted, it
writes the last iterate and its record (``"interrupted": true``) before it stops;
``--start`` that file continues. Exit status 1 when an ED mesh could not be read
(the atlas is estimated from the others), 2 on a usage error.
"""

from __future__ import annotations

import argparse
import inspect
import sys

from .cli_types import (
    DefaultsFormatter,
    UsageError,
    existing_folder,
    nonnegative_int,
    positive_float,
    positive_int,
)
from .common_arguments import add_batch_arguments, add_output, parallel_backend
from .preparation_arguments import (
    add_data_term_arguments,
    add_landmark_arguments,
    add_units_arguments,
    correspondence_settings,
    landmarks_argument,
    mesh_output_file,
    print_line,
    units_usage_error,
)

__all__ = ["add_atlas_parser", "run_atlas_command"]


def _library_default(name: str, build: bool = False):
    from ..preparation.atlas import estimate_atlas
    from ..preparation.atlas_run import build_atlas

    function = build_atlas if build else estimate_atlas
    return inspect.signature(function).parameters[name].default


def _coarse_default() -> float:
    from ..preparation import CorrespondenceSettings

    return CorrespondenceSettings().atlas_coarse_factor


def _coarse_factor(text: str) -> float:
    """A finite number ``>= 1`` (the data term's width over ``--sigma-w``)."""
    value = positive_float(text)
    if value < 1.0:
        raise argparse.ArgumentTypeError(
            f"expected a number >= 1 (1: no coarse stage), got {text!r}"
        )
    return value


def _subset_count(text: str) -> int | None:
    """``all`` (None) or a positive number of subjects."""
    return None if str(text).strip().lower() == "all" else positive_int(text)


def add_atlas_parser(sub) -> None:
    """Register the ``atlas`` subcommand on an argparse subparsers object."""
    from ..preparation.atlas_subset import SUBSET_RULES

    p = sub.add_parser(
        "atlas",
        help="estimate the LDDMM atlas (Karcher mean) of a cohort's ED meshes",
        description=(
            "Estimate the atlas of the ED meshes of a folder: register the start onto every "
            "subject, average the momenta, shoot, until an iteration moves the atlas by at "
            "most --tol. Meshes in correspondence are compared vertex to vertex; others by a "
            "surface (varifold) term, and the atlas keeps the start's triangulation. Writes "
            "OUTPUT and, next to it, <name>.json with the convergence flag and the objective "
            "per iteration."
        ),
        formatter_class=DefaultsFormatter,
    )
    p.add_argument(
        "--meshes",
        type=existing_folder,
        required=True,
        help="folder of meshes: <name>_ed.<ext> (or <name>/ed.<ext>), any vertex count; ES "
        "meshes and an atlas.<ext> there are not used",
    )
    add_output(
        p,
        "symladders-output/atlas.vtk",
        "the atlas's file; the extension chooses the format (vtk, vtu, ply, obj, off, stl)",
        file_type=mesh_output_file,
    )
    p.add_argument(
        "--start",
        default=None,
        help="the start: a subject's name, 'mean' (the vertex-wise mean shape; meshes in "
        "correspondence) or a mesh file (e.g. an interrupted atlas, to continue); default: "
        "the first subject",
    )
    p.add_argument(
        "--term",
        choices=("auto", "landmarks", "varifold", "current"),
        default="auto",
        help="data term: 'auto' compares vertices when the meshes and the start share one "
        "vertex count and triangulation, surfaces (varifold) otherwise; 'landmarks' needs "
        "correspondence; 'varifold' and 'current' compare surfaces in any case",
    )
    add_data_term_arguments(p)
    p.add_argument(
        "--coarse-factor", type=_coarse_factor, default=_coarse_default(),
        help="register the atlas onto each subject with a data term this many times wider "
        "than --sigma-w first, then at --sigma-w from there (coarse to fine; 1: directly, "
        "which lets far subjects fall into local minima and the objective rise over the "
        "iterations: docs/evidence/atlas_evidence.md)",
    )  # fmt: skip
    add_landmark_arguments(p)
    p.add_argument(
        "--tol",
        type=positive_float,
        default=_library_default("tol"),
        help="stop when an iteration moves the atlas by at most this (per-vertex RMS, mm)",
    )
    p.add_argument(
        "--max-iter", type=positive_int, default=_library_default("max_iter"),
        help="iteration limit",
    )  # fmt: skip
    add_units_arguments(p, reference="that of the mesh of median size (taken to be in mm)")
    p.add_argument(
        "--subset", type=_subset_count, default=_library_default("subset", build=True),
        metavar="N|all",
        help="estimate the atlas from N subjects chosen by --subset-rule (every subject when "
        "the folder has at most N; 'all': every subject), each weighted by the share of the "
        "cohort it stands for; the record names them; every subject is then corresponded to "
        "it as usual",
    )  # fmt: skip
    p.add_argument(
        "--subset-rule", choices=SUBSET_RULES, default="stratified",
        help="'stratified': k-means strata of the meshes' principal extents, one subject "
        "nearest each stratum's centre; 'random': a seeded draw",
    )  # fmt: skip
    p.add_argument("--subset-seed", type=nonnegative_int, default=0,
                   help="seed of the strata or of the draw")  # fmt: skip
    p.add_argument(
        "--no-resume", action="store_true",
        help="estimate the atlas again even when OUTPUT holds a finished one with the same "
        "inputs and settings (its record's key)",
    )  # fmt: skip
    add_batch_arguments(p)
    p.set_defaults(run=run_atlas_command, output_is_file=True)


def run_atlas_command(args) -> int:
    """Estimate the atlas from parsed command-line arguments (:func:`build_atlas`)."""
    from ..preparation import UnitsError, read_atlas_inputs
    from ..preparation.atlas_run import (
        AtlasInterrupted,
        atlas_term,
        build_atlas,
        resolve_atlas_start,
    )
    from ..preparation.landmarks import LandmarkError

    try:
        inputs = read_atlas_inputs(args.meshes, units=args.units, allow_scale=args.allow_scale)
    except UnitsError as exc:
        raise units_usage_error("atlas", exc) from None
    except (ValueError, OSError) as exc:
        raise UsageError(
            f"symladders atlas: error: --meshes: {str(exc).removeprefix('meshes: ')}"
        ) from None
    try:  # the usage errors, before any computation
        initial, label = resolve_atlas_start(inputs, args.start)
        _, term = atlas_term(inputs, initial, args.term)
    except ValueError as exc:
        raise UsageError(f"symladders atlas: error: --{exc}") from None
    subset = ""
    if args.subset is not None and args.subset < len(inputs.names):
        subset = f" ({args.subset_rule} subset of {args.subset})"
        label = label if args.start is not None else "the subset's first subject"
    print_line(
        f"symladders atlas: {len(inputs.names)} ED mesh(es) from {args.meshes}{subset}, {term} "
        f"term, start {label}, output {args.output}"
    )
    for name, reason in inputs.skipped.items():
        print(f"symladders atlas: warning: {name} left out: {reason}", file=sys.stderr)
    try:
        with parallel_backend(args, "atlas"):
            run = build_atlas(
                args.meshes, args.output,
                correspondence_settings(args, atlas_coarse_factor=args.coarse_factor),
                start=args.start,
                term=args.term, tol=args.tol, max_iter=args.max_iter, inputs=inputs,
                progress=None if args.no_progress else _progress,
                landmarks=landmarks_argument(args, args.meshes), subset=args.subset,
                subset_rule=args.subset_rule, subset_seed=args.subset_seed, jobs=args.jobs,
                resume=not args.no_resume,
            )  # fmt: skip
    except AtlasInterrupted as exc:
        args.on_interrupt = exc.message
        raise
    except LandmarkError as exc:
        raise UsageError(f"symladders atlas: error: --landmarks: {exc}") from None
    res = run.result
    if run.reused:
        print_line(
            f"symladders atlas: reused {args.output}: finished before with the same inputs and "
            f"settings (key {run.record['key']}, {res.n_iter} iteration(s)); --no-resume "
            f"estimates it again"
        )
        return 1 if inputs.skipped else 0
    why = f"the limit, --max-iter {args.max_iter}" if res.n_iter >= args.max_iter else res.message
    state = "converged" if res.converged else "not converged"
    print_line(
        f"symladders atlas: {state} after {res.n_iter} iteration(s)"
        f"{'' if res.converged else f' ({why})'}, {term} term, objective "
        f"{res.objectives[0]:.6g} -> {res.objectives[-1]:.6g}; written to {args.output} "
        f"({len(res.vertices)} vertices), record {run.record_path}"
    )
    return 1 if inputs.skipped else 0


def _progress(it: int, objective: float, norm: float) -> None:
    what = "start" if it == 0 else f"iteration {it}"
    print_line(f"{what}: objective {objective:.6g}, norm of the averaged momenta {norm:.4g}")
