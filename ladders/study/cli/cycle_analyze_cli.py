"""``symladders cycle-analyze``: where two groups' transported cycles differ.

A thin wrapper of :func:`~ladders.study.sequences.compare_cycles` on the output of
``symladders cycle-study`` (:mod:`.cycle_cli`), writing the analysis folder
(:func:`~ladders.study.sequences.cycle_outputs.write_cycle_tests`).
"""

from __future__ import annotations

from pathlib import Path

from .cli_types import (
    DefaultsFormatter,
    UsageError,
    existing_file,
    existing_folder,
    output_folder,
    positive_float,
    positive_int,
)

__all__ = ["add_cycle_analyze_parser", "run_cycle_analyze_command"]


def add_cycle_analyze_parser(sub) -> None:
    """Register ``cycle-analyze`` on an argparse subparsers object."""
    p = sub.add_parser(
        "cycle-analyze",
        help="compare two groups' cycles: per frame, peak and time to peak of the normal motion",
        description=(
            "Test two groups' transported cycles (STUDY, the output of 'symladders "
            "cycle-study') on the normal motion (or, with --measure rotation, the rotation "
            "about the long axis) at every vertex: per frame (FWER over the "
            "vertices and frames together), and on each vertex's peak and its "
            "time in the cycle (FWER over the vertices), by permutation. OUTPUT holds "
            "cycle_vertices.csv, cycle_frames.csv, cycle_tests.vtu and cycle_curves.png."
        ),
        formatter_class=DefaultsFormatter,
    )
    p.add_argument("study", type=existing_folder, metavar="STUDY")
    p.add_argument("--groups", type=existing_file, required=True,
                   help="CSV with the columns subject,group (two groups)")  # fmt: skip
    p.add_argument("--compare", nargs=2, default=None, metavar=("GROUP", "REFERENCE"),
                   help="the two groups to compare (needed when the table has more than two)")  # fmt: skip
    p.add_argument("--permutations", type=positive_int, default=5000)
    p.add_argument("--seed", type=int, default=0, help="seed of the permutations")
    p.add_argument("--tfce", action="store_true",
                   help="also test the peak with threshold-free cluster enhancement on the "
                        "atlas's mesh (a regional effect through noisy tracking)")  # fmt: skip
    p.add_argument("--measure", choices=("normal", "rotation"), default="normal",
                   help="the curve tested per vertex: the normal motion (mm), or the rotation "
                        "about the long axis (degrees, counter-clockwise seen from the apex; "
                        "what a twist changes; needs --aha)")  # fmt: skip
    p.add_argument("--min-radius", type=positive_float, default=5.0,
                   help="with --measure rotation: vertices closer to the long axis than this "
                        "(mm) are not tested (their angle is ill-conditioned)")  # fmt: skip
    p.add_argument("--fwhm", type=positive_float, default=None, metavar="MM",
                   help="smooth every subject's map at every frame on the atlas before the "
                        "tests, by the heat kernel of this full width at half maximum (mm); "
                        "default: not smoothed")  # fmt: skip
    p.add_argument("--aha", type=existing_file, default=None, metavar="LANDMARKS",
                   help="the atlas's apex, base-plane centre and septal point (a JSON file, or a "
                        "landmark table's row 'atlas'): places the AHA segments for "
                        "--exclude-segments and the long axis for --measure rotation")  # fmt: skip
    p.add_argument("--exclude-segments", type=int, nargs="+", default=None, metavar="SEGMENT",
                   help="AHA segments (1-17) left out of the tests, e.g. 17, the apical cap "
                        "thick short-axis slices resolve poorly; needs --aha")  # fmt: skip
    p.add_argument("--output", "-o", type=output_folder, default=None,
                   help="folder of the results (default: STUDY/analysis)")  # fmt: skip
    p.set_defaults(run=run_cycle_analyze_command, output_is_file=False)


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

    motion = load_cycle_motion(args.study)
    labels, names = _two_groups(read_groups(args.groups), args.compare, motion.subjects)
    if len(labels) < len(motion.subjects):  # subjects of other groups left out
        keep = [i for i, s in enumerate(motion.subjects) if s in labels]
        motion = type(motion)(tuple(motion.subjects[i] for i in keep),
                              motion.displacement[keep], motion.atlas, motion.faces)  # fmt: skip
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
