"""Limit the BLAS thread pools while an optimiser runs.

Each quasi-Newton step and each preconditioner application is a small BLAS
call; with a threaded BLAS every one of them wakes worker threads that then
compete with the objective's own (compiled, parallel) kernels, which on a
machine with few cores costs far more than the call itself, and makes the
iterates depend on the thread count. The previous setting is restored on exit.
"""

from __future__ import annotations

import contextlib

import threadpoolctl

__all__ = ["limit_blas_threads"]

_CONTROLLER = None


@contextlib.contextmanager
def limit_blas_threads(n_threads: int | None = 1):
    """Context limiting the BLAS thread pools of the process to ``n_threads``.

    Uses ``threadpoolctl``; ``None`` leaves the pools unchanged.
    """
    if n_threads is None:
        yield
        return
    global _CONTROLLER
    if _CONTROLLER is None:  # scanning the loaded libraries costs ~2 ms: do it once
        _CONTROLLER = threadpoolctl.ThreadpoolController()
    with _CONTROLLER.limit(limits=int(n_threads), user_api="blas"):
        yield
