"""Speed of the per-vertex linear model with Freedman-Lane permutations.

    python benchmarks/bench_glm.py [--quick] [--publish]

Times :func:`ladders.statistics.glm_test` (10,000 Freedman-Lane permutations, 200
subjects, a design of 4 columns: intercept, group, age, sex; the contrast on group;
1,009 vertices) for displacement vectors (Pillai's trace, ``d = 3``) and for a scalar
per vertex (``t``), against the target of at most 60 s on 2 cores. Each timing is the
best of ``--repeats`` runs (default 1). ``--quick`` runs 500 permutations and
extrapolates to 10,000 (a check of the script, not a measurement to publish).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import (  # noqa: E402
    design_matrix,
    glm_test,
    mesh_adjacency,
)
from ladders.study.cohort.synthetic_lv import make_synthetic_cohort  # noqa: E402

TARGET_S = 60.0
PERMUTATIONS = 10000


def cohort(n: int, rng: np.random.Generator) -> dict[str, list]:
    """A table of ``n`` subjects: two groups, age and sex."""
    return {
        "subject": [f"s{i:03d}" for i in range(n)],
        "group": ["patients" if i % 2 else "controls" for i in range(n)],
        "age": list(np.round(rng.normal(60.0, 10.0, n), 1)),
        "sex": list(rng.choice(["F", "M"], n)),
    }


def measure(dim: int, permutations: int, repeats: int, n: int = 200, tfce: bool = False) -> float:
    """Seconds (best of ``repeats``) of one :func:`glm_test` run (with TFCE if asked)."""
    rng = np.random.default_rng(0)
    design = design_matrix(cohort(n, rng), "group + age + sex")
    k = 1009
    data = rng.standard_normal((n, k, dim) if dim > 1 else (n, k))
    name = "group[patients] - group[controls]"
    adjacency = None
    if tfce:
        atlas = make_synthetic_cohort(1, seed=0)
        adjacency = mesh_adjacency(atlas.faces, atlas.atlas.shape[0])
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        glm_test(data, design, name, permutations, rng=rng, tfce=adjacency)
        best = min(best, time.perf_counter() - start)
    return best


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="500 permutations, extrapolated")
    parser.add_argument("--repeats", type=int, default=1, help="runs per timing (best kept)")
    parser.add_argument("--publish", action="store_true", help="write docs/generated/glm_speed.md")
    args = parser.parse_args(argv)
    if args.quick and args.publish:
        parser.error("--publish needs the full measurement (without --quick)")
    permutations = 500 if args.quick else PERMUTATIONS
    print(machine())
    rows = ["| statistic | permutations | subjects x vertices | design | time | target |",
            "|---|---|---|---|---|---|"]  # fmt: skip
    cases = ((3, "Pillai's trace of displacements (d = 3)", False), (1, "t of a scalar", False),
             (3, "Pillai's trace, with TFCE on the atlas", True),
             (1, "t, with two-sided TFCE on the atlas", True))  # fmt: skip
    for dim, name, tfce in cases:
        seconds = measure(dim, permutations, args.repeats, tfce=tfce) * PERMUTATIONS / permutations
        target = 2 * TARGET_S if tfce else TARGET_S
        met = "met" if seconds <= target else "NOT met"
        note = " (extrapolated from 500)" if args.quick else ""
        print(f"{name}: {seconds:.2f} s for 10,000 permutations{note}; "
              f"target <= {target:g} s: {met}")  # fmt: skip
        rows.append(f"| {name} | 10,000 Freedman-Lane | 200 x 1,009 | intercept, group, age, "
                    f"sex | {seconds:.2f} s | <= {target:g} s: {met} |")  # fmt: skip
    if args.publish:
        publish("glm_speed", "\n".join(rows), "python benchmarks/bench_glm.py --publish")


if __name__ == "__main__":
    main()
