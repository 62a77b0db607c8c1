"""Peak memory of registering 10,242-point shapes (target: < 1 GB).

An icosphere with 10,242 vertices scaled to an ellipsoid (semi-axes 1, 0.7, 0.5)
is registered onto its bent-and-twisted copy (sigma = 0.5, alpha = 0.02, 10 Euler
steps) through ``LDDMMLandmarks``: with grid control points (the default above
1,000 vertices) for 20 iterations with each kernel backend, and with dense control
points (10,242 x 10,242 kernel pairs, evaluated blockwise or fused) for a few
iterations. Each case runs in its own process; its peak resident set size
(``ru_maxrss``) is printed with the time per iteration.

Usage: ``python benchmarks/bench_memory.py [--dense-iterations N] [--publish]``
(``--publish``: the table ``docs/generated/memory.md``, with the CPU).
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
import warnings
from pathlib import Path

TARGET_MB = 1024.0


def run_case(policy: str, backend: str, iterations: int) -> dict:
    from ladders.study.cohort.benchmark_shapes import bent_ellipsoid
    from manifolds import LDDMMLandmarks
    from manifolds.lddmm.kernels import numba_available

    if backend == "numba" and not numba_available():
        return {"skipped": "numba not installed"}
    template, target, _ = bent_ellipsoid(subdivisions=5)
    space = LDDMMLandmarks(
        len(template), 3, sigma=0.5, alpha=0.02, control_points=policy,
        max_iter=iterations, kernel_backend=backend,
    )  # fmt: skip
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t0 = time.perf_counter()
        res = space.register(template, target)
        seconds = time.perf_counter() - t0
    return {
        "policy": policy,
        "backend": backend,
        "n_points": len(template),
        "n_cp": len(res.control_points),
        "iterations": res.n_iter,
        "seconds": seconds,
        "objective": res.objective,
        "rss_base_mb": base,
        "rss_peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dense-iterations", type=int, default=3)
    parser.add_argument("--case", nargs=3, help=argparse.SUPPRESS)
    parser.add_argument("--publish", action="store_true", help="write docs/generated/memory.md")
    args = parser.parse_args(argv)
    if args.case:
        print(json.dumps(run_case(args.case[0], args.case[1], int(args.case[2]))))
        return 0
    cases = [
        ("grid", "numpy", 20),
        ("grid", "numba", 20),
        ("dense", "numba", args.dense_iterations),
    ]
    cases.append(("dense", "numpy", 1))
    rows = []
    for policy, backend, iters in cases:
        cmd = [sys.executable, __file__, "--case", policy, backend, str(iters)]
        out = subprocess.run(cmd, capture_output=True, text=True, check=True)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        if "skipped" in r:
            print(f"{policy:5s} {backend:5s}: skipped ({r['skipped']})")
            continue
        met = "met" if r["rss_peak_mb"] < TARGET_MB else "NOT met"
        print(
            f"{policy:5s} {backend:5s}: {r['n_points']} points, {r['n_cp']} control points, "
            f"{r['iterations']} iterations in {r['seconds']:.1f} s "
            f"({r['seconds'] / max(r['iterations'], 1):.2f} s/iteration), "
            f"peak RSS {r['rss_peak_mb']:.0f} MB (libraries {r['rss_base_mb']:.0f} MB); "
            f"target < 1 GB: {met}"
        )
        rows.append(
            f"| {policy}, {backend} | {r['n_points']:,} / {r['n_cp']:,} | {r['iterations']} | "
            f"{r['seconds'] / max(r['iterations'], 1):.2f} s | {r['rss_peak_mb']:.0f} MB "
            f"(libraries {r['rss_base_mb']:.0f} MB) | {met.lower()} |"
        )
    if args.publish:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from generated_tables import publish

        header = ("| control points, kernels | points / control points | iterations | "
                  "time per iteration | peak RSS | target < 1 GB |\n|---|---|---|---|---|---|")  # fmt: skip
        note = ("A 10,242-vertex ellipsoid registered onto its bent and twisted copy "
                "(sigma 0.5, alpha 0.02, 10 Euler steps), one process per case.")  # fmt: skip
        publish("memory", note + "\n\n" + header + "\n" + "\n".join(rows),
                "python benchmarks/bench_memory.py --publish")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
