"""How many flow passes any gradient-based solver needs: a Krylov lower bound at the minimum.

For the atlas-to-subject registrations of the study (1,009 vertices, built-in cohort),
at each ``alpha^2``, this script measures:

* ``today``: L-BFGS-B to ``ftol = 1e-11`` (the former rule), flow passes (FE: one
  forward shooting, one adjoint or one tangent-linear pass);
* ``shape rule``: L-BFGS-B under the study's shape rule (``shape_tol = 1e-4`` mm), its
  FE and the per-vertex RMS distance ``eps`` of its deformed template to the one of a
  tight reference (``ftol = 1e-14``);
* ``oracle``: the FE at which today's run first came within ``eps`` of the reference
  (the best any stopping rule can do with this solver and start);
* ``Krylov``: the Gauss-Newton matrix ``H`` and the Jacobian ``J`` of ``phi_1(T)`` at
  the reference minimum, in the solver's (preconditioned) variables, built from exact
  tangent-linear and adjoint passes. On the quadratic model ``q(x) = 1/2 (x - x*)^T H
  (x - x*)`` started at the solver's start ``x0``, the ``k``-th iterate of any method
  that builds its steps from gradients (or from Hessian-vector products: L-BFGS,
  nonlinear CG, Newton-CG, Gauss-Newton-CG) lies in ``x0 + K_k(H, g0)``. The script
  finds the smallest ``k`` for which some point of that affine Krylov space puts
  ``phi_1(T)`` within ``eps`` of the reference (the exact minimum of
  ``|J (x - x*)|`` over the space: :func:`manifolds.numerics.solvers.krylov_lower_bound`). Each
  gradient or Hessian-vector product costs at least two flow passes (one forward or
  tangent, one adjoint), so ``2 k`` FE is a lower bound for such solvers in these
  variables, even if the objective were its quadratic model. ``today / bound`` is
  then the largest speed-up any of them could give.

Another preconditioner changes the Krylov space, and the bound with it; forming and
factorising ``H`` itself costs ``2 n`` FE for ``n`` variables (1,620 FE on the
270-point grid).

Usage: ``python benchmarks/bench_krylov_bound.py [--settings vertices10,sigma10,grid45]
[--alpha2 0.01,0.1,1,100] [--subjects 0,1] [--cache out.json]``.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np

SETTINGS = {
    "vertices10": dict(sigma=10.0, control_points="vertices"),
    "sigma10": dict(sigma=10.0, control_points="grid"),
    "grid45": dict(sigma=20.0, control_points="grid"),
}
TODAY = dict(stopping="objective", ftol=1e-11, gtol=1e-9, max_iter=5000)
REFERENCE = dict(stopping="objective", ftol=1e-14, gtol=1e-12, max_iter=20000)
SHAPE = dict(stopping="shape", shape_tol=1e-4, max_iter=5000)


def _rms(diff) -> float:
    diff = np.asarray(diff, dtype=float).reshape(-1, 3)
    return float(np.sqrt((diff * diff).sum() / diff.shape[0]))


def _solve(template, target, alpha, settings):
    """Run the settings' solver; return the problem, the result and (FE, deformed) per iteration."""
    from manifolds.lddmm import build_registration_problem
    from manifolds.lddmm.hamiltonian_shooting import HamiltonianFlow
    from manifolds.numerics.solvers import StoppingRule, get_solver

    problem, x0 = build_registration_problem(HamiltonianFlow, template, target, alpha, settings)
    visited: list = []

    class Recording(StoppingRule):
        def met(self, problem, x, f, g):
            visited.append((problem.n_flow_evaluations, np.array(problem.shape(x))))
            return super().met(problem, x, f, g)

    rule = Recording(settings.stopping, settings.ftol, settings.gtol, settings.shape_tol,
                     settings.max_iter)  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        opt = get_solver(settings.solver)(problem, x0.copy(), settings.solver_options(), rule)
    return problem, x0, opt, visited


def _matrices(problem, x):
    """Gauss-Newton matrix ``H`` and Jacobian ``J`` of ``phi_1(T)`` at ``x`` (solver's variables)."""
    n = x.size
    ev = problem.evaluate(x)
    flow = ev.flow_pass
    H = np.empty((n, n))
    J = np.empty((flow.deformed.size, n))
    for i in range(n):
        e = np.zeros(n)
        e[i] = 1.0
        H[:, i] = problem.gauss_newton_product(x, e)
        d_c, d_mu = problem.to_natural(e)
        J[:, i] = problem.model.tangent(flow, d_c, d_mu).ravel()
    return 0.5 * (H + H.T), J


def run_case(cohort, setting: str, subject: int, alpha2: float) -> dict:
    from ladders.study.running.pipeline import DEFAULT_REGISTRATION
    from manifolds.numerics.solvers import krylov_lower_bound

    template, target = cohort.atlas, cohort.subjects[subject].ed
    alpha = float(np.sqrt(alpha2))
    base = DEFAULT_REGISTRATION.replace(**SETTINGS[setting])
    start = time.perf_counter()
    ref_problem, _, ref, _ = _solve(template, target, alpha, base.replace(**REFERENCE))
    reference_shape = np.array(ref_problem.shape(ref.x))
    today_problem, _, today, today_visits = _solve(template, target, alpha,
                                                   base.replace(**TODAY))  # fmt: skip
    shape_problem, x0, shape, _ = _solve(template, target, alpha, base.replace(**SHAPE))
    shape_fe = shape_problem.n_flow_evaluations
    eps = _rms(shape_problem.shape(shape.x) - reference_shape)
    oracle = next(
        (fe for fe, phi in today_visits if _rms(phi - reference_shape) <= eps),
        today_problem.n_flow_evaluations,
    )
    # the reference minimum in the shape run's variables (same preconditioner and scale)
    mu_star, c_star = ref_problem.unpack(ref.x)
    x_star = shape_problem.variables(mu_star, c_star)
    H, J = _matrices(shape_problem, x_star)
    floor = krylov_lower_bound(H, J, x0, x_star, n_points=template.shape[0], tol=eps)
    k_min = floor.first_below(eps)
    bound = 2 * k_min if k_min else None
    today_fe = today_problem.n_flow_evaluations
    return {
        "setting": setting,
        "subject": subject,
        "alpha2": alpha2,
        "variables": int(x0.size),
        "today_fe": today_fe,
        "today_converged": bool(today.converged),
        "shape_fe": shape_fe,
        "eps": eps,
        "oracle_fe": int(oracle),
        "krylov_min": k_min,
        "krylov_min_10eps": floor.first_below(10.0 * eps),
        "cg_iterations": floor.cg_first_below(eps),
        "bound_fe": bound,
        "max_speedup": today_fe / bound if bound else None,
        "start_error": floor.start_error,
        "seconds": time.perf_counter() - start,
    }


def _format(r: dict) -> str:
    bound = r["bound_fe"] if r["bound_fe"] is not None else "-"
    speed = f"{r['max_speedup']:.2f}x" if r["max_speedup"] else "-"
    return (
        f"| {r['setting']} | {r['alpha2']:g} | {r['subject']} | {r['today_fe']} | "
        f"{r['shape_fe']} | {r['eps']:.2e} | {r['oracle_fe']} | {r['krylov_min']} | "
        f"{r['cg_iterations']} | {bound} | {speed} | {r['krylov_min_10eps']} |"
    )


HEADER = (
    "| setting | alpha^2 | subject | today FE (ftol 1e-11) | shape rule FE | eps (mm) | "
    "oracle FE | Krylov k | CG k | bound FE (2k) | today / bound | Krylov k at 10 eps |\n"
    "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--settings", default="sigma10,grid45")
    parser.add_argument("--alpha2", default="0.01,0.1,1,100")
    parser.add_argument("--subjects", default="0,1")
    parser.add_argument("--cache", type=Path, default=None, help="JSON file of finished rows")
    args = parser.parse_args(argv)
    from ladders.study import make_synthetic_cohort

    settings = [s for s in args.settings.split(",") if s]
    for s in settings:
        if s not in SETTINGS:
            parser.error(f"--settings: unknown setting {s!r}; choose from {sorted(SETTINGS)}")
    alpha2s = [float(a) for a in args.alpha2.split(",")]
    subjects = [int(j) for j in args.subjects.split(",")]
    cache = json.loads(args.cache.read_text()) if args.cache and args.cache.exists() else {}
    cohort = make_synthetic_cohort(max(subjects) + 1, seed=0)
    print(HEADER, flush=True)
    for setting in settings:
        for alpha2 in alpha2s:
            for subject in subjects:
                key = f"{setting}/{alpha2:g}/{subject}"
                if key not in cache:
                    cache[key] = run_case(cohort, setting, subject, alpha2)
                    if args.cache:
                        args.cache.write_text(json.dumps(cache, indent=1))
                print(_format(cache[key]), flush=True)


if __name__ == "__main__":
    main()
