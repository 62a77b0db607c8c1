"""Timings of the closed-form symmetric spaces and of batched pole-ladder transport.

Run from the repository root::

    python benchmarks/bench_closed_form.py [--repeats 15]

Prints, for batches of 1000 configurations:

* the time of 1000 pole-ladder transports on ``S^2`` (one call on batched
  arrays) with 1 and 10 rungs, in total and per transport, with the target
  "1000 one-rung transports in at most 0.5 ms";
* the throughput (points per second) of ``exp``, ``log`` and
  ``parallel_transport`` on ``S^2``, ``H^3`` and ``SPD(3)``.

Each figure is the best and the median over ``--repeats`` timed runs
(``time.perf_counter``), after one warm-up call.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from ladders.pole_ladder import pole_ladder  # noqa: E402
from manifolds.hyperbolic import Hyperbolic  # noqa: E402
from manifolds.hypersphere import Hypersphere  # noqa: E402
from manifolds.spd import SPDMatrices  # noqa: E402

BATCH = 1000
TARGET_SECONDS = 0.5e-3


def timeit(func, repeats: int, number: int = 1) -> tuple[float, float]:
    """Best and median wall time (seconds) of ``number`` calls, over ``repeats`` runs."""
    func()
    runs = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(number):
            func()
        runs.append((time.perf_counter() - start) / number)
    return min(runs), float(np.median(runs))


def batch_configuration(space, rng, size: int = BATCH):
    """``size`` triples ``(base, end, tangent)`` with distances and vectors of size ~1."""
    base = space.random_point(rng, size)
    end = space.exp(base, space.random_tangent(base, rng, scale=1.0))
    return base, end, space.random_tangent(base, rng, scale=1.0)


def bench_pole_ladder(repeats: int, rows: list | None = None) -> bool:
    space = Hypersphere(2)
    base, end, u = batch_configuration(space, np.random.default_rng(0))
    exact = space.parallel_transport(base, end, u)
    print(f"Pole ladder on S^2, {BATCH} transports in one batched call")
    met = False
    for n_rungs in (1, 10):
        best, median = timeit(
            lambda n=n_rungs: pole_ladder(space, base, end, u, n_rungs=n),
            repeats,
            number=20 if n_rungs == 1 else 3,
        )
        err = np.max(np.abs(pole_ladder(space, base, end, u, n_rungs=n_rungs) - exact))
        print(
            f"  n_rungs={n_rungs:2d}: total best {best * 1e3:7.3f} ms, median {median * 1e3:7.3f} ms"
            f" | per transport best {best / BATCH * 1e6:6.3f} us,"
            f" median {median / BATCH * 1e6:6.3f} us | max error vs exact {err:.1e}"
        )
        if rows is not None:
            target = (f"<= {TARGET_SECONDS * 1e3:.1f} ms: "
                      f"{'met' if best <= TARGET_SECONDS else 'not met'}") if n_rungs == 1 else "-"  # fmt: skip
            rows.append(f"| {n_rungs} | {best * 1e3:.3f} ms | {median * 1e3:.3f} ms | "
                        f"{best / BATCH * 1e6:.3f} us | {err:.1e} | {target} |")  # fmt: skip
        if n_rungs == 1:
            met = best <= TARGET_SECONDS
            print(
                f"  target: {BATCH} one-rung transports in <= {TARGET_SECONDS * 1e3:.1f} ms:"
                f" {'met' if met else 'MISSED'} (best {best * 1e3:.3f} ms,"
                f" median {median * 1e3:.3f} ms)"
            )
    return met


def bench_throughput(repeats: int) -> None:
    print(f"\nThroughput at batch size {BATCH} (points per second; best / median)")
    print(f"  {'space':<16}{'exp':>24}{'log':>24}{'parallel_transport':>24}")
    for space in (Hypersphere(2), Hyperbolic(3), SPDMatrices(3)):
        base, end, u = batch_configuration(space, np.random.default_rng(1))
        v = space.log(base, end)
        calls = {
            "exp": lambda s=space, b=base, w=v: s.exp(b, w),
            "log": lambda s=space, b=base, e=end: s.log(b, e),
            "transport": lambda s=space, b=base, e=end, w=u: s.parallel_transport(b, e, w),
        }
        number = 5 if isinstance(space, SPDMatrices) else 50
        cells = []
        for func in calls.values():
            best, median = timeit(func, repeats, number=number)
            cells.append(f"{BATCH / best:10.3g} / {BATCH / median:9.3g}")
        print(f"  {space!r:<16}" + "".join(f"{c:>24}" for c in cells))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=15, help="timed runs per figure")
    parser.add_argument("--publish", action="store_true",
                        help="write the pole-ladder table to docs/generated/closed_form.md")  # fmt: skip
    args = parser.parse_args(argv)
    print(f"numpy {np.__version__}, float64, {args.repeats} repeats\n")
    rows: list = []
    bench_pole_ladder(args.repeats, rows)
    bench_throughput(args.repeats)
    if args.publish:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from generated_tables import publish

        header = ("| rungs | 1,000 transports (best) | median | per transport | largest error "
                  "against the exact transport | target |\n|---|---|---|---|---|---|")  # fmt: skip
        note = (f"Pole ladder on S^2: {BATCH:,} transports in one batched call, numpy "
                f"{np.__version__}, float64, best and median of {args.repeats} runs.")  # fmt: skip
        publish("closed_form", note + "\n\n" + header + "\n" + "\n".join(rows),
                "python benchmarks/bench_closed_form.py --publish")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
