"""``symladders analyze``: where the transported motion of two groups differs, from a study folder.

A thin wrapper of :func:`~ladders.study.population.analyze`: it reads the groups
table (and the planted truth, if any), checks them against the study's results
before any computation and writes the analysis folder (tables, ``summary.md``,
maps on the atlas for ParaView, figures).
"""

from __future__ import annotations

from pathlib import Path

from .cli_types import (
    DefaultsFormatter,
    UsageError,
    existing_file,
    existing_folder,
    positive_int,
)
from .common_arguments import (
    RECOMMENDED_ALPHA2,
    add_alpha2,
    add_no_progress,
    add_output,
    add_permutations,
    add_seed,
)
from .model_arguments import add_model_arguments, model_request, print_outcome

__all__ = ["add_analyze_parser", "run_analyze_command"]


def add_analyze_parser(sub) -> None:
    """Register the ``analyze`` subcommand on an argparse subparsers object."""
    p = sub.add_parser(
        "analyze",
        help="compare two groups' transported motion on the atlas (per vertex, global, classifier)",
        description=(
            "Compare the transported motion of two groups of subjects in a study's results: "
            "per atlas vertex, Hotelling T^2 of the displacement T' - T, t of its component "
            "along the atlas's normal, t of the area strain and t of the normal wall motion "
            "(the signed distance along the atlas's normal to the surface T'), with the "
            "family-wise error controlled by permutations of the group labels; a global "
            "permutation test on the first PCA scores; a cross-validated classifier's AUC. "
            "Every transport and alpha^2 of the study is analysed, and the motion without "
            "transport (S' - S). With --truth, every transport is scored "
            "against the planted region (power, Dice); with --null, the false-positive rate "
            "is measured on a study without the effect."
        ),
        formatter_class=DefaultsFormatter,
    )
    p.add_argument("study", type=existing_folder, metavar="STUDY_OUTPUT",
                   help="folder written by 'symladders study'")  # fmt: skip
    p.add_argument("--groups", type=existing_file, default=None,
                   help="CSV table with the columns subject and group")  # fmt: skip
    add_model_arguments(
        p,
        "tables and bull's-eyes per AHA segment",
        fwhm_when="with the linear model (--design, --tfce or --aha): ",
    )
    p.add_argument("--truth", type=existing_file, default=None,
                   help="planted_region.json of a synthetic cohort ('symladders cohort')")  # fmt: skip
    p.add_argument("--null", type=existing_folder, default=None, metavar="NULL_STUDY",
                   help="study of the same subjects without the effect (with --truth)")  # fmt: skip
    add_alpha2(p, None, "alpha^2 values to analyse (default: every one of the study); the "
                        "main motion (the terminal's line, the figures) is the pole ladder with "
                        f"residuals at the study's alpha^2 nearest {RECOMMENDED_ALPHA2:g}, the "
                        "value for group statistics (docs/population.md, 'Choosing the transport and alpha^2')")  # fmt: skip
    p.add_argument("--transport", nargs="+", default=None,
                   help="transport methods to analyse, e.g. pole_ladder_residual fanning none")  # fmt: skip
    add_permutations(p)
    p.add_argument("--components", type=positive_int, default=5,
                   help="PCA scores of the global test and the classifier")  # fmt: skip
    p.add_argument("--normalize", choices=("none", "volume"), default="none",
                   help="amplitude normalisation of the transported motion: 'volume' keeps "
                        "each subject's relative volume change (ejection fraction)")  # fmt: skip
    p.add_argument("--null-repetitions", type=positive_int, default=200,
                   help="random splits of the null study")  # fmt: skip
    add_seed(p)
    add_output(p, None, "analysis folder (default: STUDY_OUTPUT/analysis)")
    p.add_argument("--no-figures", action="store_true", help="skip the figures")
    add_no_progress(p)
    p.set_defaults(run=run_analyze_command, output_is_file=False)


def run_analyze_command(args) -> int:
    """Run the analysis from parsed arguments."""
    from ..cohort import read_groups
    from ..errors import CohortError
    from ..population import analyze, read_planted_region

    request = model_request(args, "analyze")
    if not request.groups:
        return _run_model(args, request)
    if args.null is not None and args.truth is None:
        raise UsageError("symladders analyze: error: --null needs --truth (the planted region)")
    try:
        groups = read_groups(args.groups)
        region = None if args.truth is None else read_planted_region(args.truth)
        outcome = analyze(
            args.study, groups, args.output, compare=args.compare, alpha2=args.alpha2,
            methods=args.transport, region=region, null_output=args.null,
            n_permutations=args.permutations, n_components=args.components,
            normalize=None if args.normalize == "none" else args.normalize, alpha=args.alpha,
            seed=args.seed, n_null_repetitions=args.null_repetitions,
            progress=not args.no_progress, figures=not args.no_figures,
        )  # fmt: skip
    except CohortError as exc:
        raise UsageError(f"symladders analyze: error: {exc}") from None
    c = outcome.main
    k = c.displacement.statistic.size
    print(
        f"symladders analyze: {c.groups[0]} ({int(c.labels.sum())}) against {c.groups[1]} "
        f"({int((~c.labels).sum())}), {len(outcome.comparisons)} motion(s), {k} atlas vertices"
    )
    if outcome.left_out:
        print(f"left out (in neither group): {', '.join(outcome.left_out)}")
    print(
        f"{c.motion.label} ({c.motion.name}): {int(c.detected(args.alpha).sum())} vertices with a "
        f"different displacement, {int(c.detected(args.alpha, 'strain').sum())} with a different "
        f"strain, {int(c.detected(args.alpha, 'wall_motion').sum())} with a different normal "
        f"wall motion (FWER {args.alpha:g}); global p = {c.global_test.p_permutation:.2g}; "
        f"AUC {c.classifier.auc:.2f} [{c.classifier.ci_low:.2f}, {c.classifier.ci_high:.2f}]"
    )
    folder = Path(outcome.paths["summary.md"]).parent
    if args.tfce or args.aha is not None or args.fwhm is not None:
        _run_model(args, request)
    print(
        f"Tables, maps and figures in {folder}: "
        + ", ".join(Path(p).name for p in outcome.paths.values())
    )
    return 0


def _run_model(args, request) -> int:
    """The linear-model analysis (``--design``, or the groups with ``--tfce`` / ``--aha`` /
    ``--fwhm``)."""
    from ..errors import CohortError
    from ..population import analyze_model, read_aha_landmarks

    if args.outcome is not None:
        _run_outcome(args, request)
        if request.formula is None:
            return 0
    try:
        landmarks = None if args.aha is None else read_aha_landmarks(args.aha)
        outcome = analyze_model(
            args.study, request.table, request.formula, request.contrasts, args.output,
            alpha2=args.alpha2, methods=args.transport, n_permutations=args.permutations,
            tfce=args.tfce, aha_landmarks=landmarks, blocks=args.blocks,
            normalize=None if args.normalize == "none" else args.normalize, alpha=args.alpha,
            seed=args.seed, progress=not args.no_progress, figures=not args.no_figures,
            fwhm=args.fwhm, source=request.source,
        )  # fmt: skip
    except (CohortError, ValueError) as exc:
        raise UsageError(f"symladders analyze: error: {exc}") from None
    k = outcome.comparisons[0].motion.atlas.shape[0]
    n = len(outcome.comparisons[0].design.subjects)
    print(f"symladders analyze: model '{request.formula}', {n} subjects, "
          f"{len(outcome.comparisons)} motion(s) x contrast(s), {k} atlas vertices"
          + ("" if args.fwhm is None else f", maps smoothed {args.fwhm:g} mm FWHM"))  # fmt: skip
    if outcome.left_out:
        print(f"left out (not in the design): {', '.join(outcome.left_out)}")
    for c in outcome.main:
        counts = ", ".join(
            f"{test} {int(c.detected(args.alpha, test).sum())}"
            + (f" (TFCE {int(c.detected(args.alpha, test, tfce=True).sum())})" if args.tfce else "")
            for test in ("displacement", "normal", "strain", "wall_motion")
        )
        print(
            f"{c.motion.label}, '{c.contrast}': vertices detected (FWER {args.alpha:g}): {counts}"
        )
    folder = Path(outcome.paths["model_summary.md"]).parent
    print(f"Model tables, maps and figures in {folder}: "
          + ", ".join(Path(p).name for p in outcome.paths.values()))  # fmt: skip
    return 0


def _run_outcome(args, request) -> None:
    """Survival predicted from every motion (``--outcome TIME,EVENT``)."""
    from ..errors import CohortError
    from ..population import analyze_outcome

    try:
        outcome = analyze_outcome(
            args.study, request.table, *args.outcome, args.output,
            baseline=args.baseline, alpha2=args.alpha2, methods=args.transport,
            n_components=args.components, seed=args.seed, source=request.source,
        )  # fmt: skip
    except (CohortError, ValueError) as exc:
        raise UsageError(f"symladders analyze: error: {exc}") from None
    print_outcome(outcome, args.baseline)
