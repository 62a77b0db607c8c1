"""Whole cycles through the study and the analysis, against the planted truth and the ideal transport.

    python benchmarks/bench_cycle_study.py                      # studies (resumed), then the table
    python benchmarks/bench_cycle_study.py --publish            # docs/generated/cycle_study.md
    python benchmarks/bench_cycle_study.py --quick              # 12 subjects, 10 frames

Cohorts (:func:`~ladders.study.population.make_two_group_cycles`, seed 0, 20 patients
against 20 controls, 1,009 vertices, 25 frames, ES at 35 % of the cycle): the
whole-cycle hypokinesia (:data:`~ladders.study.population.CYCLE_ABNORMALITY`, half the
motion in segments 7, 8, 13 and 14) and its mild form (a fifth of the motion). The
frames are the meshes in correspondence (no segmentation: this measures the transport
and the tests, not a tracking route). Every frame is transported to the atlas with the
pole ladder with residuals (:func:`~ladders.study.sequences.run_cycle_study`, LDDMM at
``alpha^2`` in :data:`ALPHA2`), beside the motion without transport. Per motion:

* the distance to the ideal transport of every frame
  (:func:`~ladders.study.population.ideal_cycle_transport`), the mean over the vertices,
  frames and subjects, and at the ES frame;
* power and Dice against the planted region of the peak inward normal motion's test
  and of the per-frame test (a vertex found at some frame), FWER 5 %;
* the null FWER of the peak test from random 10-against-10 splits of the controls,
  with its binomial interval (splits of one group: a rate, not independent studies).
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import binomial_interval, detection_power, dice  # noqa: E402
from ladders.study.population import (  # noqa: E402
    CYCLE_ABNORMALITY,
    ideal_cycle_transport,
    make_two_group_cycles,
)
from ladders.study.sequences import (  # noqa: E402
    CycleMotion,
    compare_cycles,
    load_cycle_motion,
    run_cycle_study,
)

COHORTS = {"hypokinesia": CYCLE_ABNORMALITY,
           "hypokinesia_mild": replace(CYCLE_ABNORMALITY, magnitude=0.2)}  # fmt: skip
ALPHA2 = (1.0, 100.0)


def _cycles(name: str, n: int, n_frames: int):
    return make_two_group_cycles(n_subjects=n, abnormality=COHORTS[name], n_frames=n_frames)


def run_studies(work: Path, n: int, n_frames: int, jobs: int) -> None:
    for name in COHORTS:
        c = _cycles(name, n, n_frames)
        sequences = {s: c.frames[i] for i, s in enumerate(c.names)}
        for alpha2 in ALPHA2:
            start = time.perf_counter()
            out = run_cycle_study(c.data.cohort.atlas, c.faces, sequences,
                                  work / name / f"alpha2_{alpha2:g}", alpha2=alpha2, jobs=jobs)  # fmt: skip
            print(f"  {name}, alpha^2 = {alpha2:g}: {len(out.computed)} subjects transported, "
                  f"{len(out.failures)} failed, {time.perf_counter() - start:.0f} s",
                  flush=True)  # fmt: skip


def null_splits(motion: CycleMotion, controls, rng, repetitions: int):
    """``repetitions`` random halves of the controls: ``(motion of the two halves, labels)``.

    Each split is drawn from ``rng`` when it is requested, so a caller that also draws
    its permutations from ``rng`` between splits keeps one reproducible stream."""
    for _ in range(repetitions):
        order = rng.permutation(controls)
        half = len(order) // 2
        keep = np.sort(order[: 2 * half])
        sub = CycleMotion(tuple(motion.subjects[i] for i in keep), motion.displacement[keep],
                          motion.atlas, motion.faces)  # fmt: skip
        yield sub, np.isin(keep, order[:half])


def _null_rate(motion: CycleMotion, controls, rng, repetitions: int, permutations: int):
    hits = 0
    for sub, labels in null_splits(motion, controls, rng, repetitions):
        found = compare_cycles(sub, labels, permutations, rng, summaries=("peak",)).peak.p_fwer
        hits += bool((found < 0.05).any())
    return hits / repetitions, *binomial_interval(hits, repetitions)


def _rows(work: Path, n: int, n_frames: int, permutations: int, repetitions: int, rng):
    rows = []
    for name in COHORTS:
        c = _cycles(name, n, n_frames)
        ideal = ideal_cycle_transport(c)
        es = int(round(0.35 * n_frames))
        region = c.data.region.affected
        motions = [("no transport", CycleMotion(c.names, c.frames - c.frames[:, :1],
                                                c.data.cohort.atlas, c.faces))]  # fmt: skip
        for alpha2 in ALPHA2:
            folder = work / name / f"alpha2_{alpha2:g}"
            if (folder / "cycle_study.json").is_file():
                motions.append((f"pole ladder, with residuals, alpha^2 = {alpha2:g}",
                                load_cycle_motion(folder)))  # fmt: skip
        for label, motion in motions:
            order = [c.names.index(s) for s in motion.subjects]
            distance = np.linalg.norm(motion.displacement - ideal[order], axis=-1).mean(axis=-1)
            patients = c.patients[order]
            tests = compare_cycles(motion, patients, permutations, rng,
                                   summaries=("per_frame", "peak"))  # fmt: skip
            peak = tests.peak.p_fwer < 0.05
            frames = (tests.per_frame.p_fwer < 0.05).any(axis=0)
            rate = _null_rate(motion, np.flatnonzero(~patients), rng, repetitions,
                              min(permutations, 500))  # fmt: skip
            rows.append((name, label, len(motion.subjects), distance[:, 1:].mean(),
                         distance[:, es].mean(), detection_power(peak, region), dice(peak, region),
                         detection_power(frames, region), dice(frames, region), rate))  # fmt: skip
            print(rows[-1], flush=True)
    return rows


def _table(rows, n_frames: int, permutations: int, repetitions: int) -> str:
    lines = [
        "| cohort | motion | subjects | distance to the ideal, all frames / ES (mm) | peak test: "
        "power / Dice | per-frame test: power / Dice | null FWER of the peak test [95 % CI] |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, label, n, d_all, d_es, pp, pd, fp, fd, (rate, low, high) in rows:
        lines.append(f"| {name} | {label} | {n} | {d_all:.2f} / {d_es:.2f} | {pp:.2f} / {pd:.2f} "
                     f"| {fp:.2f} / {fd:.2f} | {rate:.2f} [{low:.2f}, {high:.2f}] |")  # fmt: skip
    note = (
        f"Two groups of synthetic subjects through {n_frames} frames of the cycle (meshes in "
        "correspondence, ES at 35 %); hypokinesia of segments 7, 8, 13 and 14 at half (and, "
        f"mild, a fifth of) the motion. {permutations:,} permutations, FWER 5 %; null: "
        f"{repetitions} random splits of the controls in two halves."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stage", choices=("studies", "tables", "all"), default="all")
    parser.add_argument("--work", type=Path, default=Path("symladders-output/bench_cycle_study"))
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    n, n_frames = (12, 10) if args.quick else (40, 25)
    permutations, repetitions = (500, 10) if args.quick else (5000, 100)
    if args.stage in ("studies", "all"):
        run_studies(args.work, n, n_frames, args.jobs)
    if args.stage in ("tables", "all"):
        start = time.perf_counter()
        rows = _rows(args.work, n, n_frames, permutations, repetitions, np.random.default_rng(0))
        table = _table(rows, n_frames, permutations, repetitions)
        print(f"\n{table}\n({time.perf_counter() - start:.0f} s)")
        if args.publish:
            publish("cycle_study", table, "python benchmarks/bench_cycle_study.py --publish")


if __name__ == "__main__":
    main()
