"""Optimisers of registrations, selected by name, and their stopping rules.

- :mod:`.result`: :class:`OptimizationResult` and the :class:`SolverProblem`
  interface a solver works on;
- :mod:`.stopping`: :class:`StoppingRule` (in the objective's digits, or in the
  shapes' unit);
- :mod:`.lbfgsb`: scipy's L-BFGS-B (``"lbfgsb"``);
- :mod:`.gauss_newton`: trust-region Gauss-Newton with matrix-free Steihaug-Toint CG
  (``"gauss-newton"``), for least-squares data terms;
- :mod:`.krylov_bound`: the fewest products any Krylov-type solver needs on a
  quadratic model (a lower bound to judge solvers by);
- :mod:`.options`: :class:`SolverOptions`, the solvers' own knobs and their defaults;
- :mod:`.blas`: BLAS thread limits during a run.

:data:`SOLVERS` maps a name (``RegistrationSettings.solver``) to a function
``(problem, x0, options, rule) -> OptimizationResult``; :func:`get_solver` looks one
up. The solvers know nothing of the spaces or of their settings.
"""

from .blas import limit_blas_threads
from .gauss_newton import minimize_gauss_newton, steihaug_cg
from .krylov_bound import KrylovBound, krylov_lower_bound
from .lbfgsb import minimize_lbfgsb
from .options import SolverOptions
from .result import OptimizationResult, SolverProblem
from .stopping import StoppingRule, TraceRow

#: Solver name -> ``(problem, x0, options, rule) -> OptimizationResult``.
SOLVERS = {"lbfgsb": minimize_lbfgsb, "gauss-newton": minimize_gauss_newton}


def get_solver(name: str):
    """The solver registered under ``name`` (:data:`SOLVERS`)."""
    try:
        return SOLVERS[name]
    except KeyError:
        raise ValueError(
            f"solver: unknown name {name!r}; choose one of {sorted(SOLVERS)}"
        ) from None


__all__ = [
    "SOLVERS",
    "get_solver",
    "OptimizationResult",
    "SolverProblem",
    "SolverOptions",
    "StoppingRule",
    "TraceRow",
    "minimize_lbfgsb",
    "minimize_gauss_newton",
    "steihaug_cg",
    "limit_blas_threads",
    "KrylovBound",
    "krylov_lower_bound",
]
