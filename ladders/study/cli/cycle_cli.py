"""``symladders cycle-study``: every tracked frame's motion transported to the atlas.

A thin wrapper of :func:`~ladders.study.sequences.run_cycle_study`. It exits with
status 1 when a subject failed (the others are stored, the reason is in
``cycle_study.csv`` and on standard error), 2 on a usage error. The analysis of the
transported cycles, ``symladders cycle-analyze``, is :mod:`.cycle_analyze_cli`.
"""

from __future__ import annotations

import sys

from .cli_types import (
    DefaultsFormatter,
    UsageError,
    existing_folder,
    positive_float,
)
from .common_arguments import RECOMMENDED_ALPHA2, add_batch_arguments, add_output, parallel_backend
from .plugin_arguments import add_plugin_argument, one_deformation, registered_names
from .preparation_arguments import mesh_file

__all__ = ["add_cycle_study_parser", "run_cycle_study_command"]


def add_cycle_study_parser(sub) -> None:
    """Register ``cycle-study`` on an argparse subparsers object."""
    p = sub.add_parser(
        "cycle-study",
        help="transport every tracked frame's motion to the atlas (pole ladder)",
        description=(
            "For every subject of FRAMES (the output of 'symladders track': <subject>/"
            "frame_<kk>.<ext>, frame 0 at end-diastole, in the atlas's correspondence), "
            "transport the deformation from ED to every frame to the atlas with the pole "
            "ladder (the paper's Algorithm 1, with residuals): two registrations per frame, "
            "the midpoint shared. OUTPUT holds <subject>.npz (the transported frames), "
            "cycle_study.csv and cycle_study.json. Every subject is stored as it finishes; a "
            "rerun skips the subjects stored with the same frames and settings, and a "
            "failing subject is recorded while the others go on (exit 1)."
        ),
        formatter_class=DefaultsFormatter,
    )
    p.add_argument("frames", type=existing_folder, metavar="FRAMES",
                   help="folder of <subject>/frame_<kk>.<ext> meshes")  # fmt: skip
    p.add_argument("--atlas", type=mesh_file, required=True,
                   help="the atlas mesh (the frames' vertex correspondence)")  # fmt: skip
    add_output(p, "symladders-output/cycle_study", "the study's folder")
    p.add_argument("--alpha2", type=positive_float, default=RECOMMENDED_ALPHA2, metavar="A",
                   help="the regularisation alpha^2 of the registrations (eq. 3): one value, the "
                        "one for group statistics (docs/population.md, 'Choosing the transport and alpha^2': "
                        "never an LDDMM transport at small alpha^2)")  # fmt: skip
    p.add_argument("--deformation", type=one_deformation, default="lddmm", metavar="NAME",
                   help="deformation model of the registrations and the pole ladder, a "
                        "registered name (" + ", ".join(registered_names())
                   + "; a model of your own: --plugin)")  # fmt: skip
    add_plugin_argument(p)
    p.add_argument("--sigma", type=positive_float, default=10.0, help="kernel width (mm)")
    add_batch_arguments(p)
    p.set_defaults(run=run_cycle_study_command, output_is_file=False)


def run_cycle_study_command(args) -> int:
    """Transport the tracked frames from parsed arguments."""
    from ..meshes.mesh_io import read_mesh
    from ..sequences import read_tracked_frames, run_cycle_study

    atlas, faces = read_mesh(args.atlas)
    sequences = read_tracked_frames(args.frames)
    args.on_interrupt = f"the subjects done are kept in {args.output}; rerun the command to resume"
    try:
        with parallel_backend(args, "cycle-study"):
            outcome = run_cycle_study(atlas, faces, sequences, args.output, alpha2=args.alpha2,
                                      deformation=args.deformation, jobs=args.jobs,
                                      progress=not args.no_progress, sigma=args.sigma)  # fmt: skip
    except ValueError as exc:  # a bad atlas
        raise UsageError(f"symladders cycle-study: error: {exc}") from None
    print(
        f"symladders cycle-study: {len(sequences)} subject(s): {len(outcome.computed)} "
        f"transported, {len(outcome.reused)} already done, {len(outcome.failures)} failed, in "
        f"{outcome.output} (cycle_study.csv), {outcome.seconds:.0f} s"
    )
    for name, reason in outcome.failures.items():
        print(f"symladders cycle-study: failed: {name}: {reason}", file=sys.stderr)
    return 1 if outcome.failures else 0
