"""Where transport pays: groups that differ in anatomy only, and in anatomy plus a regional effect.

    python benchmarks/bench_anatomy.py                   # studies (resumed), then the tables
    python benchmarks/bench_anatomy.py --stage studies
    python benchmarks/bench_anatomy.py --publish         # docs/generated/anatomy_transport.md
    python benchmarks/bench_anatomy.py --quick           # 8 per group, alpha^2 = 1 only

Cohorts (:func:`~ladders.study.population.make_covariate_cohort`, seed 0, 20 per
group, 1,009 vertices, the default covariates): ``anatomy``, controls against a
dilated, rounder group (:data:`SHIFT`: every length times 1.15, the base radius
times 1.1 more, the mid-ventricular bulge + 0.05) whose motion parameters are drawn
from the same distribution and act on their own anatomy (the same motion relative to
the anatomy); ``anatomy_effect``, the same with the default hypokinesia planted in the
dilated group. Every subject's ideal transport is known
(:func:`~ladders.study.population.ideal_transport`: its own motion parameters on the
atlas's anatomy). Studies: LDDMM and SVF at every ``alpha^2`` of the default study
(:data:`ALPHA2`), all transports of the default study. For every transport, and the motion without
transport, with and without the volume normalisation:

* the distance to the ideal transport (mean over the vertices, per subject; the
  median over each group of the ``anatomy`` cohort);
* anatomy only: the fraction of the atlas's vertices found at FWER 5 % (the
  displacement's and the normal component's tests, 20 against 20: every one is a
  false positive relative to the anatomy) and the rate of random 10-against-10
  subsamples with any vertex found, with its binomial interval (overlapping
  subsamples of one cohort: a rate, not independent replications);
* anatomy plus effect: power and Dice of both tests against the planted region.

The motion without transport is also volume-normalised as a transported motion would
be (its ``S' - S`` scaled on the atlas to the subject's volume change): the
normalisation without any transport, to tell what the transport adds to it.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import binomial_interval, detection_power, dice, vertexwise_test  # noqa: E402
from ladders.study import StudyConfig, run_study  # noqa: E402
from ladders.study.errors import CohortError  # noqa: E402
from ladders.study.population import (  # noqa: E402
    DEFAULT_ABNORMALITY,
    AnatomyShift,
    compare_groups,
    ideal_transport,
    load_transported_motion,
    make_covariate_cohort,
    normalize_motion,
    transport_error,
)
from ladders.study.wall_motion import outward_vertex_normals  # noqa: E402

SHIFT = AnatomyShift(scale=1.15, sphericity=1.1, bulge=0.05)
COHORTS = {
    "anatomy": (("controls", None), ("dilated", SHIFT)),
    "anatomy_effect": (("controls", None), ("dilated", DEFAULT_ABNORMALITY, SHIFT)),
}
ALPHA2 = (0.01, 0.1, 1.0, 10.0, 33.0, 100.0, 1089.0)  # the default study's grid
PLAN = (("lddmm", ALPHA2), ("svf", ALPHA2))


def _cohort(name: str, n: int):
    return make_covariate_cohort(n, COHORTS[name], seed=0)


def run_studies(work: Path, n: int, plan, jobs: int) -> None:
    for name in COHORTS:
        cohort = _cohort(name, n).cohort
        for deformation, alpha2 in plan:
            out = work / "studies" / name / deformation
            start = time.perf_counter()
            outcome = run_study(StudyConfig.build(alpha2=alpha2, deformation=deformation),
                                cohort.atlas, cohort.faces, cohort.subjects, out, jobs=jobs,
                                progress=False, meshes=False)  # fmt: skip
            print(f"  {name}/{deformation}: {len(outcome.computed)} pairs computed, "
                  f"{len(outcome.failures)} failed, {time.perf_counter() - start:.0f} s",
                  flush=True)  # fmt: skip


def _motions(work: Path, name: str):
    motions = []
    for deformation, _ in PLAN:
        folder = work / "studies" / name / deformation
        if folder.is_dir():
            motions += [m for m in load_transported_motion(folder)
                        if not (m.method == "none" and any(x.method == "none" for x in motions))]  # fmt: skip
    return motions


def _normal(motion) -> np.ndarray:
    normals = outward_vertex_normals(motion.atlas, motion.faces)
    return np.einsum("nkd,kd->nk", motion.displacement, normals)


def _subsample_rate(motion, labels, rng, repetitions: int, permutations: int):
    """Rate of random half-size subsamples (per group) with any vertex found."""
    cases, controls = np.flatnonzero(labels), np.flatnonzero(~labels)
    hits = 0
    for _ in range(repetitions):
        rows = np.concatenate([rng.choice(cases, len(cases) // 2, replace=False),
                               rng.choice(controls, len(controls) // 2, replace=False)])  # fmt: skip
        test = vertexwise_test(motion.displacement[rows], labels[rows], permutations, rng)
        hits += bool((test.p_fwer < 0.05).any())
    return hits / repetitions, *binomial_interval(hits, repetitions)


def _label(m) -> str:
    if m.method == "none":
        return "no transport"
    prefix = "" if m.label.startswith(m.deformation.upper()) else f"{m.deformation.upper()} "
    return f"{prefix}{m.label}, alpha^2 = {m.alpha2:g}"


def _load_rows(path: Path) -> dict:
    """Rows measured before (``rows.json`` in the work folder), by label."""
    if not path.is_file():
        return {}
    return {r["label"]: r for r in json.loads(path.read_text())}


def _rows(work, n, permutations, repetitions, rng):
    """Every motion's row; rows of ``work/rows.json`` are kept (a rerun measures the rest)."""
    cache = work / "rows.json"
    done = _load_rows(cache)
    data = {name: _cohort(name, n) for name in COHORTS}
    ideal = ideal_transport(data["anatomy"])
    groups = np.array([data["anatomy"].groups[s.name] == "dilated"
                       for s in data["anatomy"].cohort.subjects])  # fmt: skip
    region = data["anatomy_effect"].regions["dilated"].affected
    effect = {m.name: m for m in _motions(work, "anatomy_effect")}
    rows = []
    for motion in _motions(work, "anatomy"):
        for normalize in (None, "volume"):
            label = _label(motion) + (", volume-normalised" if normalize else "")
            source, effect_motion = motion, effect[motion.name]
            if normalize and motion.method == "none":  # S' - S itself scaled on the atlas
                label = "no transport, volume-normalised (S' - S scaled on the atlas)"
            if label in done:
                rows.append(done[label])
                continue
            try:
                m, scales = (source, None) if normalize is None else normalize_motion(source)
            except CohortError as exc:  # a transported motion no scale brings to the ratio
                print(f"{motion.name}, volume-normalised: {exc}", flush=True)
                rows.append({"label": label, "failed": str(exc)})
                continue
            order = [data["anatomy"].cohort.names.index(s) for s in m.subjects]
            error = transport_error(m.displacement, ideal[order])
            labels = groups[order]
            null = compare_groups(m, labels, ("dilated", "controls"), permutations, rng=rng)
            rate = _subsample_rate(m, labels, rng, repetitions, min(permutations, 1000))
            try:
                e = compare_groups(effect_motion, labels, ("dilated", "controls"),
                                   permutations, rng=rng, normalize=normalize)  # fmt: skip
                found = {t: e.detected(0.05, t) for t in ("displacement", "normal")}
            except CohortError as exc:  # the effect cohort's normalisation
                print(f"{motion.name} with the effect, {normalize}: {exc}", flush=True)
                found = {t: None for t in ("displacement", "normal")}
            rows.append({
                "label": label, "rate": list(rate),
                "scale_max": None if scales is None else float(scales.max()),
                "ideal_controls": float(np.median(error[~labels])),
                "ideal_dilated": float(np.median(error[labels])),
                "null_displacement": float(null.detected(0.05, "displacement").mean()),
                "null_normal": float(null.detected(0.05, "normal").mean()),
                "null_global_p": float(null.global_test.p_permutation),
                **{f"power_{t}": None if f is None else detection_power(f, region)
                   for t, f in found.items()},
                **{f"dice_{t}": None if f is None else dice(f, region) for t, f in found.items()},
            })  # fmt: skip
            print(rows[-1], flush=True)
            done[label] = rows[-1]
            cache.write_text(json.dumps(list(done.values()), indent=1))
    return rows


def _pair(row: dict, test: str) -> str:
    if row[f"power_{test}"] is None:
        return "undefined"
    return f"{row[f'power_{test}']:.2f} / {row[f'dice_{test}']:.2f}"


def _table(rows, n, permutations, repetitions) -> str:
    lines = [
        "| transport | distance to the ideal, controls / dilated (mm) | anatomy only: vertices "
        "found, displacement / normal | anatomy only: global test p | anatomy only: 10 v 10 "
        "subsamples with a false vertex [95 % CI] | anatomy + effect: power / Dice, displacement "
        "| anatomy + effect: power / Dice, normal |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if "failed" in r:
            who = re.search(r"subject (\S+)'s", r["failed"])
            lines.append(f"| {r['label']} | undefined: no scale in [0, 16] reaches the volume "
                         f"change of {who.group(1) if who else 'a subject'} | | | | | |")  # fmt: skip
            continue
        rate, low, high = r["rate"]
        lines.append(
            f"| {r['label']} | {r['ideal_controls']:.2f} / {r['ideal_dilated']:.2f} | "
            f"{100 * r['null_displacement']:.0f} % / {100 * r['null_normal']:.0f} % | "
            f"{r['null_global_p']:.3g} | {rate:.2f} [{low:.2f}, {high:.2f}] | "
            f"{_pair(r, 'displacement')} | {_pair(r, 'normal')} |"
        )
    note = (
        f"{n} controls against {n} dilated subjects (every length x {SHIFT.scale}, base radius "
        f"x {SHIFT.sphericity} more, bulge + {SHIFT.bulge}), the same motion relative to the "
        f"anatomy; with the effect, the default hypokinesia in the dilated group. "
        f"{permutations:,} permutations, FWER 5 %; {repetitions} subsamples."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stage", choices=("studies", "tables", "all"), default="all")
    parser.add_argument("--work", type=Path, default=Path("symladders-output/bench_anatomy"))
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    n = 8 if args.quick else 20
    plan = (("lddmm", (1.0,)),) if args.quick else PLAN
    permutations, repetitions = (500, 10) if args.quick else (5000, 100)
    if args.stage in ("studies", "all"):
        run_studies(args.work, n, plan, args.jobs)
    if args.stage in ("tables", "all"):
        start = time.perf_counter()
        rows = _rows(args.work, n, permutations, repetitions, np.random.default_rng(0))
        table = _table(rows, n, permutations, repetitions)
        print(f"\n{table}\n({time.perf_counter() - start:.0f} s)")
        if args.publish:
            publish("anatomy_transport", table, "python benchmarks/bench_anatomy.py --publish")


if __name__ == "__main__":
    main()
