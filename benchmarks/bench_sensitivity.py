"""Which of the paper's claims hold under which study settings (``docs/evidence/developer_notes.md``).

Runs the study on the first subjects of the built-in cohort for each setting
(control points x sigma x mesh resolution, with the study's stopping rule) and
prints, per setting, the compute time, the flow passes, the fraction of converged
registrations and the paper's claims:

(a) with residuals, the midpoint distance, centrality and involutivity are
    lower than without, at every alpha^2: the mean over subjects (one letter per
    alpha^2, ``y`` when it holds), and the share of subjects where it holds;
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

ALPHA2 = (0.01, 0.1, 1.0, 100.0, 1089.0)
ERRORS = ("midpoint_distance", "centrality", "involutivity", "transvectivity")

#: name -> (vertices, registration settings overriding the study's default)
SETTINGS = {
    "grid-241": (241, dict(sigma=20.0, control_points="grid")),
    "dense-241": (241, dict(sigma=20.0, control_points="dense")),
    "grid-1009": (1009, dict(sigma=20.0, control_points="grid")),
    "grid-sigma15-1009": (1009, dict(sigma=15.0, control_points="grid")),
    "grid-sigma10-1009": (1009, dict(sigma=10.0, control_points="grid")),
    "vertices-sigma10-1009": (1009, dict(sigma=10.0, control_points="vertices")),
    "vertices-sigma10-spacing5-1009": (
        1009,
        dict(sigma=10.0, control_points="vertices", control_point_spacing=5.0),
    ),
    "vertices-sigma10-spacing10-1009": (
        1009,
        dict(sigma=10.0, control_points="vertices", control_point_spacing=10.0),
    ),
    "vertices-sigma15-1009": (1009, dict(sigma=15.0, control_points="vertices")),
    "vertices-sigma20-1009": (1009, dict(sigma=20.0, control_points="vertices")),
    "finegrid-1009": (1009, dict(sigma=20.0, control_points="finegrid")),
    "optimised-grid-241": (241, dict(sigma=20.0, optimize_control_points=True)),
    "optimised-grid-1009": (1009, dict(sigma=20.0, optimize_control_points=True)),
}


def run_setting(name: str, n_subjects: int, output: Path, jobs: int, base: dict) -> dict:
    from ladders.study import StudyConfig, make_synthetic_cohort, run_study

    vertices, overrides = SETTINGS[name]
    cohort = make_synthetic_cohort(n_subjects, n_vertices=vertices, seed=0)
    config = StudyConfig.build(alpha2=ALPHA2, **{**base, **overrides})
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


def summarise(name: str, results: list, seconds: float) -> dict:
    """Means per alpha^2 and the three claims for one setting (typed study results)."""
    from ladders.study.running import RegistrationCounts

    def values(a, variant, measure):
        return np.array([r.at(a).measure(variant, measure) for r in results if r.at(a)])

    means = {
        str(a): {
            v: {e: float(values(a, v, e).mean()) for e in ERRORS}
            for v in ("residual", "no_residual")
        }
        for a in ALPHA2
    }
    lower = {
        e: [float(np.mean(values(a, "residual", e) < values(a, "no_residual", e))) for a in ALPHA2]
        for e in ERRORS[:3]
    }
    reg = [float(np.mean([r.at(a).registration.error for r in results])) for a in ALPHA2]
    norm = [float(np.mean([r.at(a).registration.rkhs_norm for r in results])) for a in ALPHA2]
    counts = RegistrationCounts.total(p.counts for r in results for p in r.pairs)
    trans = {v: [means[str(a)][v]["transvectivity"] for a in ALPHA2] for v in means["1.0"]}
    return {
        "setting": name,
        "seconds": seconds,
        "registrations": counts.n_registrations,
        "flow_passes": counts.n_flow_evaluations,
        "converged_fraction": 1.0 - counts.non_converged / max(counts.n_registrations, 1),
        "means": means,
        "fraction_residual_lower": lower,
        "registration_error": reg,
        "rkhs_norm": norm,
        "claim_a": {
            e: [means[str(a)]["residual"][e] < means[str(a)]["no_residual"][e] for a in ALPHA2]
            for e in ERRORS[:3]
        },
        "claim_b": bool(np.all(np.diff(reg) > 0) and np.all(np.diff(norm) < 0)),
        "claim_c": {v: ALPHA2[int(np.argmin(t))] for v, t in trans.items()},
    }


def row(s: dict) -> str:
    a = " ".join(
        f"{e[:4]}:{''.join('y' if ok else 'n' for ok in oks)}" for e, oks in s["claim_a"].items()
    )
    share = " ".join(
        f"{e[:4]}:{'/'.join(f'{f:.0%}' for f in fr)}"
        for e, fr in s["fraction_residual_lower"].items()
    )
    c = ", ".join(f"{v} {a:g}" for v, a in s["claim_c"].items())
    inv = s["means"]["0.01"]
    return (
        f"| {s['setting']} | {s['seconds']:.0f} s | {s['flow_passes']} | "
        f"{s['converged_fraction']:.1%} | {a} | {share} | {'yes' if s['claim_b'] else 'no'} | "
        f"{c} | {inv['residual']['involutivity']:.3f} / {inv['no_residual']['involutivity']:.3f} |"
    )


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=3)
    parser.add_argument("--settings", default=",".join(SETTINGS))
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--output", type=Path, default=Path("symladders-output/sensitivity"))
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument(
        "--registration",
        default="{}",
        help="JSON of registration settings applied to every setting (e.g. the stopping rule)",
    )
    args = parser.parse_args(argv)
    names = [n for n in args.settings.split(",") if n]
    unknown = sorted(set(names) - set(SETTINGS))
    if unknown:
        parser.error(f"--settings: unknown {unknown}; choose from {sorted(SETTINGS)}")
    base = json.loads(args.registration)
    print(f"alpha^2 = {ALPHA2}, {args.subjects} subjects, per-vertex RMS distances in mm")
    print(
        "| setting | time | flow passes | converged | (a) residual lower (means) at each "
        "alpha^2 | share of subjects | (b) | (c) transvectivity minimum at | "
        "involutivity at 0.01, res / no res |"
    )
    print("| --- | ---: | ---: | ---: | --- | --- | --- | --- | --- |")
    summaries = []
    for name in names:
        summaries.append(run_setting(name, args.subjects, args.output, args.jobs, base))
        print(row(summaries[-1]), flush=True)
    if args.json:
        args.json.write_text(json.dumps(summaries, indent=1))


if __name__ == "__main__":
    main()
