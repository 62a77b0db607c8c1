"""Agreement of the ladders on wrapped geomstats spaces with geomstats' own transports.

Run from the repository root (needs the extra ``geomstats``)::

    python benchmarks/bench_geomstats.py [--seeds 20]

For S^2, H^2 (hyperboloid) and SPD(3) wrapped by :func:`manifolds.interop.from_geomstats`
and ``--seeds`` random configurations (base point, end point at geodesic distance ~0.8,
vector of size ~0.5), prints the worst relative difference ``max|x - ref| / max|ref|``
between

* ``ladders.pole_ladder`` and geomstats' exact ``parallel_transport``;
* ``ladders.pole_ladder`` / ``ladders.schild_ladder`` and geomstats'
  ``ladder_parallel_transport`` with the same scheme, rungs and scaling exponent

for 1, 2 and 5 rungs, and the time of one wrapped one-rung pole ladder.
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

from ladders import pole_ladder, schild_ladder  # noqa: E402
from manifolds.interop import from_geomstats  # noqa: E402

SCHEMES = {"pole": (pole_ladder, 1.0), "schild": (schild_ladder, 2.0)}


def relative(x, ref) -> float:
    return float(np.abs(np.asarray(x) - ref).max() / np.abs(ref).max())


def worst_differences(gs_space, n_seeds: int) -> dict[str, float]:
    """Worst relative differences over ``n_seeds`` configurations."""
    space = from_geomstats(gs_space, is_symmetric=True)
    metric = gs_space.metric
    worst: dict[str, float] = {}
    for seed in range(n_seeds):
        rng = np.random.default_rng(seed)
        a = space.random_point(rng)
        b = space.exp(a, space.random_tangent(a, rng, scale=0.8))
        u = space.random_tangent(a, rng, scale=0.5)
        exact = metric.parallel_transport(u, a, end_point=b)
        for n in (1, 2, 5):
            rows = {f"pole, {n} rungs vs exact": relative(pole_ladder(space, a, b, u, n), exact)}
            for scheme, (ladder, exponent) in SCHEMES.items():
                theirs = metric.ladder_parallel_transport(
                    u, a, space.log(a, b), n_rungs=n, scheme=scheme, alpha=exponent
                )["transported_tangent_vec"]
                ours = ladder(space, a, b, u, n_rungs=n, scaling_exponent=exponent)
                rows[f"{scheme}, {n} rungs vs geomstats ladder"] = relative(ours, theirs)
            for key, value in rows.items():
                worst[key] = max(worst.get(key, 0.0), value)
    start = time.perf_counter()
    for _ in range(20):
        pole_ladder(space, a, b, u)
    worst["time of one pole rung (ms)"] = (time.perf_counter() - start) / 20 * 1e3
    return worst


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=20)
    args = parser.parse_args()
    # geomstats is imported after the adapter, which aliases numpy.trapz on numpy >= 2.4.
    from geomstats.geometry.hyperboloid import Hyperboloid
    from geomstats.geometry.hypersphere import Hypersphere
    from geomstats.geometry.spd_matrices import SPDMatrices

    for name, gs_space in (
        ("S^2", Hypersphere(2)),
        ("H^2", Hyperboloid(2)),
        ("SPD(3)", SPDMatrices(3)),
    ):
        print(f"{name} ({args.seeds} configurations)")
        for key, value in worst_differences(gs_space, args.seeds).items():
            print(f"  {key:40s} {value:.1e}")


if __name__ == "__main__":
    main()
