"""The one command on a synthetic cohort written as a user holds it: what it finds, adjusted.

    python benchmarks/bench_route.py [--subjects 40] [--work DIR] [--draws 200] [--publish]

Two cohorts of ``make_covariate_cohort`` are written as a user holds them
(``symladders cohort --images labels``' writer: label images of 1.5 mm voxels with a
right-ventricle label, ``subjects.csv`` with group, age, sex and body size,
``study.toml``), with an age confound: the patients are older and larger (``--imbalance`` 1: two
standard deviations of age and body size) and age reduces every subject's contraction (10 % per
standard deviation). The first has the default hypokinesia planted in the patients;
the second none (the null). Each goes through ``symladders run study.toml`` with the
recommended settings, as written.

* **The effect**: the power and Dice of the maps against the planted segments, read
  from the run's own output (``report.md``'s table, :func:`~ladders.study.route.truth_scores`
  on ``analysis/model_vertices.csv``), for the model the table implies (``group + age
  + sex + body_size``) and, on the same study, for the unadjusted ``group``.
* **The null**: on the null cohort's study, the family-wise error rate of the group
  contrast over ``--draws`` designs whose group labels are drawn anew with the
  confound kept (a subject is a patient with probability increasing with its age,
  logistic with slope 1 per standard deviation, half the subjects on average): the
  fraction of draws with at least one vertex found, with its exact binomial interval,
  adjusted and unadjusted, on the normal wall motion of the pole ladder with residuals
  (the permutation test ``symladders analyze --design`` runs on it, the motion read once).
* **The rerun**: the same command again; every step is reused.

The tables go to ``docs/generated/route_cohort.md`` (with ``--imbalance`` other than 1,
``route_cohort_imbalance_<value without its point>.md``, e.g. ``..._05`` for 0.5) and,
once marked there, the regions of the same names in ``docs/evidence/route_evidence.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import binomial_interval  # noqa: E402
from ladders.study.cohort.planted_effect import MotionAbnormality  # noqa: E402
from ladders.study.population import (  # noqa: E402
    Covariates,
    analyze_model,
    make_covariate_cohort,
)
from ladders.study.population.analysis import select_motions  # noqa: E402
from ladders.study.population.image_cohort import write_image_cohort  # noqa: E402
from ladders.study.population.model_comparison import model_tests  # noqa: E402
from ladders.study.population.model_design import model_design  # noqa: E402
from ladders.study.population.transported_motion import load_transported_motion  # noqa: E402
from ladders.study.route import truth_scores  # noqa: E402

ADJUSTED = "group + age + sex + body_size"
CONTRAST = "group[patients] - group[controls]"


def _cohort(folder: Path, n: int, effect: bool, seed: int, imbalance: float) -> Path:
    abnormality = MotionAbnormality() if effect else None
    data = make_covariate_cohort(
        [n // 2, n - n // 2], (("controls", None), ("patients", abnormality)),
        Covariates(age_effect=0.1, imbalance=imbalance), seed=seed,
    )  # fmt: skip
    write_image_cohort(data, folder, spacing=1.5)
    return folder / "study.toml"


def _run(settings: Path) -> tuple[float, str]:
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "ladders.study.cli", "run", str(settings)],
                          capture_output=True, text=True, check=False)  # fmt: skip
    seconds = time.perf_counter() - start
    if done.returncode not in (0, 1):
        raise SystemExit(f"symladders run {settings} failed ({done.returncode}):\n"
                         f"{done.stdout[-3000:]}\n{done.stderr[-3000:]}")  # fmt: skip
    return seconds, done.stdout


def _design(folder: Path) -> dict:
    import csv

    with open(folder / "study_results" / "analysis" / "design.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    return {k: [r[k] for r in rows] for k in rows[0]}


def _scores(results: Path, truth: Path, formula: str, n_permutations: int) -> dict:
    """Power and Dice of the normal wall motion (pole ladder with residuals), max-t and TFCE."""
    if formula == ADJUSTED:
        vertices = results / "analysis" / "model_vertices.csv"
    else:
        out = results / "bench_unadjusted"
        analyze_model(results / "study", _design(results.parent), formula, [CONTRAST], out,
                      methods=["pole_ladder_residual"], n_permutations=n_permutations, tfce=True,
                      aha_landmarks=_landmarks(results), progress=False, figures=False)  # fmt: skip
        vertices = out / "model_vertices.csv"
    scores = {s["test"]: s for s in truth_scores(vertices, truth, 0.05)
              if s["method"] == "pole_ladder_residual"}  # fmt: skip
    return {k: scores[k] for k in ("wall_motion", "wall_motion (TFCE)", "normal")}


def _landmarks(results: Path):
    from ladders.study.population import read_aha_landmarks

    return read_aha_landmarks(results / "atlas" / "atlas_landmarks.csv")


def _null_rate(folder: Path, draws: int, n_permutations: int, seed: int) -> dict:
    """The FWER of the group contrast over designs whose labels keep the age confound.

    The normal wall motion of the pole ladder with residuals is read once; each draw
    tests it with the model's permutation test (:func:`model_tests`, the test
    ``analyze_model`` runs on it), adjusted and unadjusted.
    """
    design = _design(folder)
    age = np.array(design["age"], float)
    z = (age - age.mean()) / age.std()
    rng = np.random.default_rng(seed)
    motion = select_motions(load_transported_motion(folder / "study_results" / "study"), None,
                            ["pole_ladder_residual"])[0]  # fmt: skip
    wall_motion = dict(zip(motion.subjects, motion.wall_motion))  # computed once
    hits = {"adjusted": 0, "unadjusted": 0}
    done = 0
    while done < draws:
        patients = rng.random(age.size) < 1.0 / (1.0 + np.exp(-z))
        if min(patients.sum(), (~patients).sum()) < 5:
            continue
        table = dict(design, group=["patients" if p else "controls" for p in patients])
        for name, formula in (("adjusted", ADJUSTED), ("unadjusted", "group")):
            model = model_design(table, formula, [CONTRAST], motion.subjects, None)
            response = np.stack([wall_motion[s] for s in model.kept])
            tests = model_tests({"wall_motion": response}, model.design, CONTRAST,
                                n_permutations, rng)  # fmt: skip
            hits[name] += bool(tests["wall_motion"].significant(0.05).any())
        done += 1
    return {k: (v / draws, *binomial_interval(v, draws)) for k, v in hits.items()}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=40)
    parser.add_argument("--draws", type=int, default=200, help="null designs drawn")
    parser.add_argument("--null-permutations", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--imbalance",
        type=float,
        default=1.0,
        help="the patients' shift of age and body size (Covariates)",
    )
    parser.add_argument("--work", type=Path, default=None, help="scratch folder (default: temp)")
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as scratch:
        work = args.work or Path(scratch)
        rows, timing = {}, {}
        for name, effect in (("effect", True), ("null", False)):
            folder = work / name
            settings = folder / "study.toml"
            if not settings.is_file():
                _cohort(
                    folder, args.subjects, effect, args.seed + (0 if effect else 1), args.imbalance
                )
            timing[name] = _run(settings)
            print(f"{name}: symladders run in {timing[name][0]:.0f} s", flush=True)
        rerun, out = _run(work / "effect" / "study.toml")
        reused = all(": reused (" in line for line in out.splitlines() if line.startswith("["))
        truth = work / "effect" / "planted_region.json"
        results = work / "effect" / "study_results"
        for label, formula in (("adjusted (the table's model)", ADJUSTED),
                               ("unadjusted (group)", "group")):  # fmt: skip
            rows[label] = _scores(results, truth, formula, 10000)
        null = _null_rate(work / "null", args.draws, args.null_permutations, args.seed)
        record = json.loads((results / "run.json").read_text())
        design = _design(work / "effect")
        patients = np.array([g == "patients" for g in design["group"]], float)
        corr = {c: float(np.corrcoef(patients, np.array(design[c], float))[0, 1])
                for c in ("age", "body_size")}  # fmt: skip
    lines = [
        f"{args.subjects} subjects (half patients with the planted hypokinesia of segments 7, "
        f"8, 13, 14), older and larger patients (imbalance {args.imbalance:g}: correlation of the "
        f"group with age {corr['age']:.2f}, with body size {corr['body_size']:.2f}) and age "
        "reducing the contraction (10 % per "
        "SD), label images of 1.5 mm voxels with an RV label; `symladders run study.toml` as "
        "written (1,000-vertex meshes, alpha^2 = 100, 10,000 permutations, TFCE). Normal wall "
        "motion, pole ladder with residuals, read from the run's `analysis/model_vertices.csv`.",
        "",
        "| model | power | Dice | power, TFCE | Dice, TFCE | null FWER [95% CI] |",
        "|---|---:|---:|---:|---:|---|",
    ]
    for (label, s), key in zip(rows.items(), ("adjusted", "unadjusted")):
        rate, low, high = null[key]
        lines.append(
            f"| {label} | {s['wall_motion']['power']:.2f} | {s['wall_motion']['dice']:.2f} | "
            f"{s['wall_motion (TFCE)']['power']:.2f} | {s['wall_motion (TFCE)']['dice']:.2f} | "
            f"{rate:.3f} [{low:.3f}, {high:.3f}] |"
        )
    steps = ", ".join(f"{k} {v['seconds']:.0f} s" for k, v in record["steps"].items()
                      if "seconds" in v)  # fmt: skip
    lines += [
        "",
        f"Null FWER: {args.draws} designs of the null cohort's study with the group labels "
        "drawn anew, the age confound kept (logistic in age), "
        f"{args.null_permutations} permutations each; exact binomial intervals. The run's "
        f"steps took {sum(v.get('seconds', 0.0) for v in record['steps'].values()):.0f} s "
        f"({steps}; {machine()}, load "
        f"{os.getloadavg()[0]:.1f} at the end); the second run {rerun:.0f} s, "
        + ("every step reused." if reused else "NOT every step reused."),
    ]
    table = "\n".join(lines)
    print(table)
    if args.publish:
        name, flag = "route_cohort", ""
        if args.imbalance != 1.0:  # a table of its own per imbalance
            name = f"route_cohort_imbalance_{args.imbalance:g}".replace(".", "")
            flag = f" --imbalance {args.imbalance:g}"
        publish(name, table, f"python benchmarks/bench_route.py{flag} --publish")


if __name__ == "__main__":
    main()
