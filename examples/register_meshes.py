"""Register an ellipsoid mesh onto a bent and twisted copy and plot the deformation.

Run ``python examples/register_meshes.py --output deformation.png``.
"""

from __future__ import annotations

import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ladders.study.cohort.benchmark_shapes import bent_ellipsoid  # noqa: E402
from manifolds.lddmm import LDDMMLandmarks  # noqa: E402


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--output", default="symladders-output/register_meshes.png")
    parser.add_argument("--subdivisions", type=int, default=2)
    parser.add_argument("--sigma", type=float, default=0.5)
    parser.add_argument("--alpha", type=float, default=0.02)
    args = parser.parse_args(argv)

    template, target, faces = bent_ellipsoid(args.subdivisions)
    space = LDDMMLandmarks(
        len(template), 3, sigma=args.sigma, alpha=args.alpha, control_points="dense"
    )
    result = space.register(template, target)
    print(
        f"{len(template)} vertices: {result.n_iter} iterations, objective {result.objective:.4g}, "
        f"RMS residual {result.rms_error:.3g}, |v0|_H {result.rkhs_norm:.3g}, "
        f"converged {result.converged}"
    )
    _, trajectory = space.shoot(template, result.momenta, return_trajectory=True)

    fig = plt.figure(figsize=(11, 4))
    views = [(template, "template T"), (result.deformed, "phi_1(T)"), (target, "target S")]
    for i, (pts, title) in enumerate(views):
        ax = fig.add_subplot(1, 4, i + 1, projection="3d")
        ax.plot_trisurf(*pts.T, triangles=faces, color="lightsteelblue", edgecolor="grey", lw=0.2)
        ax.set_title(title)
        ax.set_box_aspect((1, 0.7, 0.6))
        ax.set_axis_off()
    ax = fig.add_subplot(1, 4, 4)
    paths = np.stack([state[0] for state in trajectory])  # dense: vertices are control points
    for k in range(0, paths.shape[1], max(1, paths.shape[1] // 60)):
        ax.plot(paths[:, k, 0], paths[:, k, 2], color="tab:blue", lw=0.8)
    ax.scatter(*target[:, [0, 2]].T, s=2, color="tab:red", label="target")
    ax.set_title("vertex paths (x, z)")
    ax.set_aspect("equal")
    ax.legend(loc="lower right", fontsize=7)
    out = pathlib.Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    print(f"saved {out}")
    return result


if __name__ == "__main__":
    main()
