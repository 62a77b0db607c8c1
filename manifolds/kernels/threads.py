"""How many threads the compiled kernel sums use: every core for a lone computation, one
per worker when several processes share the machine.

A kernel sum runs its parallel loop above
:data:`~manifolds.kernels.numba_primitives.PARALLEL_MIN_PAIRS` pairs and when numba has
more than one thread (:func:`~manifolds.kernels.numba_primitives.use_parallel`). A
single registration therefore uses every core; a study or a correspondence running
``jobs`` processes on the same machine calls :func:`threads_per_worker` and runs each
task inside :func:`kernel_threads`, so that ``jobs`` workers times their threads do not
exceed the cores (no oversubscription).
"""

from __future__ import annotations

import contextlib
import os

from .backends import numba_available

__all__ = ["kernel_threads", "threads_per_worker"]


def threads_per_worker(jobs: int | None, cores: int | None = None) -> int | None:
    """Kernel threads for each of ``jobs`` workers on ``cores`` cores (None: leave as is).

    ``jobs`` of 1 (or None) is a lone computation: None, every thread numba has. ``-1``
    (joblib: one worker per core) and any ``jobs`` >= the cores give 1.
    """
    if jobs is None or jobs == 1:
        return None
    cores = cores or os.cpu_count() or 1
    workers = cores if jobs < 0 else int(jobs)
    return max(1, cores // max(workers, 1))


@contextlib.contextmanager
def kernel_threads(n: int | None):
    """Run the compiled kernel sums of the block on at most ``n`` threads (None: unchanged)."""
    if n is None or not numba_available():
        yield
        return
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(max(1, min(int(n), numba.config.NUMBA_NUM_THREADS)))
    try:
        yield
    finally:
        numba.set_num_threads(before)
