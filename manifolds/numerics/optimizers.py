"""L-BFGS-B minimisation with an objective history and an explicit convergence flag."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.optimize

__all__ = ["LBFGSOptions", "OptimizationResult", "minimize_lbfgsb"]


@dataclass(frozen=True)
class LBFGSOptions:
    """Settings of :func:`minimize_lbfgsb`.

    Attributes
    ----------
    max_iter : int
        Maximum number of L-BFGS iterations.
    ftol : float
        Stop when the relative decrease ``(f_k - f_{k+1}) / max(|f_k|, |f_{k+1}|, 1)``
        falls below ``ftol`` (the objective is normalised to be of order one).
    gtol : float
        Stop when the largest gradient component falls below ``gtol``.
    max_corrections : int
        Number of stored correction pairs (memory of the Hessian approximation).
    max_line_search : int
        Maximum number of function evaluations per line search.
    """

    max_iter: int = 500
    ftol: float = 1e-11
    gtol: float = 1e-9
    max_corrections: int = 30
    max_line_search: int = 30


@dataclass
class OptimizationResult:
    """Outcome of :func:`minimize_lbfgsb`."""

    x: np.ndarray
    fun: float
    grad: np.ndarray
    n_iter: int
    n_evals: int
    history: list = field(default_factory=list)
    converged: bool = False
    message: str = ""


def minimize_lbfgsb(
    fun_and_grad: Callable[[np.ndarray], tuple[float, np.ndarray]],
    x0: np.ndarray,
    options: LBFGSOptions | None = None,
) -> OptimizationResult:
    """Minimise ``f`` with scipy's L-BFGS-B given ``x -> (f(x), grad f(x))``.

    ``history`` holds ``f`` at ``x0`` followed by its value after every
    iteration. ``converged`` is True when the run stopped on ``ftol`` or
    ``gtol``; a line search that cannot decrease ``f`` further counts as
    converged only when the gradient is already within ``10 gtol``.
    """
    opts = LBFGSOptions() if options is None else options
    x0 = np.asarray(x0, dtype=float).ravel()
    cache: dict = {}
    n_evals = [0]

    def wrapped(x):
        key = x.tobytes()
        if cache.get("key") != key:
            f, g = fun_and_grad(x)
            n_evals[0] += 1
            cache.update(key=key, f=float(f), g=np.asarray(g, dtype=float).ravel())
        return cache["f"], cache["g"].copy()

    f0, _ = wrapped(x0.copy())
    history = [f0]

    def callback(intermediate_result):
        history.append(float(intermediate_result.fun))

    res = scipy.optimize.minimize(
        wrapped,
        x0,
        jac=True,
        method="L-BFGS-B",
        callback=callback,
        options={
            "maxiter": int(opts.max_iter),
            "ftol": float(opts.ftol),
            "gtol": float(opts.gtol),
            "maxcor": int(opts.max_corrections),
            "maxls": int(opts.max_line_search),
        },
    )
    f, g = wrapped(res.x)
    message = str(res.message)
    converged = bool(res.success)
    if not converged and "ABNORMAL" in message.upper():
        converged = bool(np.max(np.abs(g), initial=0.0) <= 10.0 * opts.gtol)
    return OptimizationResult(
        x=np.asarray(res.x, dtype=float),
        fun=f,
        grad=g,
        n_iter=int(res.nit),
        n_evals=n_evals[0],
        history=history,
        converged=converged,
        message=message,
    )
