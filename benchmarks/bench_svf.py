"""SVF registration against LDDMM registration at the same control points.

The template is an icosphere scaled to semi-axes (1, 0.7, 0.5) (642 vertices by
default), the target its bent and twisted copy
(:func:`ladders.study.cohort.benchmark_shapes.bent_ellipsoid`); grid control points of
spacing sigma = 0.5 (45 points), alpha = 0.02, 10 time steps. Each method
registers to convergence (at most ``--max-iter`` L-BFGS-B iterations) from the
same linearised start; reported: best wall time of ``--repeats`` runs,
iterations, objective evaluations, time per evaluation, final objective, RMS
residual and inverse consistency (the backward registration composed with the
forward one). LDDMM uses its default Euler scheme and SVF its default RK4; each is
also run with the other's scheme so that the per-step costs can be compared.

Usage: ``python benchmarks/bench_svf.py [--subdivisions 3] [--repeats 1] [--max-iter 500]``.
"""

from __future__ import annotations

import argparse
import time
import warnings

from ladders.study.cohort.benchmark_shapes import bent_ellipsoid
from manifolds.lddmm import LDDMMLandmarks, RegistrationSettings, SVFLandmarks

SIGMA, ALPHA, N_STEPS = 0.5, 0.02, 10
METHODS = (
    ("LDDMM", LDDMMLandmarks, "euler"),
    ("SVF", SVFLandmarks, "rk4"),
    ("LDDMM", LDDMMLandmarks, "rk4"),
    ("SVF", SVFLandmarks, "euler"),
)


def run(cls, integrator, template, target, repeats, max_iter):
    """Best time of ``repeats`` registrations and the last result."""
    settings = RegistrationSettings(
        sigma=SIGMA, control_points="grid", integrator=integrator, n_steps=N_STEPS,
        max_iter=max_iter,
    )  # fmt: skip
    k, d = template.shape
    # Load the compiled kernels first so that JIT time is not counted.
    warm = cls(k, d, alpha=ALPHA, settings=settings.replace(max_iter=2))
    warm.register(template, target)
    times = []
    for _ in range(max(1, repeats)):
        space = cls(k, d, alpha=ALPHA, settings=settings, cache_size=2)
        t0 = time.perf_counter()
        res = space.register(template, target)
        times.append(time.perf_counter() - t0)
    ic = space.inverse_consistency(template, target)
    n_cp = len(space.control_points(template))
    return min(times), res, ic, n_cp


def main(argv=None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subdivisions", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--max-iter", type=int, default=500)
    args = parser.parse_args(argv)
    template, target, _ = bent_ellipsoid(args.subdivisions)
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, cls, integrator in METHODS:
            seconds, res, ic, n_cp = run(
                cls, integrator, template, target, args.repeats, args.max_iter
            )
            rows.append(
                dict(
                    method=f"{name} ({integrator}, {N_STEPS} steps)",
                    seconds=seconds,
                    n_iter=res.n_iter,
                    n_evals=res.n_evals,
                    objective=res.objective,
                    rms=res.rms_error,
                    converged=res.converged,
                    inverse_consistency=ic,
                )
            )
    print(
        f"{len(template)} vertices, {n_cp} grid control points, sigma {SIGMA}, alpha {ALPHA}, "
        f"best of {args.repeats} runs, at most {args.max_iter} iterations"
    )
    header = f"{'method':<24}{'time s':>8}{'iter':>6}{'evals':>7}{'ms/eval':>9}"
    print(header + f"{'objective':>12}{'RMS':>10}{'conv':>6}{'inv. cons.':>12}")
    for r in rows:
        print(
            f"{r['method']:<24}{r['seconds']:>8.2f}{r['n_iter']:>6}{r['n_evals']:>7}"
            f"{1e3 * r['seconds'] / r['n_evals']:>9.2f}{r['objective']:>12.6g}{r['rms']:>10.4g}"
            f"{'yes' if r['converged'] else 'no':>6}{r['inverse_consistency']:>12.4g}"
        )
    return rows


if __name__ == "__main__":
    main()
