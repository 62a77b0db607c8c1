"""L-BFGS-B minimisation with an objective history and an explicit convergence flag.

During the iterations the BLAS libraries loaded by numpy and scipy are
limited to ``LBFGSOptions.blas_threads`` threads (one by default). Each
L-BFGS-B step and each preconditioner application is a small BLAS call; with
a threaded BLAS every one of them wakes worker threads that then compete with
the objective's own (compiled, parallel) kernels, which on a machine with few
cores costs far more than the call itself, and makes the iterates depend on
the thread count. The previous setting is restored on exit.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.optimize
import threadpoolctl

from ..errors import ManifoldError
from ..validation import check_float, check_int

__all__ = ["LBFGSOptions", "OptimizationResult", "minimize_lbfgsb", "limit_blas_threads"]


@contextlib.contextmanager
def limit_blas_threads(n_threads: int | None = 1):
    """Context limiting the BLAS thread pools of the process to ``n_threads``.

    Uses ``threadpoolctl``; ``None`` leaves the pools unchanged. The previous
    settings are restored on exit.
    """
    if n_threads is None:
        yield
        return
    global _CONTROLLER
    if _CONTROLLER is None:  # scanning the loaded libraries costs ~2 ms: do it once
        _CONTROLLER = threadpoolctl.ThreadpoolController()
    with _CONTROLLER.limit(limits=int(n_threads), user_api="blas"):
        yield


_CONTROLLER = None


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
        A long memory costs little next to a registration objective and helps on
        the ill-conditioned, curved LDDMM objective (100 instead of 30 lowers the
        objective after 100 iterations of the 642-vertex benchmark by 0.8 %).
    max_line_search : int
        Maximum number of function evaluations per line search.
    blas_threads : int or None
        BLAS threads during the iterations (see the module docstring);
        None keeps the process setting.
    """

    max_iter: int = 500
    ftol: float = 1e-11
    gtol: float = 1e-9
    max_corrections: int = 100
    max_line_search: int = 30
    blas_threads: int | None = 1

    def __post_init__(self):
        for key in ("max_iter", "max_corrections", "max_line_search"):
            check_int(getattr(self, key), f"LBFGSOptions: {key}", minimum=1)
        for key in ("ftol", "gtol"):
            check_float(getattr(self, key), f"LBFGSOptions: {key}", minimum=0.0)
        if self.blas_threads is not None:
            check_int(self.blas_threads, "LBFGSOptions: blas_threads", minimum=1)

    @classmethod
    def coerce(cls, options, name: str = "optimizer") -> LBFGSOptions:
        """``options`` as LBFGSOptions: None (defaults), a dict of fields, or an instance."""
        if options is None:
            return cls()
        if isinstance(options, cls):
            return options
        if not isinstance(options, dict):
            raise TypeError(
                f"{name}: expected LBFGSOptions, a dict or None, got {type(options).__name__}"
            )
        unknown = sorted(set(options) - set(cls.__dataclass_fields__))
        if unknown:
            raise ManifoldError(
                f"{name}: unknown option(s) {unknown}; expected keys among "
                f"{sorted(cls.__dataclass_fields__)}"
            )
        return cls(**options)


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

    history: list = []

    def callback(intermediate_result):
        history.append(float(intermediate_result.fun))

    with limit_blas_threads(opts.blas_threads):
        history.append(wrapped(x0.copy())[0])
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
