"""``symladders wall``: wall thickness, thickening and strain of every tracked subject.

A thin wrapper of :func:`~ladders.study.wall.run_wall_maps`. Exit status 1 when a
subject failed (the others are written, the reason is in ``wall.csv`` and on standard
error), 2 on a usage error.
"""

from __future__ import annotations

import sys

from .cli_types import DefaultsFormatter, UsageError, existing_file, existing_folder
from .common_arguments import add_batch_arguments, add_output, parallel_backend
from .preparation_arguments import mesh_file

__all__ = ["add_wall_parser", "run_wall_command"]


def add_wall_parser(sub) -> None:
    """Register the ``wall`` subcommand on an argparse subparsers object."""
    p = sub.add_parser(
        "wall",
        help="wall thickness, thickening and strain per vertex and AHA segment of tracked subjects",
        description=(
            "For every subject of TRACKED (the output of 'symladders track' with "
            "--myocardium-label, or --epicardia for cine: <subject>/frame_<kk> and "
            "<subject>/epicardium/frame_<kk>), measure at every frame and endocardial vertex "
            "the wall thickness (the distance to the epicardium, cut at the endocardium's "
            "rim), its thickening from ED (mm, and relative: the radial strain) and the "
            "circumferential and longitudinal Lagrangian strain of the endocardium (the "
            "directions from the atlas's long axis). OUTPUT holds <subject>.npz (the maps, "
            "which 'symladders cycle-analyze OUTPUT --measure thickening' tests), "
            "maps/<subject>.vtu (ED thickness and peaks per vertex), wall_segments.csv (per "
            "AHA segment), wall.csv and wall.json. A rerun skips the subjects done; a failing "
            "subject is recorded while the others go on (exit 1)."
        ),
        formatter_class=DefaultsFormatter,
    )
    p.add_argument("tracked", type=existing_folder, metavar="TRACKED",
                   help="folder of <subject>/frame_<kk>.<ext> and <subject>/epicardium/")  # fmt: skip
    p.add_argument("--atlas", type=mesh_file, required=True,
                   help="the atlas mesh (the tracked meshes' correspondence and frame)")  # fmt: skip
    p.add_argument("--aha", type=existing_file, required=True, metavar="LANDMARKS",
                   help="the atlas's apex, base-plane centre and septal point (a JSON file, or a "
                        "landmark table's row 'atlas'): the long axis and the AHA segments")  # fmt: skip
    add_output(p, "symladders-output/wall", "folder of the maps and tables")
    add_batch_arguments(p)
    p.set_defaults(run=run_wall_command, output_is_file=False)


def run_wall_command(args) -> int:
    """Measure the wall of the tracked subjects from parsed arguments."""
    from ..meshes.mesh_io import read_mesh
    from ..population import read_aha_landmarks
    from ..wall import run_wall_maps

    atlas, faces = read_mesh(args.atlas)
    try:
        landmarks = read_aha_landmarks(args.aha)
    except ValueError as exc:
        raise UsageError(f"symladders wall: error: --aha: {exc}") from None
    args.on_interrupt = f"the subjects done are kept in {args.output}; rerun the command to resume"
    with parallel_backend(args, "wall"):
        outcome = run_wall_maps(args.tracked, atlas, faces, landmarks, args.output,
                                jobs=args.jobs, progress=not args.no_progress)  # fmt: skip
    n = len(outcome.computed) + len(outcome.reused) + len(outcome.failures)
    print(
        f"symladders wall: {n} subject(s): {len(outcome.computed)} measured, "
        f"{len(outcome.reused)} already done, {len(outcome.failures)} failed, in "
        f"{outcome.output} (wall.csv, wall_segments.csv), {outcome.seconds:.0f} s"
    )
    for name, reason in outcome.failures.items():
        print(f"symladders wall: failed: {name}: {reason}", file=sys.stderr)
    return 1 if outcome.failures else 0
