"""``symladders correspond``: a folder of segmentations into a folder the study reads.

A thin wrapper of :func:`~ladders.study.preparation.correspond_cohort`: each
subject's ED and ES meshes (any vertex count, format or pose) are aligned onto
the atlas and the atlas is registered onto them; ``OUTPUT`` then holds the atlas,
the corresponded meshes (``symladders study --meshes OUTPUT`` reads it), the
quality table and one record per subject. Exit status 1 when a subject failed
(the others finished, the reason is in the quality table), 2 on a usage error.
"""

from __future__ import annotations

import sys
from pathlib import Path

from .cli_types import DefaultsFormatter, UsageError, existing_folder, positive_float
from .common_arguments import MESH_FORMATS, add_batch_arguments, add_output, parallel_backend
from .preparation_arguments import (
    add_data_term_arguments,
    add_landmark_arguments,
    add_units_arguments,
    correspondence_settings,
    landmarks_argument,
    mesh_file,
    print_line,
    units_usage_error,
)

__all__ = ["add_correspond_parser", "run_correspond_command"]

_SHOWN = 10  # flagged meshes named in the last line


def add_correspond_parser(sub) -> None:
    """Register the ``correspond`` subcommand on an argparse subparsers object."""
    from ..preparation import CorrespondenceSettings

    p = sub.add_parser(
        "correspond",
        help="bring segmentations (any vertex count, format, pose, unit) into correspondence "
        "with an atlas",
        description=(
            "Align each subject's ED and ES meshes rigidly onto the atlas (one transform per "
            "subject, estimated on ED; the input's own turn about the long axis is kept where "
            "the surface cannot tell it, or landmarks fix it), register the atlas onto ED with a "
            "varifold term, move it along its normals onto ES (the wall motion the surfaces "
            "show) and write the results: OUTPUT holds atlas.<ext>, <name>_ed.<ext>, "
            "<name>_es.<ext> (read by 'symladders study --meshes OUTPUT'), quality.csv and "
            "quality.md (meshes to inspect first) and correspondence/<name>.json. A subject "
            "that fails is recorded with its reason and the others finish (exit status 1). "
            "Rerunning the command skips the subjects done with the same atlas, settings, "
            "input files and unit."
        ),
        formatter_class=DefaultsFormatter,
    )
    p.add_argument("--atlas", type=mesh_file, required=True, help="the atlas mesh")
    p.add_argument(
        "--meshes",
        type=existing_folder,
        required=True,
        help="folder of segmentations: <name>_ed.<ext> and <name>_es.<ext> (or <name>/ed.<ext>, "
        "<name>/es.<ext>), any vertex count; PLY/OBJ/STL/OFF/VTK/VTU/VTP",
    )
    add_output(p, "symladders-output/corresponded", "folder of the corresponded meshes")
    p.add_argument(
        "--ext",
        choices=MESH_FORMATS,
        default=None,
        help="format of the written meshes (default: the atlas's, vtk when it is not written)",
    )
    add_units_arguments(
        p,
        reference="the atlas's (taken to be in mm)",
        pose="accept meshes far from the atlas's pose; the pose is checked with --alignment "
        "none only (ICP estimates it otherwise)",
    )
    p.add_argument(
        "--alignment",
        choices=("icp", "none"),
        default="icp",
        help="rigid alignment of each subject onto the atlas; 'none': the meshes are in the "
        "atlas's frame already",
    )
    add_landmark_arguments(p, atlas_landmarks=True)
    p.add_argument(
        "--landmark-anchor",
        choices=("axial", "points", "none"),
        default="axial",
        help="with landmarks, what the apex and base-plane centre fix in the affine fit onto "
        "each mesh: their heights along the long axis (the stretch a wall cut at its base "
        "leaves loose), the whole points, or nothing",
    )
    p.add_argument(
        "--es-correspondence",
        choices=("normal", "registration"),
        default="normal",
        help="end-systole: the corresponded ED moved along its normals onto the ES surface "
        "(keeps the wall motion), or registered like ED (slides along the wall; "
        "docs/preparation.md)",
    )
    add_data_term_arguments(p)
    p.add_argument(
        "--flag-hausdorff",
        type=positive_float,
        default=CorrespondenceSettings().flag_hausdorff,
        metavar="MM",
        help="flag a mesh for inspection when its Hausdorff distance to the corresponded "
        "atlas exceeds this (thick slices end in a flat apical cap up to half a slice "
        "beyond the apex); only the quality table changes, the results are reused",
    )
    p.add_argument(
        "--flag-mean-distance",
        type=positive_float,
        default=CorrespondenceSettings().flag_mean_distance,
        metavar="MM",
        help="flag a mesh for inspection when its mean surface distance exceeds this",
    )
    _add_run_arguments(p)
    p.set_defaults(run=run_correspond_command)


def _add_run_arguments(p) -> None:
    """Flags of the execution: workers, progress, backend, resume."""
    add_batch_arguments(p)
    p.add_argument(
        "--no-resume",
        action="store_true",
        help="correspond every subject again instead of skipping the ones done",
    )


def _scan(folder: Path) -> dict:
    from ..preparation import scan_segmentations

    try:
        return scan_segmentations(folder)
    except (ValueError, OSError) as exc:
        raise UsageError(
            f"symladders correspond: error: --meshes: {str(exc).removeprefix('meshes: ')}"
        ) from None


def _check_atlas(path: Path) -> int:
    """The atlas's vertex count; an unreadable atlas is a usage error naming ``--atlas``."""
    from ..meshes import read_mesh

    try:
        return len(read_mesh(path)[0])
    except (ValueError, OSError) as exc:
        raise UsageError(f"symladders correspond: error: --atlas: {exc}") from None


def _progress(done: int, total: int, name: str, record: dict) -> None:
    if record["status"] != "ok":
        print_line(f"[{done}/{total}] {name}: failed ({record.get('reason', '')})")
        return
    ed, es = record["ed"], record["es"]
    late = [p.upper() for p in ("ed", "es") if not record[p]["converged"]]
    print_line(
        f"[{done}/{total}] {name}: mean surface distance ED {ed['mean_surface_distance']:.3g}, "
        f"ES {es['mean_surface_distance']:.3g} mm"
        + (f"; {' and '.join(late)} stopped before converging" if late else "")
    )


def _summary(outcome) -> str:
    failed = set(outcome.failed)
    done = sum(n not in failed for n in outcome.computed)
    flagged = outcome.flagged
    named = ", ".join(flagged[:_SHOWN]) + (
        f" and {len(flagged) - _SHOWN} more" if len(flagged) > _SHOWN else ""
    )
    return (
        f"symladders correspond: {len(outcome.records)} subject(s): {done} corresponded, "
        f"{len(outcome.reused)} reused, {len(failed)} failed; {len(flagged)} mesh(es) flagged "
        f"for inspection{': ' + named if flagged else ''}; quality table: "
        f"{outcome.output / 'quality.md'}"
    )


def run_correspond_command(args) -> int:
    """Correspond a folder of segmentations from parsed command-line arguments."""
    from ..preparation import UnitsError, correspond_cohort
    from ..preparation.landmarks import LandmarkError

    n_vertices = _check_atlas(args.atlas)
    entries = _scan(args.meshes)
    anchor = {"none": {"anchor_weight": 0.0}}.get(args.landmark_anchor, {"anchor": args.landmark_anchor})  # fmt: skip
    settings = correspondence_settings(
        args, alignment=args.alignment, es_correspondence=args.es_correspondence,
        flag_hausdorff=args.flag_hausdorff, flag_mean_distance=args.flag_mean_distance, **anchor,
    )  # fmt: skip
    landmarks = landmarks_argument(args, args.meshes)
    output = Path(args.output)
    print_line(
        f"symladders correspond: {len(entries)} subject(s) from {args.meshes} onto the atlas "
        f"{args.atlas} ({n_vertices} vertices), output {output}"
        + (f", landmarks {landmarks}" if landmarks else "")
    )
    args.on_interrupt = f"the subjects done are kept in {output}; rerun the command to resume"
    try:
        with parallel_backend(args, "correspond"):
            outcome = correspond_cohort(
                args.atlas, entries, output, settings, jobs=args.jobs,
                progress=None if args.no_progress else _progress, resume=not args.no_resume,
                units=args.units, allow_scale=args.allow_scale,
                allow_pose=True if args.allow_pose else None, ext=args.ext, landmarks=landmarks,
                atlas_landmarks=args.atlas_landmarks,
            )  # fmt: skip
    except UnitsError as exc:
        raise units_usage_error("correspond", exc) from None
    except LandmarkError as exc:
        raise UsageError(f"symladders correspond: error: --landmarks: {exc}") from None
    print_line(_summary(outcome))
    if outcome.failed:
        print(
            f"symladders correspond: {len(outcome.failed)} subject(s) failed "
            f"({', '.join(outcome.failed)}); reasons in {output / 'quality.md'}",
            file=sys.stderr,
        )
    return 1 if outcome.failed else 0
