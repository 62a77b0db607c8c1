"""Speed of the per-vertex permutation test: 10,000 permutations of 40 subjects x 1,009 vertices.

    python benchmarks/bench_permutation.py [--publish]

Times :func:`ladders.statistics.vertexwise_test` on random data of the default
two-group cohort's size (40 subjects, 20 per group, 1,009 atlas vertices) for
displacement vectors (Hotelling ``T^2``, ``d = 3``) and for a scalar per vertex
(``t``), with the peak memory the test allocates (tracemalloc), against the target
of at most 30 s on 2 cores. Each timing is the best of three runs.
"""

from __future__ import annotations

import argparse
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import vertexwise_test  # noqa: E402

TARGET_S = 30.0


def measure(dim: int, n: int = 40, k: int = 1009, permutations: int = 10000) -> tuple[float, float]:
    rng = np.random.default_rng(0)
    shape = (n, k, dim) if dim > 1 else (n, k)
    data = rng.standard_normal(shape)
    groups = np.arange(n) < n // 2
    best = np.inf
    for _ in range(3):
        start = time.perf_counter()
        vertexwise_test(data, groups, permutations, rng=rng)
        best = min(best, time.perf_counter() - start)
    tracemalloc.start()
    vertexwise_test(data, groups, permutations, rng=rng)
    peak = tracemalloc.get_traced_memory()[1] / 2**20
    tracemalloc.stop()
    return best, peak


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--publish", action="store_true", help="write docs/generated/permutations.md"
    )
    args = parser.parse_args(argv)
    print(machine())
    rows = ["| test | permutations | subjects x vertices | time (best of 3) | peak memory | target |",
            "|---|---|---|---|---|---|"]  # fmt: skip
    for dim, name in ((3, "Hotelling T^2 of displacements (d = 3)"), (1, "t of area strain")):
        seconds, peak = measure(dim)
        met = "met" if seconds <= TARGET_S else "NOT met"
        print(f"{name}: {seconds:.2f} s, peak {peak:.0f} MB; target <= {TARGET_S:g} s: {met}")
        rows.append(f"| {name} | 10,000 | 40 x 1,009 | {seconds:.2f} s | {peak:.0f} MB | "
                    f"<= {TARGET_S:g} s: {met} |")  # fmt: skip
    if args.publish:
        publish("permutations", "\n".join(rows), "python benchmarks/bench_permutation.py --publish")


if __name__ == "__main__":
    main()
