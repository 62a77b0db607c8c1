"""One resumable runner for the application's batches: a study's subjects, a correspondence's
subjects, a meshing's images.

:func:`run_batch` asks each step's own ``reuse`` check whether an item is already done
(the study's pair store, the correspondence's records, the meshing's provenance files:
each knows what its results depend on) and yields those results at once; it runs
``work(*task)`` for the others, in ``jobs`` processes (joblib) or in this one, and yields
each result as it finishes, so that the caller (or the work function) stores it at
once: an interruption keeps every finished item, and a rerun resumes. The work
functions record their own failures (a failing item returns a record saying why and
never stops the others). Threads: a lone run lets the compiled kernel sums use every
core; several workers share the cores (:func:`~manifolds.kernels.threads_per_worker`),
and BLAS runs on one thread in every case, so that an item's numbers do not depend on
``jobs``. Every item runs in the caller's current folder (a worker kept from an earlier
batch changes to it first), so that relative paths in the tasks mean what they mean to
the caller.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Iterator

from manifolds.kernels import kernel_threads, threads_per_worker
from manifolds.numerics.solvers import limit_blas_threads

__all__ = ["run_batch"]


def _call(work: Callable, threads: int | None, task: tuple, cwd: str | None = None):
    if cwd is not None and os.getcwd() != cwd:  # a reused worker: the caller's folder
        os.chdir(cwd)
    with kernel_threads(threads), limit_blas_threads(1):
        return work(*task)


def run_batch(
    work: Callable,
    tasks: Iterable[tuple],
    *,
    jobs: int = 1,
    progress: bool | Callable = False,
    desc: str = "items",
    unit: str = "item",
    ordered: bool = True,
    reuse: Callable | None = None,
) -> Iterator:
    """Run ``work(*task)`` for every task not done yet; yield each result as it finishes.

    Parameters
    ----------
    work : callable
        A module-level function (it is sent to the worker processes).
    tasks : iterable of tuple
        Its arguments, one tuple per item.
    jobs : int
        Worker processes (joblib; ``-1``: one per core; 1: this process).
    progress : bool or callable
        True: a progress bar (tqdm) over the items; a callable: called with each result.
    desc, unit : str
        The progress bar's label and unit.
    ordered : bool
        Yield in the tasks' order (else as they finish).
    reuse : callable, optional
        ``reuse(*task)``, called here for every task before any runs: the stored
        result of a task already done (yielded first, in the tasks' order, without
        running it), or None (the task runs).
    """
    from joblib import Parallel, delayed
    from tqdm.auto import tqdm

    tasks = list(tasks)
    if not tasks:
        return
    bar = tqdm(total=len(tasks), desc=desc, unit=unit, disable=progress is not True)
    pending = []
    try:
        for task in tasks:
            stored = None if reuse is None else reuse(*task)
            if stored is None:
                pending.append(task)
                continue
            bar.update(1)
            if callable(progress):
                progress(stored)
            yield stored
        if not pending:
            return
        threads = threads_per_worker(jobs)
        kind = "generator" if ordered else "generator_unordered"
        runner = Parallel(n_jobs=jobs, return_as=kind)
        cwd = os.getcwd()  # relative paths in the tasks mean the caller's folder
        for result in runner(delayed(_call)(work, threads, task, cwd) for task in pending):
            bar.update(1)
            if callable(progress):
                progress(result)
            yield result
    finally:
        bar.close()
