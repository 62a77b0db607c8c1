"""``symladders atlas``: the LDDMM atlas (Karcher mean) of a cohort's end-diastolic meshes.

A thin wrapper of :func:`~ladders.study.preparation.estimate_atlas` on the ED
meshes :func:`~ladders.study.preparation.read_atlas_inputs` reads from a folder
(in one unit). It prints the objective per iteration, writes the atlas (format
from the extension of ``--output``) and next to it ``<name>.json``: convergence,
objectives, data term, start, units, settings, input files. Interrupted, it
writes the last iterate and its record (``"interrupted": true``) before it stops;
``--start`` that file continues. Exit status 1 when an ED mesh could not be read
(the atlas is estimated from the others), 2 on a usage error.
"""

from __future__ import annotations

import difflib
import inspect
import json
import sys
from pathlib import Path

from .cli_types import (
    DefaultsFormatter,
    UsageError,
    existing_folder,
    positive_float,
    positive_int,
)
from .preparation_arguments import (
    add_data_term_arguments,
    add_units_arguments,
    correspondence_settings,
    mesh_output_file,
    print_line,
    units_usage_error,
)

__all__ = ["add_atlas_parser", "run_atlas_command"]


def _library_default(name: str):
    from ..preparation.atlas import estimate_atlas

    return inspect.signature(estimate_atlas).parameters[name].default


def add_atlas_parser(sub) -> None:
    """Register the ``atlas`` subcommand on an argparse subparsers object."""
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
    p.add_argument(
        "--output",
        "-o",
        type=mesh_output_file,
        default="symladders-output/atlas.vtk",
        help="the atlas's file; the extension chooses the format (vtk, vtu, ply, obj, off, stl)",
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
    p.add_argument("--no-progress", action="store_true", help="no line per iteration")
    p.set_defaults(run=run_atlas_command, output_is_file=True)


def _inputs(args):
    from ..preparation import UnitsError, read_atlas_inputs

    try:
        return read_atlas_inputs(args.meshes, units=args.units, allow_scale=args.allow_scale)
    except UnitsError as exc:
        raise units_usage_error("atlas", exc) from None
    except (ValueError, OSError) as exc:
        raise UsageError(
            f"symladders atlas: error: --meshes: {str(exc).removeprefix('meshes: ')}"
        ) from None


def _start(args, inputs):
    """``(initial, label)`` for :func:`estimate_atlas` from ``--start``."""
    from ..meshes import MESH_EXTENSIONS, read_mesh
    from ..preparation import meshes_correspond

    start = args.start
    if start is None:
        return 0, inputs.names[0]
    if start == "mean":
        if not meshes_correspond(inputs.meshes):
            raise UsageError(
                "symladders atlas: error: --start mean: the mean shape needs meshes in "
                "correspondence (one vertex count and triangulation); name a subject instead"
            )
        return "mean", "mean"
    if start in inputs.names:
        return inputs.names.index(start), start
    if Path(start).suffix.lower() in MESH_EXTENSIONS and Path(start).is_file():
        try:
            return read_mesh(start), str(Path(start).resolve())
        except (ValueError, OSError) as exc:
            raise UsageError(f"symladders atlas: error: --start: {exc}") from None
    why = f"its ED mesh was not read ({inputs.skipped[start]})" if start in inputs.skipped else (
        "no subject of that name and no mesh file"
    )  # fmt: skip
    close = difflib.get_close_matches(start, inputs.names, n=1)
    hint = (
        f"; did you mean {close[0]!r}?" if close else f" (subjects: {', '.join(inputs.names[:5])}"
    )
    hint += "" if close else (", ...)" if len(inputs.names) > 5 else ")")
    raise UsageError(f"symladders atlas: error: --start {start!r}: {why}{hint}")


def _data_term(args, inputs, initial) -> tuple[bool | None, str]:
    """``surface_term`` for :func:`estimate_atlas` and the name of the term it will use."""
    from ..preparation import meshes_correspond

    start = [initial] if isinstance(initial, tuple) else []
    corresponding = meshes_correspond(inputs.meshes + start)
    if args.term == "landmarks" and not corresponding:
        raise UsageError(
            "symladders atlas: error: --term landmarks: the meshes (and the start) do not share "
            "one vertex count and triangulation; use --term auto or varifold"
        )
    if args.term == "landmarks" or (args.term == "auto" and corresponding):
        return (False if args.term == "landmarks" else None), "landmarks"
    return (None if args.term == "auto" else True), (
        "varifold" if args.term == "auto" else args.term
    )


def _record(args, inputs, settings, label, result, interrupted=False) -> dict:
    from ..files import file_sha256

    return {
        "atlas": str(Path(args.output).resolve()),
        "converged": bool(result.get("converged", False)) and not interrupted,
        "interrupted": interrupted,
        "n_iter": result["n_iter"],
        "objectives": result["objectives"],
        "gradient_norms": result.get("gradient_norms", []),
        "term": result["term"],
        "start": label,
        "tol": args.tol,
        "max_iter": args.max_iter,
        "subjects": inputs.names,
        "skipped": inputs.skipped,
        "units": {**inputs.units.as_dict(), "reference": inputs.reference},
        "settings": settings.as_dict(),
        "input_files": {str(p.resolve()): file_sha256(p) for p in inputs.files},
        "message": result.get("message", ""),
    }


def _write(args, vertices, faces, record) -> Path:
    from ..files import atomic_write_text
    from ..meshes import write_mesh

    output = Path(args.output)
    output.parent.mkdir(parents=True, exist_ok=True)
    write_mesh(output, vertices, faces, atomic=True)
    path = output.with_suffix(".json")
    atomic_write_text(path, json.dumps(record, indent=1, default=str))
    return path


def _progress(it: int, objective: float, norm: float) -> None:
    what = "start" if it == 0 else f"iteration {it}"
    print_line(f"{what}: objective {objective:.6g}, norm of the averaged momenta {norm:.4g}")


def run_atlas_command(args) -> int:
    """Estimate the atlas from parsed command-line arguments."""
    from ..preparation import estimate_atlas

    inputs = _inputs(args)
    initial, label = _start(args, inputs)
    surface, term = _data_term(args, inputs, initial)
    settings = correspondence_settings(args, data_term=term if term != "landmarks" else "varifold")
    print_line(
        f"symladders atlas: {len(inputs.names)} ED mesh(es) from {args.meshes}, {term} term, "
        f"start {label}, output {args.output}"
    )
    for name, reason in inputs.skipped.items():
        print(f"symladders atlas: warning: {name} left out: {reason}", file=sys.stderr)
    seen = {"objectives": [], "gradient_norms": []}

    def progress(it, objective, norm):
        seen["objectives"].append(objective)
        seen["gradient_norms"].append(norm)
        if not args.no_progress:
            _progress(it, objective, norm)

    def checkpoint(it, vertices):
        seen.update(n_iter=it, vertices=vertices)

    try:
        res = estimate_atlas(
            inputs.meshes, settings, initial=initial, tol=args.tol, max_iter=args.max_iter,
            progress=progress, surface_term=surface, checkpoint=checkpoint,
        )  # fmt: skip
    except KeyboardInterrupt:
        _keep_last_iterate(args, inputs, settings, (label, term), initial, seen)
        raise
    record = _record(args, inputs, settings, label, {**vars(res), "term": term})
    path = _write(args, res.vertices, res.faces, record)
    why = f"the limit, --max-iter {args.max_iter}" if res.n_iter >= args.max_iter else res.message
    state = "converged" if res.converged else "not converged"
    print_line(
        f"symladders atlas: {state} after {res.n_iter} iteration(s)"
        f"{'' if res.converged else f' ({why})'}, {term} term, objective "
        f"{res.objectives[0]:.6g} -> {res.objectives[-1]:.6g}; written to {args.output} "
        f"({len(res.vertices)} vertices), record {path}"
    )
    return 1 if inputs.skipped else 0


def _keep_last_iterate(args, inputs, settings, labels, initial, seen) -> None:
    """On Ctrl-C: write the last iterate (not the start) and its record; say how to continue."""
    if seen.get("n_iter", 0) < 1:
        return
    label, term = labels
    faces = initial[1] if isinstance(initial, tuple) else inputs.meshes[
        0 if initial == "mean" else initial
    ][1]  # fmt: skip
    record = _record(args, inputs, settings, label, {**seen, "term": term}, interrupted=True)
    _write(args, seen["vertices"], faces, record)
    args.on_interrupt = (
        f"the iterate of iteration {seen['n_iter']} was written to {args.output}; continue "
        f"with --start {args.output}"
    )
