"""``symladders study``: the paper's Section 3 study on the built-in cohort or a folder of meshes."""

from __future__ import annotations

import argparse
import contextlib
import json
import time

import numpy as np

from .cli_types import (
    check_grid_sigma,
    existing_folder,
    jobs_count,
    nonnegative_int,
    output_folder,
    positive_float,
    positive_int,
    scheduler_address,
)

__all__ = ["add_study_parser", "run_study_command", "DEFAULT_ALPHA2", "FULL_ALPHA2"]

FULL_ALPHA2 = (0.01, 0.1, 1.0, 10.0, 33.0, 100.0, 1089.0)
DEFAULT_ALPHA2 = FULL_ALPHA2
DEFAULT_SUBJECTS = 40
FULL_SUBJECTS = 138


def _floats(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from exc
    if not values or any(not np.isfinite(v) or v <= 0 for v in values):
        raise argparse.ArgumentTypeError(f"expected positive numbers, got {text!r}")
    return values


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
            "they finish; rerunning with the same output folder resumes and skips finished "
            "subjects."
        ),
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    p.add_argument(
        "--output",
        "-o",
        type=output_folder,
        default="symladders-output/study",
        help="results folder",
    )
    p.add_argument(
        "--meshes",
        type=existing_folder,
        default=None,
        help="folder of meshes (atlas.<ext>, <subject>_ed.<ext>, <subject>_es.<ext>; "
        "PLY/OBJ/STL/OFF/VTK) instead of the built-in synthetic cohort",
    )
    p.add_argument(
        "--subjects",
        type=positive_int,
        default=None,
        help=f"number of subjects to use (default {DEFAULT_SUBJECTS} built-in, all with --meshes)",
    )
    p.add_argument(
        "--full",
        action="store_true",
        help=f"the paper's setting: {FULL_SUBJECTS} subjects and the 7-value alpha^2 sweep",
    )
    p.add_argument(
        "--alpha2", type=_floats, default=None, help="comma-separated alpha^2 values (eq. 3)"
    )
    p.add_argument(
        "--vertices", type=positive_int, default=241, help="vertices of the built-in meshes"
    )
    p.add_argument("--seed", type=nonnegative_int, default=0, help="seed of the built-in cohort")
    p.add_argument(
        "--sigma", type=positive_float, default=20.0, help="kernel width (mesh units, mm)"
    )
    p.add_argument(
        "--control-points", choices=("grid", "dense"), default="grid", help="control points"
    )
    p.add_argument("--integrator", choices=("euler", "rk2", "rk4"), default="euler")
    p.add_argument("--n-steps", type=positive_int, default=10, help="time steps of the shooting")
    p.add_argument(
        "--max-iter", type=positive_int, default=100, help="L-BFGS-B iterations per registration"
    )
    p.add_argument(
        "--fanning-steps", type=positive_int, default=10, help="steps of the fanning scheme"
    )
    p.add_argument(
        "--kernel-backend",
        choices=("auto", "numpy", "numba"),
        default="auto",
        help="kernel sums: numba (extra 'fast') when installed, else numpy",
    )
    p.add_argument(
        "--jobs", "-j", type=jobs_count, default=-1, help="parallel workers (-1: all cores)"
    )
    p.add_argument(
        "--backend",
        choices=("loky", "dask"),
        default="loky",
        help="joblib backend; 'dask' runs subjects on a Dask cluster (extra 'cluster')",
    )
    p.add_argument(
        "--scheduler",
        type=scheduler_address,
        default=None,
        help="address of a running Dask scheduler (with --backend dask); default: a local cluster",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(run=run_study_command)


def _load_cohort(args):
    from .mesh_io import read_cohort
    from .synthetic_lv import make_synthetic_cohort

    n = args.subjects
    if args.meshes is not None:
        cohort = read_cohort(args.meshes)
        description = {"source": "folder", "folder": str(args.meshes.resolve())}
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


@contextlib.contextmanager
def _backend(args):
    if args.backend != "dask":
        yield
        return
    try:
        from dask.distributed import Client
        from joblib import parallel_config
    except ImportError as exc:
        raise SystemExit(
            "symladders study: --backend dask needs the optional extra: "
            "pip install 'symladders[cluster]'"
        ) from exc
    client = Client(args.scheduler) if args.scheduler else Client(processes=True)
    try:
        with parallel_config(backend="dask"):
            yield
    finally:
        client.close()


def run_study_command(args) -> int:
    """Run the study from parsed command-line arguments."""
    from .pipeline import StudyConfig
    from .report import summarize, summary_markdown, write_report
    from .runner import run_study

    start = time.perf_counter()
    cohort, description = _load_cohort(args)
    check_grid_sigma(cohort.atlas, args.sigma, args.control_points)
    alpha2 = args.alpha2 or (FULL_ALPHA2 if args.full else DEFAULT_ALPHA2)
    config = StudyConfig(
        alpha2=tuple(alpha2),
        sigma=args.sigma,
        control_points=args.control_points,
        integrator=args.integrator,
        n_steps=args.n_steps,
        max_iter=args.max_iter,
        fanning_steps=args.fanning_steps,
        kernel_backend=args.kernel_backend,
    )
    print(
        f"symladders study: {len(cohort)} subjects, {cohort.n_vertices} vertices, "
        f"alpha^2 = {', '.join(f'{a:g}' for a in alpha2)}, output {args.output}"
    )
    with _backend(args):
        outcome = run_study(
            config,
            cohort.atlas,
            cohort.faces,
            cohort.subjects,
            args.output,
            jobs=args.jobs,
            progress=not args.no_progress,
            data_description=description,
        )
    if outcome.skipped:
        print(f"resumed: {len(outcome.skipped)} subject(s) already finished were skipped")
    paths = write_report(
        outcome.results, args.output, cohort.atlas, cohort.faces, cohort.subjects[0].ed
    )
    n_regs = sum(a["n_registrations"] for r in outcome.results for a in r["alpha2"].values())
    n_bad = sum(r["non_converged_registrations"] for r in outcome.results)
    print()
    print(summary_markdown(summarize(outcome.results)))
    print(
        f"Registrations: {n_regs}; {n_bad} stopped at the iteration limit (--max-iter "
        f"{config.max_iter}) before meeting the optimiser's tolerance."
    )
    print("Files:", json.dumps({k: str(v) for k, v in paths.items()}, indent=1))
    print(f"Total wall time {time.perf_counter() - start:.1f} s")
    return 0
