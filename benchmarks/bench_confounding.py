"""Adjusted against unadjusted group maps when a covariate acting on the motion differs by group.

    python benchmarks/bench_confounding.py               # 200 null cohorts, 40 with an effect
    python benchmarks/bench_confounding.py --quick       # 20 and 5
    python benchmarks/bench_confounding.py --publish     # docs/generated/confounding.md

Each repetition draws a cohort of 20 controls and 20 patients
(:func:`~ladders.study.population.make_covariate_cohort`, a new seed each time) whose
patients are older and larger than the controls (``imbalance`` 1: two standard
deviations of age and of body size); age reduces the contraction by ``age_effect``
per standard deviation and body size scales the heart. Under the null the groups
differ only by those covariates; with an effect the patients also carry the default
hypokinesia. The motion without transport ``S' - S`` (the generator's meshes are in
correspondence: no study needed; the inference is the same for a transported motion)
is tested per vertex, normal component (``t``) and displacement (Pillai's trace), by
the model ``group`` (unadjusted) and ``group + age + body_size`` (adjusted),
Freedman-Lane permutations, FWER 5 % over the 1,009 vertices. Reported: the
fraction of null cohorts with any vertex detected (the family-wise error, with its
95 % binomial interval) and, with the effect, power and Dice against the planted
region.
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
from ladders.study.population import (  # noqa: E402
    DEFAULT_ABNORMALITY,
    Covariates,
    make_covariate_cohort,
)
from ladders.study.wall_motion import outward_vertex_normals  # noqa: E402

MODELS = {
    "unadjusted (group)": "group",
    "adjusted (group + age + body size)": "group + age + body_size",
}
CONTRAST = "group[patients] - group[controls]"


def _responses(data):
    cohort = data.cohort
    disp = np.stack([s.es - s.ed for s in cohort.subjects])
    normals = outward_vertex_normals(cohort.atlas, cohort.faces)
    return {"normal": np.einsum("nkd,kd->nk", disp, normals), "displacement": disp}


def _detections(data, permutations, rng):
    table = data.design_table()
    subjects = [s.name for s in data.cohort.subjects]
    responses = _responses(data)
    out = {}
    for label, formula in MODELS.items():
        design = design_matrix(table, formula, subjects=subjects)
        for test, y in responses.items():
            out[(label, test)] = glm_test(y, design, CONTRAST, permutations, rng).p_fwer < 0.05
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--permutations", type=int, default=1000)
    parser.add_argument("--age-effect", type=float, default=0.15)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    n_null, n_effect = (20, 5) if args.quick else (200, 40)
    covariates = Covariates(imbalance=1.0, age_effect=args.age_effect)
    rng = np.random.default_rng(0)
    start = time.perf_counter()
    hits = {key: 0 for key in ((m, t) for m in MODELS for t in ("normal", "displacement"))}
    for r in range(n_null):
        data = make_covariate_cohort(20, (("controls", None), ("patients", None)),
                                     covariates=covariates, seed=1000 + r)  # fmt: skip
        for key, found in _detections(data, args.permutations, rng).items():
            hits[key] += bool(found.any())
    power = {key: [] for key in hits}
    for r in range(n_effect):
        data = make_covariate_cohort(20, (("controls", None), ("patients", DEFAULT_ABNORMALITY)),
                                     covariates=covariates, seed=2000 + r)  # fmt: skip
        affected = data.regions["patients"].affected
        for key, found in _detections(data, args.permutations, rng).items():
            power[key].append((detection_power(found, affected), dice(found, affected)))
    seconds = time.perf_counter() - start
    lines = ["| model | test | FWER under the null [95 % CI] | power / Dice with the effect |",
             "|---|---|---|---|"]  # fmt: skip
    for (model, test), h in hits.items():
        low, high = binomial_interval(h, n_null)
        p = np.mean(power[(model, test)], axis=0)
        lines.append(f"| {model} | {test} | {h / n_null:.3f} [{low:.3f}, {high:.3f}] | "
                     f"{p[0]:.2f} / {p[1]:.2f} |")  # fmt: skip
    note = (
        f"{n_null} null cohorts and {n_effect} with the default hypokinesia, 20 controls "
        f"against 20 patients older and larger by two standard deviations (age effect "
        f"{args.age_effect:g} of the contraction per standard deviation); the motion without "
        f"transport; {args.permutations:,} Freedman-Lane permutations per test "
        f"({seconds:.0f} s)."
    )
    table = note + "\n\n" + "\n".join(lines) + "\n"
    print(table)
    if args.publish:
        publish("confounding", table, "python benchmarks/bench_confounding.py --publish")


if __name__ == "__main__":
    main()
