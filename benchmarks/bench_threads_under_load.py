"""The compiled kernels' parallel loops on a machine other processes also use.

A registration calls short parallel loops thousands of times. Between two loops the
idle OpenMP threads (numba's ``omp`` threading layer, GNU OpenMP) spin for
``GOMP_SPINCOUNT`` iterations before they sleep. With GNU's default (300,000) they keep
their cores busy; when another process needs one, the spinning threads, the loop's own
threads and the other process fight for it. The library sets 1,000
(:data:`manifolds.kernels.numba_primitives.GOMP_SPINCOUNT`, unless the user set a value).

For both values, alone and next to one and two busy processes (``while True: pass``),
this measures, each in its own process (the setting is read when OpenMP starts):

* the Hamiltonian right-hand side of 642 control points (412,000 pairs), serial and
  parallel loop, median of 300 calls;
* the registration of the 642-vertex ellipsoid with dense control points (100 L-BFGS-B
  iterations, as in ``bench_registration.py``), best of 2.

Usage: ``python benchmarks/bench_threads_under_load.py [--publish]``; ``--publish``
writes ``docs/generated/threads_under_load.md`` (with the CPU).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
SPINS = {"GNU default": "300000", "the library's": "1000"}
LOADS = (0, 1, 2)


def measure() -> dict:
    """In this process: the sum's serial and parallel times and the registration's."""
    import numpy as np

    sys.path.insert(0, str(HERE))
    from bench_registration import problem

    from manifolds.kernels.numba_primitives import to_soa
    from manifolds.lddmm import kernels_numba
    from manifolds.lddmm.registration import register
    from manifolds.lddmm.settings import RegistrationSettings

    template, target = problem(3)
    c, mu = to_soa(template), to_soa(0.01 * (target - template))
    dc, dmu = np.empty_like(c), np.empty_like(c)
    out = {}
    for name, loop in zip(("serial", "parallel"), kernels_numba.LOOPS["hamiltonian_rhs"]):
        loop(c, mu, 4.0, dc, dmu)
        times = []
        for _ in range(300):
            t0 = time.perf_counter()
            loop(c, mu, 4.0, dc, dmu)
            times.append(time.perf_counter() - t0)
        out[name] = float(np.median(times))
    settings = RegistrationSettings(sigma=0.5, integrator="euler", max_iter=100)
    kernel = settings.make_kernel()
    register(template[:300], target[:300], 0.02, settings.replace(max_iter=2),
             control_points=template[:300], kernel=kernel, warn=False)  # fmt: skip
    best = []
    for _ in range(2):
        t0 = time.perf_counter()
        register(template, target, 0.02, settings, control_points=template, kernel=kernel,
                 warn=False)  # fmt: skip
        best.append(time.perf_counter() - t0)
    out["registration"] = min(best)
    return out


def run(spin: str, load: int) -> dict:
    busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(load)]
    try:
        env = dict(os.environ, GOMP_SPINCOUNT=spin)
        proc = subprocess.run([sys.executable, __file__, "--measure"], env=env,
                              capture_output=True, text=True, check=True)  # fmt: skip
    finally:
        for p in busy:
            p.kill()
            p.wait()
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--measure", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    if args.measure:
        print(json.dumps(measure()))
        return
    rows = []
    for label, spin in SPINS.items():
        for load in LOADS:
            r = run(spin, load)
            ratio = r["parallel"] / r["serial"]
            rows.append(
                f"| {spin} ({label}) | {load} | {1e3 * r['serial']:.2f} ms | "
                f"{1e3 * r['parallel']:.2f} ms ({ratio:.2f} x serial) | {r['registration']:.2f} s |"
            )
            print(rows[-1], flush=True)
    if args.publish:
        sys.path.insert(0, str(HERE))
        from generated_tables import publish

        header = ("| idle threads spin (`GOMP_SPINCOUNT`) | busy processes | Hamiltonian sum, "
                  "serial | the same, parallel | dense 642 registration, 100 iterations |\n"
                  "|---|---|---|---|---|")  # fmt: skip
        note = ("Parallel kernel loops next to other processes: 642 control points (412,000 "
                "pairs a sum), median of 300 sums; the registration of bench_registration.py "
                "with dense control points, best of 2; each row in its own process.")  # fmt: skip
        publish("threads_under_load", note + "\n\n" + header + "\n" + "\n".join(rows),
                "python benchmarks/bench_threads_under_load.py --publish")  # fmt: skip


if __name__ == "__main__":
    main()
