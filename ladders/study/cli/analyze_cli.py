"""``symladders analyze``: where the transported motion of two groups differs, from a study folder.

A thin wrapper of :func:`~ladders.study.population.analyze`: it reads the groups
table (and the planted truth, if any), checks them against the study's results
before any computation and writes the analysis folder (tables, ``summary.md``,
maps on the atlas for ParaView, figures).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .cli_types import (
    DefaultsFormatter,
    UsageError,
    existing_file,
    existing_folder,
    positive_float,
    positive_int,
)
from .common_arguments import (
    RECOMMENDED_ALPHA2,
    add_alpha2,
    add_compare,
    add_no_progress,
    add_output,
    add_permutations,
    add_seed,
)

__all__ = ["add_analyze_parser", "run_analyze_command"]


def _columns(text: str) -> tuple[str, str]:
    names = tuple(t.strip() for t in text.split(","))
    if len(names) != 2 or not all(names):
        raise argparse.ArgumentTypeError(f"expected two column names as TIME,EVENT, got {text!r}")
    return names


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
    p.add_argument("--design", type=existing_file, default=None,
                   help="CSV design table: a column subject and any covariates (a linear model "
                        "per vertex instead of two groups; with --model and --contrast)")  # fmt: skip
    p.add_argument("--model", default=None, metavar="FORMULA",
                   help="model formula on the design's columns, e.g. 'group + age + sex'")  # fmt: skip
    p.add_argument("--contrast", nargs="+", default=None, metavar="SPEC",
                   help="contrasts to test, e.g. 'group[patients] - group[controls]', 'age', "
                        "or 'group' (F test over its levels)")  # fmt: skip
    p.add_argument("--blocks", default=None, metavar="COLUMN",
                   help="a design column of exchangeability blocks (e.g. site): permutations "
                        "within blocks")  # fmt: skip
    p.add_argument("--outcome", type=_columns, default=None, metavar="TIME,EVENT",
                   help="design columns of a survival outcome (follow-up time, event 1 or "
                        "censored 0): Cox regression on the motion's PCA scores, cross-validated "
                        "C-index per motion")  # fmt: skip
    p.add_argument("--baseline", nargs="+", default=None, metavar="COLUMN",
                   help="with --outcome: clinical design columns predicted alone for comparison "
                        "(e.g. ejection_fraction)")  # fmt: skip
    p.add_argument("--tfce", action="store_true",
                   help="also threshold-free cluster enhancement (H = 2, E = 1) on the atlas's "
                        "triangles, with its own family-wise p-values")  # fmt: skip
    p.add_argument("--aha", type=existing_file, default=None, metavar="LANDMARKS",
                   help="the atlas's apex, base-plane centre and septal point (a JSON file, or a "
                        "landmark table's row 'atlas'): tables and bull's-eyes per AHA segment")  # fmt: skip
    p.add_argument("--fwhm", type=positive_float, default=None, metavar="MM",
                   help="with the linear model (--design, --tfce or --aha): smooth every "
                        "subject's maps on the atlas before the tests, by the heat kernel of "
                        "this full width at half maximum (mm)")  # fmt: skip
    add_compare(p)
    p.add_argument("--truth", type=existing_file, default=None,
                   help="planted_region.json of a synthetic cohort ('symladders cohort')")  # fmt: skip
    p.add_argument("--null", type=existing_folder, default=None, metavar="NULL_STUDY",
                   help="study of the same subjects without the effect (with --truth)")  # fmt: skip
    add_alpha2(p, None, "alpha^2 values to analyse (default: every one of the study); the "
                        "main motion (the terminal's line, the figures) is the pole ladder with "
                        f"residuals at the study's alpha^2 nearest {RECOMMENDED_ALPHA2:g}, the "
                        "value for group statistics (docs/population.md)")  # fmt: skip
    p.add_argument("--transport", nargs="+", default=None,
                   help="transport methods to analyse, e.g. pole_ladder_residual fanning none")  # fmt: skip
    add_permutations(p)
    p.add_argument("--components", type=positive_int, default=5,
                   help="PCA scores of the global test and the classifier")  # fmt: skip
    p.add_argument("--normalize", choices=("none", "volume"), default="none",
                   help="amplitude normalisation of the transported motion: 'volume' keeps "
                        "each subject's relative volume change (ejection fraction)")  # fmt: skip
    p.add_argument("--alpha", type=positive_float, default=0.05, help="family-wise error level")
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

    if (args.groups is None) == (args.design is None):
        raise UsageError("symladders analyze: error: give --groups or --design (one of them)")
    if args.design is not None:
        return _run_model(args)
    if args.null is not None and args.truth is None:
        raise UsageError("symladders analyze: error: --null needs --truth (the planted region)")
    if not args.alpha < 1:
        raise UsageError(
            f"symladders analyze: error: --alpha: expected a level in (0, 1), got {args.alpha}"
        )
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
        args.design_table = {"subject": list(groups), "group": list(groups.values())}
        args.model = "group"
        args.contrast = [f"group[{c.groups[0]}] - group[{c.groups[1]}]"]
        _run_model(args)
    print(
        f"Tables, maps and figures in {folder}: "
        + ", ".join(Path(p).name for p in outcome.paths.values())
    )
    return 0


def _run_model(args) -> int:
    """The linear-model analysis (``--design``, or the groups with ``--tfce`` / ``--aha`` /
    ``--fwhm``)."""
    from ladders.statistics import read_design

    from ..errors import CohortError
    from ..population import analyze_model, read_aha_landmarks

    if args.outcome is not None:
        if args.design is None:
            raise UsageError("symladders analyze: error: --outcome needs --design")
        _run_outcome(args)
        if args.model is None and not args.contrast:
            return 0
    if args.model is None or not args.contrast:
        raise UsageError(
            "symladders analyze: error: --design needs --model and --contrast (or --outcome)"
        )
    if not args.alpha < 1:
        raise UsageError(
            f"symladders analyze: error: --alpha: expected a level in (0, 1), got {args.alpha}"
        )
    try:
        table = getattr(args, "design_table", None)
        if table is None:
            table = read_design(args.design)
        if args.groups is not None and args.compare is not None:  # the two groups compared
            keep = [g in args.compare for g in table["group"]]
            table = {k: [v for v, y in zip(col, keep) if y] for k, col in table.items()}
        landmarks = None if args.aha is None else read_aha_landmarks(args.aha)
        outcome = analyze_model(
            args.study, table, args.model, args.contrast, args.output, alpha2=args.alpha2,
            methods=args.transport, n_permutations=args.permutations, tfce=args.tfce,
            aha_landmarks=landmarks, blocks=args.blocks,
            normalize=None if args.normalize == "none" else args.normalize, alpha=args.alpha,
            seed=args.seed, progress=not args.no_progress, figures=not args.no_figures,
            fwhm=args.fwhm,
        )  # fmt: skip
    except (CohortError, ValueError) as exc:
        raise UsageError(f"symladders analyze: error: {exc}") from None
    k = outcome.comparisons[0].motion.atlas.shape[0]
    n = len(outcome.comparisons[0].design.subjects)
    print(f"symladders analyze: model '{args.model}', {n} subjects, "
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


def _run_outcome(args) -> None:
    """Survival predicted from every motion (``--outcome TIME,EVENT``)."""
    from ladders.statistics import read_design

    from ..errors import CohortError
    from ..population import analyze_outcome

    try:
        outcome = analyze_outcome(
            args.study, read_design(args.design), *args.outcome, args.output,
            baseline=args.baseline, alpha2=args.alpha2, methods=args.transport,
            n_components=args.components, seed=args.seed,
        )  # fmt: skip
    except (CohortError, ValueError) as exc:
        raise UsageError(f"symladders analyze: error: {exc}") from None
    for m, r in outcome.results:
        base = ("" if r.baseline_c_index is None else
                f"; {', '.join(args.baseline)} alone {r.baseline_c_index:.2f}")  # fmt: skip
        print(f"{m.label}: C-index {r.c_index:.2f} [{r.ci_low:.2f}, {r.ci_high:.2f}]{base}")
    print(f"Outcome tables in {Path(outcome.paths['outcome.csv']).parent}: outcome.csv, "
          "outcome_summary.md")  # fmt: skip
