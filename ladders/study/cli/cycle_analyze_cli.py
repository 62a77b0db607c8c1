"""``symladders cycle-analyze``: the linear model on a cycle study's transported cycles.

A thin wrapper of :func:`~ladders.study.sequences.cycle_model_analysis.analyze_cycle_model`
(and, with ``--outcome``, :func:`~ladders.study.sequences.cycle_model_analysis.analyze_cycle_outcome`)
on the output of ``symladders cycle-study`` (:mod:`.cycle_cli`). The model's flags
(``--groups`` or ``--design`` with ``--model`` and ``--contrast``, ``--blocks``,
``--tfce``, ``--aha``, ``--fwhm``, ``--outcome``, ``--compare``) are those of
``symladders analyze`` (:mod:`.model_arguments`).
"""

from __future__ import annotations

import sys

from ..sequences.cycle_analysis import MEASURES, MOTION_MEASURES
from .cli_types import (
    DefaultsFormatter,
    OneLineParser,
    UsageError,
    existing_file,
    existing_folder,
    positive_float,
)
from .common_arguments import add_no_progress, add_output, add_permutations, add_seed
from .model_arguments import add_model_arguments, model_request, print_outcome

__all__ = ["add_cycle_analyze_parser", "run_cycle_analyze_command"]

#: What the summaries are called in the printed counts.
_COUNTED_ORDER = ("per_frame", "peak", "time_to_peak", "trajectory")
_COUNTED = {"peak": "peak", "time_to_peak": "time to peak", "per_frame": "some frame",
            "trajectory": "trajectory"}  # fmt: skip


class _LegacyCompareParser(OneLineParser):
    """``cycle-analyze``'s parser: the former ``--compare GROUP REFERENCE`` (two words) is
    read as ``--compare GROUP,REFERENCE``, with a deprecation warning."""

    def parse_known_args(self, args=None, namespace=None):
        args = list(sys.argv[1:] if args is None else args)
        if "--compare" in args:
            i = args.index("--compare")
            pair = args[i + 1 : i + 3]
            if len(pair) == 2 and not any(a.startswith("-") or "," in a for a in pair):
                print("symladders cycle-analyze: warning: '--compare GROUP REFERENCE' is "
                      f"deprecated; write '--compare {pair[0]},{pair[1]}'", file=sys.stderr)  # fmt: skip
                args[i + 1 : i + 3] = [f"{pair[0]},{pair[1]}"]
        return super().parse_known_args(args, namespace)


def add_cycle_analyze_parser(sub) -> None:
    """Register ``cycle-analyze`` on an argparse subparsers object."""
    p = sub.add_parser(
        "cycle-analyze",
        help="the linear model (two groups, or covariates and contrasts) on the transported "
        "cycles: per frame, peak, time to peak and trajectory",
        description=(
            "Test the transported cycles of a cycle study (STUDY, the output of 'symladders "
            "cycle-study') on the normal motion (or, with --measure rotation, the rotation "
            "about the long axis), or a cohort's wall maps (STUDY, the output of 'symladders "
            "wall', with --measure thickness, thickening, radial, circumferential or "
            "longitudinal) at every vertex, by the linear model of 'symladders analyze "
            "--design': two groups (--groups) or a design table with covariates (--design, "
            "--model, --contrast: t per one-row contrast, F over several levels). Each "
            "contrast is tested per frame (FWER over the vertices and frames together), on "
            "each vertex's peak and its time in the cycle, and on its whole trajectory "
            "(Pillai's trace on its first principal components over the cycle), by "
            "Freedman-Lane permutations (FWER over the vertices). OUTPUT holds "
            "cycle_vertices.csv, cycle_frames.csv, cycle_summary.md, cycle_tests.vtu, "
            "cycle_curves.png and cycle_trajectory.png (and cycle_segments.csv with --aha, "
            "outcome.csv with --outcome)."
        ),
        formatter_class=DefaultsFormatter,
    )
    p.add_argument("study", type=existing_folder, metavar="STUDY",
                   help="folder written by 'symladders cycle-study' (or, with a wall measure, "
                        "'symladders wall')")  # fmt: skip
    p.add_argument("--groups", type=existing_file, default=None,
                   help="CSV table with the columns subject and group: two groups compared "
                        "(the model 'group'; instead of --design)")  # fmt: skip
    add_model_arguments(p, "tables per AHA segment (cycle_segments.csv), and the segments of "
                           "--exclude-segments and the long axis of --measure rotation")  # fmt: skip
    add_permutations(p)
    add_seed(p)
    p.add_argument("--measure", choices=tuple(MEASURES), default="normal",
                   help="the curve tested per vertex: the normal motion (mm), or the rotation "
                        "about the long axis (degrees, counter-clockwise seen from the apex; "
                        "what a twist changes; needs --aha), of a cycle study; or, of the maps "
                        "of 'symladders wall', the wall thickness or thickening (mm) or the "
                        "radial, circumferential or longitudinal strain (percent)")  # fmt: skip
    p.add_argument("--min-radius", type=positive_float, default=5.0,
                   help="with --measure rotation: vertices closer to the long axis than this "
                        "(mm) are not tested (their angle is ill-conditioned)")  # fmt: skip
    p.add_argument("--exclude-segments", type=int, nargs="+", default=None, metavar="SEGMENT",
                   help="AHA segments (1-17) left out of the tests, e.g. 17, the apical cap "
                        "thick short-axis slices resolve poorly; needs --aha")  # fmt: skip
    p.add_argument("--summaries", nargs="+", default=list(_COUNTED_ORDER),
                   choices=_COUNTED_ORDER, metavar="SUMMARY",
                   help="the summaries of each vertex's curve tested: per_frame, peak, "
                        "time_to_peak, trajectory")  # fmt: skip
    p.add_argument("--no-figures", action="store_true", help="skip the figures")
    add_no_progress(p)
    add_output(p, None, "analysis folder (default: STUDY/analysis)")
    p.set_defaults(run=run_cycle_analyze_command, output_is_file=False)
    p.__class__ = _LegacyCompareParser


def _landmarks(args):
    """The atlas's landmarks of ``--aha`` (None without it); checks what needs them."""
    from ..cohort.aha_segments import check_segments
    from ..errors import CohortError
    from ..population import read_aha_landmarks

    if args.aha is None:
        if args.measure == "rotation":
            raise UsageError("symladders cycle-analyze: error: --measure rotation: needs --aha "
                             "(the atlas's apex and base-plane centre place the long axis)")  # fmt: skip
        if args.exclude_segments is not None:
            raise UsageError("symladders cycle-analyze: error: --exclude-segments: needs --aha "
                             "(the atlas's landmarks that place the segments)")  # fmt: skip
        return None
    try:
        if args.exclude_segments is not None:
            check_segments(args.exclude_segments, "--exclude-segments")
        return read_aha_landmarks(args.aha)
    except (CohortError, ValueError) as exc:
        raise UsageError(f"symladders cycle-analyze: error: {exc}") from None


def _counts(tests, alpha: float) -> str:
    parts = []
    for summary in ("peak", "time_to_peak", "per_frame", "trajectory"):
        if summary not in tests.tests():
            continue
        text = f"{_COUNTED[summary]} {int(tests.detected(summary, alpha).sum())}"
        if tests.tfce:
            text += f" (TFCE: {int(tests.detected(summary, alpha, tfce=True).sum())})"
        parts.append(("peak rotation" + text[4:]) if summary == "peak" and tests.measure ==
                     "rotation" else text)  # fmt: skip
    return ", ".join(parts)


def run_cycle_analyze_command(args) -> int:
    """The linear model (or two groups) on the cycle study, from parsed arguments."""
    from ..errors import CohortError
    from ..sequences.cycle_model_analysis import analyze_cycle_model, analyze_cycle_outcome

    prefix = "symladders cycle-analyze: error:"
    request = model_request(args, "cycle-analyze")
    landmarks = _landmarks(args)
    curves = {"measure": args.measure, "min_radius": args.min_radius, "fwhm": args.fwhm}
    if args.measure not in MOTION_MEASURES:  # the wall's measures: the maps of 'symladders wall'
        from ..wall import load_wall_cycles

        curves["motion"] = load_wall_cycles(args.study)
    if args.outcome is not None:
        try:
            outcome = analyze_cycle_outcome(
                args.study, request.table, *args.outcome, args.output, baseline=args.baseline,
                landmarks=landmarks, seed=args.seed, source=request.source, **curves,
            )  # fmt: skip
        except (CohortError, ValueError) as exc:
            raise UsageError(f"{prefix} {exc}") from None
        print_outcome(outcome, args.baseline)
        if request.formula is None:
            return 0
    groups = None
    if request.groups:
        groups = tuple(dict.fromkeys(request.table["group"]))
        if args.compare is not None:
            groups = tuple(args.compare)
    try:
        outcome = analyze_cycle_model(
            args.study, request.table, request.formula, request.contrasts, args.output,
            n_permutations=args.permutations, seed=args.seed, tfce=args.tfce,
            landmarks=landmarks, exclude_segments=args.exclude_segments, blocks=args.blocks,
            alpha=args.alpha, groups=groups, summaries=tuple(dict.fromkeys(args.summaries)),
            progress=not args.no_progress, figures=not args.no_figures, source=request.source,
            **curves,
        )  # fmt: skip
    except (CohortError, ValueError) as exc:
        raise UsageError(f"{prefix} {exc}") from None
    first = outcome.tests[0]
    tested = "" if first.tested.all() else f" (of {int(first.tested.sum())} vertices tested)"
    smoothed = "" if args.fwhm is None else f", smoothed {args.fwhm:g} mm FWHM"
    folder = outcome.paths[0].parent
    level = f"FWER {100 * args.alpha:g} %"
    if groups is not None:
        n_first = int(first.labels.sum())
        print(f"symladders cycle-analyze: {groups[0]} ({n_first}) against {groups[1]} "
              f"({len(first.labels) - n_first}), {args.permutations:,} permutations{smoothed}: "
              f"vertices found at {level}: {_counts(first, args.alpha)}{tested}; in {folder}")  # fmt: skip
    else:
        print(f"symladders cycle-analyze: model '{request.formula}', "
              f"{len(outcome.model.kept)} subjects, {args.permutations:,} permutations"
              f"{smoothed}, trajectory on {first.components} component(s){tested}; in {folder}")  # fmt: skip
        for tests in outcome.tests:
            print(f"'{tests.contrast}': vertices found at {level}: {_counts(tests, args.alpha)}")
    if outcome.left_out:
        print(f"left out (not in {request.source.name}): {', '.join(outcome.left_out)}")
    return 0
