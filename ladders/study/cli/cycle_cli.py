"""``symladders cycle-study`` and ``symladders cycle-analyze``: whole cycles transported and tested.

Thin wrappers of :func:`~ladders.study.sequences.run_cycle_study` and
:func:`~ladders.study.sequences.compare_cycles`. ``cycle-study`` exits with status 1
when a subject failed (the others are stored, the reason is in ``cycle_study.csv`` and
on standard error), 2 on a usage error.
"""

from __future__ import annotations

import sys
from pathlib import Path

from ..sequences.cycle_analysis import MEASURES, MOTION_MEASURES
from .cli_types import (
    DefaultsFormatter,
    UsageError,
    existing_file,
    existing_folder,
    output_folder,
    positive_float,
    positive_int,
)
from .common_arguments import RECOMMENDED_ALPHA2, add_batch_arguments, add_output, parallel_backend
from .plugin_arguments import add_plugin_argument, one_deformation, registered_names
from .preparation_arguments import mesh_file

__all__ = ["add_cycle_parsers", "run_cycle_study_command", "run_cycle_analyze_command"]


def add_cycle_parsers(sub) -> None:
    """Register ``cycle-study`` and ``cycle-analyze`` on an argparse subparsers object."""
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
                        "one for group statistics (docs/population.md, 'Which to use when': "
                        "never an LDDMM transport at small alpha^2)")  # fmt: skip
    p.add_argument("--deformation", type=one_deformation, default="lddmm", metavar="NAME",
                   help="deformation model of the registrations and the pole ladder, a "
                        "registered name (" + ", ".join(registered_names())
                   + "; a model of your own: --plugin)")  # fmt: skip
    add_plugin_argument(p)
    p.add_argument("--sigma", type=positive_float, default=10.0, help="kernel width (mm)")
    add_batch_arguments(p)
    p.set_defaults(run=run_cycle_study_command, output_is_file=False)

    q = sub.add_parser(
        "cycle-analyze",
        help="compare two groups' cycles: per frame, peak and time to peak of the normal motion",
        description=(
            "Test two groups' transported cycles (STUDY, the output of 'symladders "
            "cycle-study') on the normal motion (or, with --measure rotation, the rotation "
            "about the long axis), or their wall maps (STUDY, the output of 'symladders "
            "wall', with --measure thickness, thickening, radial, circumferential or "
            "longitudinal) at every vertex: per frame (FWER over the "
            "vertices and frames together), and on each vertex's peak and its "
            "time in the cycle (FWER over the vertices), by permutation. OUTPUT holds "
            "cycle_vertices.csv, cycle_frames.csv, cycle_tests.vtu and cycle_curves.png."
        ),
        formatter_class=DefaultsFormatter,
    )
    q.add_argument("study", type=existing_folder, metavar="STUDY")
    q.add_argument("--groups", type=existing_file, required=True,
                   help="CSV with the columns subject,group (two groups)")  # fmt: skip
    q.add_argument("--compare", nargs=2, default=None, metavar=("GROUP", "REFERENCE"),
                   help="the two groups to compare (needed when the table has more than two)")  # fmt: skip
    q.add_argument("--permutations", type=positive_int, default=5000)
    q.add_argument("--seed", type=int, default=0, help="seed of the permutations")
    q.add_argument("--tfce", action="store_true",
                   help="also test the peak with threshold-free cluster enhancement on the "
                        "atlas's mesh (a regional effect through noisy tracking)")  # fmt: skip
    q.add_argument("--measure", choices=tuple(MEASURES), default="normal",
                   help="the curve tested per vertex: the normal motion (mm), or the rotation "
                        "about the long axis (degrees, counter-clockwise seen from the apex; "
                        "what a twist changes; needs --aha), of a cycle study; or, of the maps "
                        "of 'symladders wall', the wall thickness or thickening (mm) or the "
                        "radial, circumferential or longitudinal strain (percent)")  # fmt: skip
    q.add_argument("--min-radius", type=positive_float, default=5.0,
                   help="with --measure rotation: vertices closer to the long axis than this "
                        "(mm) are not tested (their angle is ill-conditioned)")  # fmt: skip
    q.add_argument("--fwhm", type=positive_float, default=None, metavar="MM",
                   help="smooth every subject's map at every frame on the atlas before the "
                        "tests, by the heat kernel of this full width at half maximum (mm); "
                        "default: not smoothed")  # fmt: skip
    q.add_argument("--aha", type=existing_file, default=None, metavar="LANDMARKS",
                   help="the atlas's apex, base-plane centre and septal point (a JSON file, or a "
                        "landmark table's row 'atlas'): places the AHA segments for "
                        "--exclude-segments and the long axis for --measure rotation")  # fmt: skip
    q.add_argument("--exclude-segments", type=int, nargs="+", default=None, metavar="SEGMENT",
                   help="AHA segments (1-17) left out of the tests, e.g. 17, the apical cap "
                        "thick short-axis slices resolve poorly; needs --aha")  # fmt: skip
    q.add_argument("--output", "-o", type=output_folder, default=None,
                   help="folder of the results (default: STUDY/analysis)")  # fmt: skip
    q.set_defaults(run=run_cycle_analyze_command, output_is_file=False)


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


def _two_groups(table: dict, compare, subjects) -> tuple[dict, tuple[str, str]]:
    present = {s: g for s, g in table.items() if s in subjects}
    missing = [s for s in subjects if s not in table]
    if missing:
        raise UsageError(f"symladders cycle-analyze: error: --groups: no group for {missing}")
    names = compare or tuple(dict.fromkeys(present.values()))
    if len(names) != 2:
        raise UsageError(
            "symladders cycle-analyze: error: --groups: expected two groups, found "
            f"{sorted(set(present.values()))}; name two with --compare"
        )
    unknown = [g for g in names if g not in present.values()]
    if unknown:
        raise UsageError(f"symladders cycle-analyze: error: --compare: no subject in {unknown}")
    return {s: g == names[0] for s, g in present.items() if g in names}, tuple(names)


def _landmarks(args):
    """The atlas's landmarks of ``--aha`` (None without it); checks what needs them."""
    from ..population import read_aha_landmarks

    if args.aha is None:
        if args.measure == "rotation":
            raise UsageError("symladders cycle-analyze: error: --measure rotation: needs --aha "
                             "(the atlas's apex and base-plane centre place the long axis)")  # fmt: skip
        return None
    if args.exclude_segments is None and args.measure != "rotation":
        raise UsageError("symladders cycle-analyze: error: --aha: only used with "
                         "--exclude-segments or --measure rotation")  # fmt: skip
    try:
        return read_aha_landmarks(args.aha)
    except ValueError as exc:
        raise UsageError(f"symladders cycle-analyze: error: --aha: {exc}") from None


def _tested_segments(args, motion, lm):
    """The vertices tested: all, or those outside ``--exclude-segments`` (None: all)."""
    if args.exclude_segments is None:
        return None
    import numpy as np

    from ..cohort.aha_segments import check_segments
    from ..population.aha_model import aha_segments

    if lm is None:
        raise UsageError("symladders cycle-analyze: error: --exclude-segments: needs --aha "
                         "(the atlas's landmarks that place the segments)")  # fmt: skip
    try:
        excluded = check_segments(args.exclude_segments, "--exclude-segments")
        labels = aha_segments(motion.atlas, lm.apex, lm.base, lm.septum, motion.faces)
    except ValueError as exc:
        raise UsageError(f"symladders cycle-analyze: error: {exc}") from None
    tested = ~np.isin(labels, excluded)
    if tested.sum() < 2:
        raise UsageError("symladders cycle-analyze: error: --exclude-segments: no vertex left")
    return tested


def run_cycle_analyze_command(args) -> int:
    """Compare two groups' cycles from parsed arguments."""
    import numpy as np

    from ..cohort import read_groups
    from ..sequences import compare_cycles, load_cycle_motion
    from ..sequences.cycle_outputs import write_cycle_tests

    if args.measure in MOTION_MEASURES:
        motion = load_cycle_motion(args.study)
    else:  # the wall's measures: the maps of 'symladders wall'
        from ..wall import load_wall_cycles

        motion = load_wall_cycles(args.study)
    labels, names = _two_groups(read_groups(args.groups), args.compare, motion.subjects)
    if len(labels) < len(motion.subjects):  # subjects of other groups left out
        motion = motion.subset([s for s in motion.subjects if s in labels])
    axis = _landmarks(args)
    tested = _tested_segments(args, motion, axis)
    try:
        tests = compare_cycles(motion, labels, args.permutations,
                               np.random.default_rng(args.seed), tfce=args.tfce,
                               vertices=tested, measure=args.measure, axis=axis,
                               min_radius=args.min_radius, fwhm=args.fwhm)  # fmt: skip
    except ValueError as exc:  # e.g. a group of fewer than 3 subjects
        raise UsageError(f"symladders cycle-analyze: error: {exc}") from None
    output = Path(args.output) if args.output else Path(args.study) / "analysis"
    write_cycle_tests(output, motion, tests, names)
    found = (tests.peak.p_fwer < 0.05).sum(), (tests.time_to_peak.p_fwer < 0.05).sum()
    frames = (tests.per_frame.p_fwer < 0.05).any(axis=0).sum()
    print(
        f"symladders cycle-analyze: {names[0]} ({int(tests.labels.sum())}) against {names[1]} "
        f"({int((~tests.labels).sum())}), {args.permutations:,} permutations"
        + ("" if tests.fwhm is None else f", smoothed {tests.fwhm:g} mm FWHM")
        + ": vertices found at "
        f"FWER 5 %: peak {'rotation ' if tests.measure == 'rotation' else ''}{found[0]}"
        + ("" if tests.peak_tfce is None
           else f" (TFCE: {int((tests.peak_tfce.p_fwer_enhanced < 0.05).sum())})")
        + f", time to peak {found[1]}, some frame {frames}"
        + ("" if tests.tested.all() else f" (of {int(tests.tested.sum())} vertices tested)")
        + f"; in {output}"
    )  # fmt: skip
    return 0
