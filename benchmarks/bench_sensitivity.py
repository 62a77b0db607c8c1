"""Which of the paper's claims hold under which study settings (``docs/study.md``).

Runs the study on the first subjects of the built-in cohort for each setting
(control-point policy x sigma x mesh resolution) and prints, per setting, the
time, the fraction of converged registrations and the paper's claims:

(a) with residuals, the midpoint distance, centrality and involutivity are
    lower than without, at every alpha^2 (mean over subjects);
(b) the registration error rises and the deformation norm falls with alpha^2;
(c) where the transvectivity curve has its minimum, with and without residuals.

Results of each setting are kept in ``--output`` (the study's resumable store),
so an interrupted run resumes; ``--json`` writes the table's numbers.

Usage: ``python benchmarks/bench_sensitivity.py [--subjects 3] [--settings a,b] [--jobs 2]``.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np

ALPHA2 = (0.01, 1.0, 100.0, 1089.0)
ERRORS = ("midpoint_distance", "centrality", "involutivity", "transvectivity")

#: name -> (vertices, sigma, control points, optimise control points, max_iter, ftol)
SETTINGS = {
    "grid-241": (241, 20.0, "grid", False, 1000, 1e-11),
    "dense-241": (241, 20.0, "dense", False, 1000, 1e-11),
    "grid-1009": (1000, 20.0, "grid", False, 1000, 1e-11),
    "grid-sigma10-1009": (1000, 10.0, "grid", False, 1000, 1e-11),
    "finegrid-1009": (1000, 20.0, "finegrid", False, 1000, 1e-11),
    "optimised-grid-241": (241, 20.0, "grid", True, 1000, 1e-8),
    "optimised-grid-1009": (1000, 20.0, "grid", True, 1000, 1e-8),
}


def run_setting(name: str, n_subjects: int, output: Path, jobs: int) -> dict:
    from ladders.study import StudyConfig, make_synthetic_cohort, run_study

    vertices, sigma, policy, optimise, max_iter, ftol = SETTINGS[name]
    cohort = make_synthetic_cohort(n_subjects, n_vertices=vertices, seed=0)
    config = StudyConfig.build(
        alpha2=ALPHA2,
        sigma=sigma,
        control_points=policy,
        optimize_control_points=optimise,
        max_iter=max_iter,
        ftol=ftol,
    )
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        outcome = run_study(
            config,
            cohort.atlas,
            cohort.faces,
            cohort.subjects,
            output / name,
            jobs=jobs,
            progress=False,
            meshes=False,
        )
    return summarise(name, outcome.results, time.perf_counter() - start)


def _mean(results, key, *path):
    values = []
    for r in results:
        node = r["alpha2"].get(str(key))
        for p in path:
            node = node[p]
        values.append(float(node))
    return float(np.mean(values))


def summarise(name: str, results: list[dict], seconds: float) -> dict:
    """Means per alpha^2 and the three claims for one setting."""
    means = {
        str(a): {
            v: {e: _mean(results, a, v, e) for e in (*ERRORS, "ase")}
            for v in ("residual", "no_residual")
        }
        for a in ALPHA2
    }
    reg = [_mean(results, a, "registration_error") for a in ALPHA2]
    norm = [_mean(results, a, "rkhs_norm") for a in ALPHA2]
    pairs = [p for r in results for p in r["alpha2"].values()]
    n_regs = sum(p["n_registrations"] for p in pairs)
    n_bad = sum(p["non_converged_registrations"] for p in pairs)
    claim_a = {
        e: [means[str(a)]["residual"][e] < means[str(a)]["no_residual"][e] for a in ALPHA2]
        for e in ERRORS[:3]
    }
    trans = {v: [means[str(a)][v]["transvectivity"] for a in ALPHA2] for v in means["1.0"]}
    return {
        "setting": name,
        "seconds": seconds,
        "registrations": n_regs,
        "converged_fraction": 1.0 - n_bad / max(n_regs, 1),
        "means": means,
        "registration_error": reg,
        "rkhs_norm": norm,
        "claim_a": claim_a,
        "claim_b": bool(np.all(np.diff(reg) > 0) and np.all(np.diff(norm) < 0)),
        "claim_c": {v: ALPHA2[int(np.argmin(t))] for v, t in trans.items()},
    }


def row(s: dict) -> str:
    a = " ".join(
        f"{e[:4]}:{''.join('y' if ok else 'n' for ok in oks)}" for e, oks in s["claim_a"].items()
    )
    c = ", ".join(f"{v} {a:g}" for v, a in s["claim_c"].items())
    inv = s["means"]["0.01"]
    return (
        f"| {s['setting']} | {s['seconds']:.0f} s | {s['converged_fraction']:.1%} | {a} | "
        f"{'yes' if s['claim_b'] else 'no'} | {c} | "
        f"{inv['residual']['involutivity']:.3f} / {inv['no_residual']['involutivity']:.3f} |"
    )


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=3)
    parser.add_argument("--settings", default=",".join(SETTINGS))
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--output", type=Path, default=Path("symladders-output/sensitivity"))
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    names = [n for n in args.settings.split(",") if n]
    unknown = sorted(set(names) - set(SETTINGS))
    if unknown:
        parser.error(f"--settings: unknown {unknown}; choose from {sorted(SETTINGS)}")
    print(f"alpha^2 = {ALPHA2}, {args.subjects} subjects, per-vertex RMS distances in mm")
    print(
        "| setting | time | converged | (a) residual lower at each alpha^2 | (b) | "
        "(c) transvectivity minimum at | involutivity at 0.01, res / no res |"
    )
    print("| --- | ---: | ---: | --- | --- | --- | --- |")
    summaries = []
    for name in names:
        summaries.append(run_setting(name, args.subjects, args.output, args.jobs))
        print(row(summaries[-1]), flush=True)
    if args.json:
        args.json.write_text(json.dumps(summaries, indent=1))


if __name__ == "__main__":
    main()
