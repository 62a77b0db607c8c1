"""Vertex max-T against TFCE against AHA segments: power, Dice and the null FWER of each.

    python benchmarks/bench_inference.py --work symladders-output/bench_population
    python benchmarks/bench_inference.py --publish     # docs/generated/inference_*.md

Reads the studies of ``bench_population.py`` (its ``studies`` stage must have run)
and, for each arm and cohort found (meshes in correspondence or segmentations; the
default and the mild hypokinesia), tests the two groups on the normal wall motion and
on the normal component of the displacement with the linear model ``"group"``
(:func:`ladders.study.population.compare_model`, Freedman-Lane permutations):

* per vertex, max-T over the atlas vertices;
* per vertex, TFCE (``H = 2``, ``E = 1``, the atlas's triangles), max over the vertices;
* per AHA segment (the subjects' segment means), max-T over the 17 segments.

Scores against the planted truth: power (fraction of the affected vertices found),
Dice, and for the segments the planted segments found and the others flagged. The
null FWER of each inference comes from random 20/20 splits of the arm's null study
(the same subjects without the abnormality), with its 95 % binomial interval.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import binomial_interval, design_matrix, detection_power, dice  # noqa: E402
from ladders.study.cohort import MotionAbnormality  # noqa: E402
from ladders.study.population import (  # noqa: E402
    aha_segments,
    compare_model,
    load_transported_motion,
    make_two_group_cohort,
)
from ladders.study.preparation.synthetic_landmarks import synthetic_landmarks  # noqa: E402

COHORTS = {"hypokinesia": MotionAbnormality(), "hypokinesia_mild": MotionAbnormality(magnitude=0.2)}
ARMS = {
    "corresponded": "meshes in correspondence",
    "segmentations": "segmentations (posed, landmarks)",
}
TESTS = ("wall_motion", "normal")
CONTRAST = "group[patients] - group[controls]"


def _motions(work: Path, arm: str, name: str, alpha2: tuple):
    folder = work / "studies" / arm / name / "lddmm"
    if not folder.is_dir():
        return []
    keep = [m for m in load_transported_motion(folder)
            if m.method in ("none", "pole_ladder_residual") and (m.alpha2 is None or m.alpha2 in alpha2)]  # fmt: skip
    return keep


def _design(subjects, groups):
    return design_matrix({"subject": list(subjects), "group": [groups[s] for s in subjects]},
                         "group")  # fmt: skip


def _score(motion, groups, affected, planted, segments, permutations, seed):
    c = compare_model(motion, _design(motion.subjects, groups), CONTRAST, permutations,
                      np.random.default_rng(seed), tfce=True, segments=segments)  # fmt: skip
    out = {}
    for test in TESTS:
        vertex = c.detected(0.05, test)
        cluster = c.detected(0.05, test, tfce=True)
        found = set(np.flatnonzero(c.segment_tests[test].p_fwer < 0.05) + 1)
        out[test] = (
            detection_power(vertex, affected), dice(vertex, affected),
            detection_power(cluster, affected), dice(cluster, affected),
            len(found & planted), len(found - planted),
        )  # fmt: skip
    return out


def _null(motion, segments, repetitions, permutations, seed):
    """Any detection under random splits of the null cohort, per test and inference."""
    rng = np.random.default_rng(seed)
    n = len(motion.subjects)
    hits = {(t, i): 0 for t in TESTS for i in ("vertex", "tfce", "segments")}
    for _ in range(repetitions):
        first = set(rng.permutation(n)[: n // 2])
        groups = {
            s: "patients" if i in first else "controls" for i, s in enumerate(motion.subjects)
        }
        c = compare_model(motion, _design(motion.subjects, groups), CONTRAST, permutations, rng,
                          tfce=True, segments=segments)  # fmt: skip
        for t in TESTS:
            hits[(t, "vertex")] += bool(c.detected(0.05, t).any())
            hits[(t, "tfce")] += bool(c.detected(0.05, t, tfce=True).any())
            hits[(t, "segments")] += bool((c.segment_tests[t].p_fwer < 0.05).any())
    return {key: (h / repetitions, *binomial_interval(h, repetitions)) for key, h in hits.items()}


def _label(motion) -> str:
    return motion.label + ("" if motion.alpha2 is None else f", alpha^2 = {motion.alpha2:g}")


def _fmt(rate):
    return f"{rate[0]:.3f} [{rate[1]:.3f}, {rate[2]:.3f}]"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("symladders-output/bench_population"))
    parser.add_argument("--permutations", type=int, default=5000)
    parser.add_argument("--null-repetitions", type=int, default=100)
    parser.add_argument("--null-permutations", type=int, default=500)
    parser.add_argument("--alpha2", type=float, nargs="+", default=[1.0, 100.0])
    parser.add_argument("--arms", nargs="+", choices=tuple(ARMS), default=list(ARMS))
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    start = time.perf_counter()
    for arm in args.arms:
        arm_label = ARMS[arm]
        nulls = {m.name: m for m in _motions(args.work, arm, "null", tuple(args.alpha2))}
        lines = [
            "| cohort | motion | test | vertex max-T power / Dice | TFCE power / Dice "
            "| AHA segments: planted found (of 4) / others | null FWER: vertex | TFCE | segments |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for name, abnormality in COHORTS.items():
            data = make_two_group_cohort(n_subjects=40, abnormality=abnormality, seed=0)
            lm = synthetic_landmarks(data.cohort.atlas)
            segments = aha_segments(data.cohort.atlas, lm.apex, lm.base, lm.septum)
            planted = set(abnormality.segments)
            for motion in _motions(args.work, arm, name, tuple(args.alpha2)):
                scores = _score(motion, data.groups, data.region.affected, planted, segments,
                                args.permutations, 0)  # fmt: skip
                null = None
                if motion.name in nulls:
                    null = _null(nulls[motion.name].subset(motion.subjects), segments,
                                 args.null_repetitions, args.null_permutations, 1)  # fmt: skip
                for test in TESTS:
                    s = scores[test]
                    cells = (["-"] * 3 if null is None else
                             [_fmt(null[(test, i)]) for i in ("vertex", "tfce", "segments")])  # fmt: skip
                    lines.append(
                        f"| {name.replace('_', ' ')} | {_label(motion)} | {test.replace('_', ' ')} "
                        f"| {s[0]:.2f} / {s[1]:.2f} | {s[2]:.2f} / {s[3]:.2f} | {s[4]} / {s[5]} | "
                        + " | ".join(cells)
                        + " |"
                    )
                    print(lines[-1], flush=True)
        if len(lines) == 2:
            continue
        note = (
            f"{arm_label}; 40 subjects (20 patients) of `make_two_group_cohort(seed=0)`; model "
            f"`group`, Freedman-Lane, {args.permutations:,} permutations; TFCE H = 2, E = 1 on "
            f"the atlas's triangles; null: {args.null_repetitions} random 20/20 splits of the "
            f"same subjects without the abnormality, {args.null_permutations:,} permutations "
            f"each, 95 % binomial intervals ({time.perf_counter() - start:.0f} s so far)."
        )
        table = note + "\n\n" + "\n".join(lines) + "\n"
        print(table)
        if args.publish:
            publish(f"inference_{arm}", table, "python benchmarks/bench_inference.py --publish")


if __name__ == "__main__":
    main()
