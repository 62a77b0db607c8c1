"""scipy's L-BFGS-B with the library's stopping rules and an objective history."""

from __future__ import annotations

import numpy as np
import scipy.optimize

from .blas import limit_blas_threads
from .options import SolverOptions
from .result import OptimizationResult
from .stopping import StoppingRule

__all__ = ["minimize_lbfgsb"]


def minimize_lbfgsb(
    problem, x0, options: SolverOptions | None = None, rule: StoppingRule | None = None
) -> OptimizationResult:
    """Minimise ``problem`` from ``x0`` with scipy's L-BFGS-B.

    Parameters
    ----------
    problem : SolverProblem
    x0 : array
    options : SolverOptions, optional
        ``max_corrections``, ``max_line_search``, ``refresh_every``, ``blas_threads``.
    rule : StoppingRule, optional
        Tolerances and iteration limit (default ``StoppingRule()``). With the ``"objective"`` rule, scipy's
        own ``ftol`` / ``gtol`` test is used (the same test); with ``"shape"``, the
        rule is checked after every iteration.

    Returns
    -------
    OptimizationResult
    """
    options = SolverOptions() if options is None else options
    rule = StoppingRule() if rule is None else rule
    # scipy calls the problem itself (it keeps its own latest evaluation, as scipy
    # does); the evaluations counted are scipy's, whose first is at x0.
    fun = problem.value_and_gradient
    n_evals = 0
    x0 = np.asarray(x0, dtype=float).ravel()
    history: list = []
    reason: list = []

    def callback(intermediate_result):
        history.append(float(intermediate_result.fun))
        x = np.asarray(intermediate_result.x, dtype=float)
        f, g = fun(x)
        why = rule.met(problem, x, f, g)  # records the iteration
        if why is not None and rule.kind == "shape":  # scipy applies the objective rule
            reason.append(why)
            raise StopIteration

    objective_rule = rule.kind == "objective"
    # A problem whose metric depends on the iterate (``refreshable``) is restarted
    # every ``refresh_every`` iterations in refreshed variables.
    every = int(options.refresh_every) if getattr(problem, "refreshable", False) else 0
    n_iter = 0
    with limit_blas_threads(options.blas_threads):
        f0 = fun(x0.copy())[0]
        history.append(f0)
        rule.start(problem, x0, f0)
        x = x0
        while True:
            budget = rule.max_iter - n_iter
            res = scipy.optimize.minimize(
                fun,
                x,
                jac=True,
                method="L-BFGS-B",
                callback=callback,
                options={
                    "maxiter": int(min(budget, every) if every > 0 else budget),
                    "ftol": float(rule.ftol) if objective_rule else 0.0,
                    "gtol": float(rule.gtol) if objective_rule else 0.0,
                    "maxcor": int(options.max_corrections),
                    "maxls": int(options.max_line_search),
                },
            )
            n_iter += int(res.nit)
            n_evals += int(res.nfev)
            x = np.asarray(res.x, dtype=float)
            restart = every > 0 and res.nit >= every and not reason and n_iter < rule.max_iter
            if not restart:
                break
            x = problem.refresh(x)  # the same iterate in the refreshed variables
        f, g = fun(x)
    if reason:
        converged, message = True, reason[0]
    else:
        message = str(res.message)
        converged = bool(res.success) and objective_rule
        stalled = any(w in message.upper() for w in ("ABNORMAL", "PROJECTED GRADIENT"))
        if not converged and stalled:  # a zero gradient (e.g. template = target) or a stall
            converged = rule.accepts_stall(problem, x, g)
    return OptimizationResult(
        x=x,
        fun=f,
        grad=g,
        n_iter=n_iter,
        n_evals=n_evals,
        history=history,
        converged=converged,
        message=message,
        trace=list(rule.trace),
    )
