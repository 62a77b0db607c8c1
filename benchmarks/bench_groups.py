"""Two groups against four: the F test over a factor and each disease against the controls.

    python benchmarks/bench_groups.py                 # 100 null cohorts, 20 with the effects
    python benchmarks/bench_groups.py --publish       # docs/generated/groups_four.md

Four groups of 12 subjects (:func:`~ladders.study.population.make_covariate_cohort`,
a new seed each time): controls and three diseases with distinct planted
hypokineses (segments 7, 8, 13, 14 as the default; 1, 2, 7, 8, basal and mid
anteroseptal; 4, 5, 10, 11, inferior and inferolateral), as in studies that compare
several diseases with controls (Guigui et al., ISBI 2021: four groups). The motion
without transport ``S' - S`` (no study needed) is tested per vertex on its normal
component by the model ``group`` (Freedman-Lane, FWER 5 % over the vertices):

* the F test over the four levels (``"group"``): any difference among the groups;
* each disease against the controls (``"group[d] - group[controls]"``), with its own
  family-wise error (no correction over the three contrasts), scored against its own
  planted region; and the same pair analysed alone, as a two-group study of the same
  24 subjects would.

Under the null (four groups without any effect) each test's family-wise error with
its 95 % binomial interval.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import binomial_interval, design_matrix, detection_power, dice, glm_test  # noqa: E402
from ladders.study.cohort import MotionAbnormality  # noqa: E402
from ladders.study.population import make_covariate_cohort  # noqa: E402
from ladders.study.wall_motion import outward_vertex_normals  # noqa: E402

DISEASES = {
    "apical_septal": MotionAbnormality(),
    "basal_anteroseptal": MotionAbnormality(segments=(1, 2, 7, 8)),
    "inferolateral": MotionAbnormality(segments=(4, 5, 10, 11)),
}


def _normal(data) -> np.ndarray:
    c = data.cohort
    normals = outward_vertex_normals(c.atlas, c.faces)
    return np.stack([np.einsum("kd,kd->k", s.es - s.ed, normals) for s in c.subjects])


def _tests(data, permutations, rng) -> dict:
    """Detections per test: the F test, each disease in the four-group model and alone."""
    names = [s.name for s in data.cohort.subjects]
    table = data.design_table()
    y = _normal(data)
    design = design_matrix(table, "group", subjects=names, reference={"group": "controls"})
    out = {"F over the four groups": glm_test(y, design, "group", permutations, rng).p_fwer < 0.05}
    for d in DISEASES:
        contrast = f"group[{d}] - group[controls]"
        out[f"{d}, four-group model"] = (
            glm_test(y, design, contrast, permutations, rng).p_fwer < 0.05
        )
        keep = [i for i, g in enumerate(table["group"]) if g in (d, "controls")]
        pair = {k: [v[i] for i in keep] for k, v in table.items()}
        two = design_matrix(pair, "group", subjects=[names[i] for i in keep],
                            reference={"group": "controls"})  # fmt: skip
        out[f"{d}, two groups alone"] = (
            glm_test(y[keep], two, contrast, permutations, rng).p_fwer < 0.05
        )
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--null", type=int, default=100)
    parser.add_argument("--effect", type=int, default=20)
    parser.add_argument("--per-group", type=int, default=12)
    parser.add_argument("--permutations", type=int, default=1000)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    rng = np.random.default_rng(0)
    start = time.perf_counter()
    null_groups = (("controls", None),) + tuple((d, None) for d in DISEASES)
    hits: dict = {}
    for r in range(args.null):
        data = make_covariate_cohort(args.per_group, null_groups, seed=3000 + r)
        for key, found in _tests(data, args.permutations, rng).items():
            hits[key] = hits.get(key, 0) + bool(found.any())
    groups = (("controls", None),) + tuple(DISEASES.items())
    scores: dict = {}
    for r in range(args.effect):
        data = make_covariate_cohort(args.per_group, groups, seed=4000 + r)
        union = np.zeros(data.cohort.atlas.shape[0], dtype=bool)
        for d in DISEASES:
            union |= data.regions[d].affected
        for key, found in _tests(data, args.permutations, rng).items():
            d = key.split(",")[0]
            affected = union if d not in DISEASES else data.regions[d].affected
            scores.setdefault(key, []).append(
                (detection_power(found, affected), dice(found, affected))
            )
    lines = ["| test | FWER under the null [95 % CI] | power / Dice against its planted region |",
             "|---|---|---|"]  # fmt: skip
    for key, h in hits.items():
        low, high = binomial_interval(h, args.null)
        p = np.mean(scores[key], axis=0)
        lines.append(f"| {key.replace('_', ' ')} | {h / args.null:.3f} [{low:.3f}, {high:.3f}] | "
                     f"{p[0]:.2f} / {p[1]:.2f} |")  # fmt: skip
    note = (
        f"Four groups of {args.per_group} (controls; hypokinesia, half the motion, in segments "
        "7, 8, 13, 14 / 1, 2, 7, 8 / 4, 5, 10, 11); the normal component of the motion without "
        f"transport; model `group`, {args.permutations:,} Freedman-Lane permutations; "
        f"{args.null} null cohorts, {args.effect} with the effects "
        f"({time.perf_counter() - start:.0f} s). The F test is scored against the union of "
        "the three regions."
    )
    table = note + "\n\n" + "\n".join(lines) + "\n"
    print(table)
    if args.publish:
        publish("groups_four", table, "python benchmarks/bench_groups.py --publish")


if __name__ == "__main__":
    main()
