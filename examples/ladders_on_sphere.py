"""Pole ladder and Schild's ladder on the sphere: trajectories and convergence.

Transports a vector along a geodesic of S^2 with both ladders, draws the rungs
(main geodesic, pivots, reflected points) and the log-log convergence of the
error against the exact parallel transport.

Run ``python examples/ladders_on_sphere.py --output ladders.png``.
"""

from __future__ import annotations

import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ladders import ladder_convergence, pole_ladder, schild_ladder  # noqa: E402
from manifolds import Hypersphere  # noqa: E402


def main(argv=None) -> pathlib.Path:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default="symladders-output/ladders_on_sphere.png")
    parser.add_argument("--rungs", type=int, default=4)
    args = parser.parse_args(argv)

    sphere = Hypersphere(2)
    base = np.array([1.0, 0.0, 0.0])
    end = sphere.exp(base, np.array([0.0, 1.2, 0.6]))
    u = np.array([0.0, -0.3, 0.5])
    exact = sphere.parallel_transport(base, end, u)

    fig = plt.figure(figsize=(11, 5))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    g = np.linspace(0, np.pi, 30)
    h = np.linspace(0, 2 * np.pi, 60)
    ax.plot_wireframe(
        np.outer(np.sin(g), np.cos(h)), np.outer(np.sin(g), np.sin(h)),
        np.outer(np.cos(g), np.ones_like(h)), color="0.85", linewidth=0.3,
    )  # fmt: skip
    path = sphere.geodesic(base, end)(np.linspace(0, 1, 50))
    ax.plot(*path.T, "k-", label="geodesic base -> end")
    for ladder, color in ((pole_ladder, "tab:blue"), (schild_ladder, "tab:orange")):
        _, traj = ladder(sphere, base, end, u, n_rungs=args.rungs, return_trajectory=True)
        tips = np.array(traj.rung_tips)
        pivots = np.array(traj.pivots)
        ax.scatter(*tips.T, color=color, s=12, label=f"{ladder.__name__}: rung tips")
        ax.scatter(*pivots.T, color=color, marker="x", s=20)
        ax.scatter(*traj.end_point, color=color, marker="*", s=80)
    ax.scatter(*sphere.exp(end, exact), color="k", marker="*", s=80, label="exact")
    ax.set_box_aspect((1, 1, 1))
    ax.set_axis_off()
    ax.legend(fontsize=7, loc="lower left")

    ax2 = fig.add_subplot(1, 2, 2)
    ns = (2, 4, 8, 16, 32)
    for ladder, a in ((pole_ladder, 1.0), (schild_ladder, 1.0), (schild_ladder, 2.0)):
        curve = ladder_convergence(sphere, ladder, base, end, u, exact, ns, a)
        errors = np.maximum(curve.errors, 1e-17)
        label = f"{ladder.__name__}, a={a:g}"
        if ladder is schild_ladder:
            label += f" (slope {curve.slope:.2f})"
        ax2.loglog(ns, errors, "o-", label=label)
    ax2.set_xticks(ns, [str(n) for n in ns], minor=False)
    ax2.set_xticks([], minor=True)
    ax2.set_xlabel("rungs n")
    ax2.set_ylabel("relative error vs exact transport")
    ax2.set_title("pole ladder: exact on a symmetric space")
    ax2.legend(fontsize=8)
    ax2.grid(True, which="both", alpha=0.3)
    out = pathlib.Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    print(f"written {out}")
    return out


if __name__ == "__main__":
    main()
