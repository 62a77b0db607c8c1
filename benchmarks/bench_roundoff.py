"""Round-off of the hyperbolic symmetry far from the origin.

Run from the repository root::

    python benchmarks/bench_roundoff.py [--trials 300]

On ``Hyperbolic(3)``, a centre ``m`` is placed at distance ``r`` from the origin
``e_0`` and a point ``p`` at distance 7 from ``m`` (random directions); the
coordinates of ``p`` then reach ``e^(r + 7)``. Prints the largest, over the
trials, of

* the L2 distance ``|s_m(s_m(p)) - p|`` of the coordinates (the paper's
  involutivity error) and the same relative to ``|p|``;
* the intrinsic length of that displacement (measured in the spatial chart,
  without cancellation);
* how far ``s_m(s_m(p))`` is from the hyperboloid, ``|<q, q>_L + 1| / q_0^2``.
"""

from __future__ import annotations

import argparse

import numpy as np

from ladders import involutivity_error
from manifolds import Hyperbolic


def chart_length(p, q):
    """Intrinsic length of the small displacement ``p -> q`` from the spatial parts."""
    xs, d = p[1:], q[1:] - p[1:]
    return float(np.sqrt(max(d @ d - (xs @ d) ** 2 / (1.0 + xs @ xs), 0.0)))


def measure(space, rng, centre_dist, point_dist, trials):
    e0 = np.zeros(space.point_shape)
    e0[0] = 1.0
    worst = dict(l2=0.0, rel=0.0, intrinsic=0.0, membership=0.0)
    for _ in range(trials):
        u = space.random_tangent(e0, rng)
        m = space.exp(e0, u * (centre_dist / space.norm(e0, u)))
        v = space.random_tangent(m, rng)
        p = space.exp(m, v * (point_dist / space.norm(m, v)))
        q = space.symmetry(m, space.symmetry(m, p))
        worst["l2"] = max(worst["l2"], float(involutivity_error(space, m, p)))
        worst["rel"] = max(worst["rel"], float(np.linalg.norm(q - p) / np.linalg.norm(p)))
        worst["intrinsic"] = max(worst["intrinsic"], chart_length(p, q))
        gap = abs(-(q[0] ** 2) + q[1:] @ q[1:] + 1.0) / q[0] ** 2
        worst["membership"] = max(worst["membership"], float(gap))
    return worst


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=300)
    args = parser.parse_args()
    space = Hyperbolic(3)
    rng = np.random.default_rng(0)
    print(f"Hyperbolic(3), s_m(s_m(p)) with d(m, p) = 7, worst of {args.trials} trials")
    for r in (0.0, 3.0, 7.0):
        w = measure(space, rng, r, 7.0, args.trials)
        print(
            f"  d(e0, m) = {r:3.0f}: L2 {w['l2']:.2e}  relative {w['rel']:.2e}  "
            f"intrinsic {w['intrinsic']:.2e}  off the hyperboloid {w['membership']:.2e}"
        )


if __name__ == "__main__":
    main()
