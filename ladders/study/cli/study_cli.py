"""``symladders study``: the paper's Section 3 study on the built-in cohort or a folder of meshes."""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

from .cli_types import DefaultsFormatter, UsageError, check_sigma
from .common_arguments import parallel_backend
from .plugin_arguments import add_plugin_argument
from .preparation_arguments import units_usage_error
from .study_arguments import (
    DEFAULT_ALPHA2,
    DEFAULT_SUBJECTS,
    FULL_ALPHA2,
    FULL_SUBJECTS,
    REGISTRATION_FLAGS,
    add_study_arguments,
)

__all__ = ["add_study_parser", "run_study_command"]


def add_study_parser(sub) -> None:
    """Register the ``study`` subcommand on an argparse subparsers object."""
    p = sub.add_parser(
        "study",
        help="the paper's study: symmetry errors over alpha^2, pole ladder vs fanning, area strain",
        description=(
            "Run the study of the paper's Section 3. Without --meshes it uses the built-in "
            f"synthetic cohort ({DEFAULT_SUBJECTS} subjects, alpha^2 in "
            f"{','.join(f'{a:g}' for a in DEFAULT_ALPHA2)} by default; --full gives the paper's "
            f"setting: {FULL_SUBJECTS} subjects and alpha^2 in "
            f"{','.join(f'{a:g}' for a in FULL_ALPHA2)}). Results are written per subject as "
            "they finish; rerunning with the same output folder resumes and computes only the "
            "missing (subject, alpha^2) pairs."
        ),
        formatter_class=DefaultsFormatter,
    )
    add_study_arguments(p)
    add_plugin_argument(p)
    p.set_defaults(run=run_study_command)


def _check_units(args, cohort, description: dict):
    """The units check of a cohort read from files (before any registration); the cohort in
    mm and the sentence ``summary.md`` states. The built-in cohort is in mm."""
    from ..preparation import UnitsError, check_cohort_units

    flags = [f for f, on in (("--units", args.units), ("--allow-scale", args.allow_scale),
                             ("--allow-pose", args.allow_pose)) if on]  # fmt: skip
    if description["source"] == "synthetic":
        if flags:
            raise UsageError(
                f"symladders study: error: {flags[0]} needs --meshes FOLDER or --cohort TABLE "
                "(the built-in cohort is in mm)"
            )
        description["units"] = {"unit": "mm", "how": "built-in"}
        return cohort, "Lengths in mm, the built-in synthetic cohort's unit."
    try:
        cohort, report = check_cohort_units(
            cohort, units=args.units, allow_scale=args.allow_scale, allow_pose=args.allow_pose
        )
    except UnitsError as exc:
        flag = "--meshes" if args.meshes is not None else "--cohort"
        raise units_usage_error("study", exc, flag) from None
    description["units"] = report.as_dict()
    return cohort, report.describe()


def _load_cohort(args):
    from ..cohort import (
        MissingAtlasError,
        UnusedMeshFilesWarning,
        make_synthetic_cohort,
        read_cohort,
        read_cohort_table,
    )

    n = args.subjects
    if args.atlas is not None and args.meshes is None and args.cohort is None:
        raise UsageError("symladders study: --atlas needs --meshes FOLDER or --cohort TABLE")
    if args.meshes is not None or args.cohort is not None:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", UnusedMeshFilesWarning)
            try:
                if args.meshes is not None:
                    cohort = read_cohort(args.meshes, atlas=args.atlas)
                    description = {"source": "folder", "folder": str(args.meshes.resolve())}
                else:
                    cohort = read_cohort_table(args.cohort, atlas=args.atlas)
                    description = {"source": "table", "table": str(args.cohort.resolve())}
            except MissingAtlasError as exc:
                raise UsageError(
                    f"symladders study: error: {exc.with_hint('--atlas PATH')}"
                ) from None
        for w in caught:  # one readable line each, not a source location
            if issubclass(w.category, UnusedMeshFilesWarning):
                print(f"symladders study: warning: {w.message}", file=sys.stderr)
            else:
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        if args.atlas is not None:
            description["atlas"] = str(args.atlas.resolve())
        if n is not None and n > len(cohort):
            where = "--meshes folder" if args.meshes is not None else "--cohort table"
            raise UsageError(
                f"symladders study: error: --subjects {n}: the {where} holds only "
                f"{len(cohort)} subject(s) (leave --subjects out to use all of them)"
            )
        if n is not None:
            cohort = cohort.head(n)
    else:
        if n is None:
            n = FULL_SUBJECTS if args.full else DEFAULT_SUBJECTS
        cohort = make_synthetic_cohort(n_subjects=n, n_vertices=args.vertices, seed=args.seed)
        description = {
            "source": "synthetic",
            "generator": cohort.source,
            "seed": args.seed,
            "vertices": int(cohort.n_vertices),
        }
    if len(cohort) == 0:
        raise SystemExit("symladders study: the cohort has no subject")
    return cohort, description


def _note_pairs_without_meshes(outcome) -> None:
    """Tell which resumed pairs have no mesh files (they were computed with --no-meshes)."""
    from ..meshes.mesh_outputs import alpha_folder

    root = Path(outcome.output) / "meshes" / outcome.config_id
    bare = [(n, a) for n, a in outcome.skipped if not (root / n / alpha_folder(a)).is_dir()]
    if bare:
        print(
            f"note: {len(bare)} skipped (subject, alpha^2) pair(s) have no mesh files (computed "
            f"with --no-meshes); delete their files under {Path(outcome.output) / 'results'} "
            "to compute them again with meshes"
        )


def _input_files(args, cohort) -> list | None:
    """The files the cohort was read from, exactly (hashed into the manifest): the table
    with ``--cohort``, the atlas and the subjects' meshes; ``None`` for the built-in one."""
    files = list(cohort.input_files)
    if args.cohort is not None:
        files.append(Path(args.cohort))
    return sorted({Path(f).resolve() for f in files}) or None


def _config(args, deformation: str):
    from ..running import StudyConfig

    alpha2 = args.alpha2 or (FULL_ALPHA2 if args.full else DEFAULT_ALPHA2)
    return StudyConfig.build(
        alpha2=tuple(alpha2),
        fanning_steps=args.fanning_steps,
        deformation=deformation,
        distance=args.distance,
        warm_starts=args.warm_starts,
        **{name: getattr(args, name) for name in REGISTRATION_FLAGS},
    )


def _run_one(args, cohort, description, config, output: Path, units: str):
    """Run (or resume) one study into ``output`` (:func:`ladders.study.run`), print its summary."""
    from ..reporting import summarize, terminal_summary
    from ..reporting.report import skipped_markdown
    from ..running import RegistrationCounts
    from ..study_run import run

    print(
        f"symladders study: {len(cohort)} subjects, {cohort.n_vertices} vertices, "
        f"{config.deformation}, alpha^2 = {', '.join(f'{a:g}' for a in config.alpha2)}, "
        f"output {output}"
    )
    print(units)
    with parallel_backend(args, "study"):
        done = run(
            config, cohort, output, jobs=args.jobs, progress=not args.no_progress,
            meshes=not args.no_meshes, units=units, data_description=description,
            input_files=_input_files(args, cohort),
        )  # fmt: skip
    outcome, paths = done.outcome, dict(done.report)
    _note_recomputed(outcome)
    if outcome.skipped:
        print(f"resumed: {len(outcome.skipped)} (subject, alpha^2) pair(s) were already done")
        if not args.no_meshes:
            _note_pairs_without_meshes(outcome)

    rule = config.registration.stopping_rule()
    pairs = [p for r in outcome.results for p in r.pairs]
    if pairs:
        print()
        print(terminal_summary(summarize(outcome.results), pairs[0].unit, len(cohort)))
    counts = RegistrationCounts.total(p.counts for p in pairs)
    print(
        f"Registrations: {counts.n_registrations}; {counts.non_converged} stopped at the "
        f"iteration limit (--max-iter {config.registration.max_iter}) before converging "
        f"({rule!r})."
    )
    skipped = skipped_markdown(outcome.results)
    if skipped:
        print(skipped, end="")
    if "maps_subject" in paths:
        print(f"Fig. 5b shows subject {paths.pop('maps_subject')} (median ASE).")
    print(f"Full tables and figures in {output}:", ", ".join(Path(v).name for v in paths.values()))
    return outcome


def _note_recomputed(outcome) -> None:
    """Say which stored results could not be used and were computed again, and why."""
    if not outcome.recomputed:
        return
    reasons = sorted(set(outcome.recomputed.values()))
    print(
        f"note: {len(outcome.recomputed)} stored (subject, alpha^2) result(s) were computed "
        f"again: {'; '.join(reasons)}",
        file=sys.stderr,
    )


def _write_comparison(outcomes: dict, output: Path) -> Path:
    from ..reporting import write_model_comparison

    path, text = write_model_comparison({m: o.results for m, o in outcomes.items()}, output)
    print(text)
    return path


def _models(args) -> tuple[str, ...]:
    """The models of ``--deformation``, refused here when one cannot take the flags."""
    from ..deformations import deformation_model, deformation_names, parse_deformations

    models = parse_deformations(args.deformation)
    if args.optimize_control_points:
        able = [n for n in deformation_names() if deformation_model(n).optimizes_control_points]
        if any(m not in able for m in models):
            raise UsageError(
                "symladders study: --optimize-control-points works with --deformation "
                f"{' or '.join(able) or 'no registered model'} only"
            )
    return models


def _check_models(configs: dict, atlas) -> None:
    """Every model's interface on the atlas (:func:`check_deformation_model`), before any
    study starts; a broken model is refused in one line naming it and the property."""
    from ..deformations import DeformationModelError, check_deformation_model

    for config in configs.values():
        try:
            check_deformation_model(config.model, atlas, config.registration)
        except DeformationModelError as exc:
            raise UsageError(f"symladders study: error: {exc}") from None


def run_study_command(args) -> int:
    """Run the study from parsed command-line arguments.

    With several models (``--deformation lddmm,svf``, or ``both``) each runs into
    ``OUTPUT/<name>`` and ``OUTPUT/comparison.md`` (and ``.csv``) compares every model
    with the first, subject by subject.
    """
    start = time.perf_counter()
    cohort, description = _load_cohort(args)
    cohort, units = _check_units(args, cohort, description)
    output = Path(args.output)
    models = _models(args)
    configs = {model: _config(args, model) for model in models}
    for config in configs.values():  # before any study starts (run() checks it again)
        check_sigma(cohort.atlas, config.registration)
    _check_models(configs, cohort.atlas)
    outcomes = {}
    for model, config in configs.items():
        folder = output / model if len(models) > 1 else output
        outcomes[model] = _run_one(args, cohort, description, config, folder, units)
    if len(models) > 1:
        print("Comparison:", _write_comparison(outcomes, output))
    print(f"Total wall time {time.perf_counter() - start:.1f} s")
    failed = [(m, o) for m, o in outcomes.items() if o.failures]
    for model, o in failed:
        print(
            f"symladders study: {o.n_failed_subjects} subject(s) failed "
            f"({len(o.failures)} pair(s)){f' ({model})' if len(models) > 1 else ''}; "
            "errors in summary.md and the result files",
            file=sys.stderr,
        )
    return 1 if failed else 0
