"""Compiled primitives shared by every kernel sum: the exponential, layouts, the thread rule.

The landmark kernels (:mod:`manifolds.lddmm.kernels_numba`) and the surface data
terms (:mod:`manifolds.data_terms.surface_kernels_numba`) are built from these:

* :func:`gexp`: ``exp(x)`` for ``x <= 0`` by a vectorisable polynomial (the Taylor
  polynomial of ``exp(x / 64)`` raised to the 64th power; relative error below
  ``3e-14``, exactly zero below ``x = -40``);
* :func:`to_soa`, :func:`from_soa`: ``(n, d)`` points to the contiguous ``(3, n)``
  layout the inner loops vectorise over, and back;
* :func:`use_parallel`: the one rule for running a sum's parallel loop (at least
  :data:`PARALLEL_MIN_PAIRS` pairs and more than one numba thread);
* :data:`JIT_FLAGS`: the compilation flags of every kernel.
"""

from __future__ import annotations

import os

import numba
import numpy as np
from numba import njit

#: Spins of an idle OpenMP thread before it sleeps, for the parallel loops (numba's
#: ``omp`` threading layer, GNU OpenMP). The default, 300,000 spins, keeps each thread
#: busy-waiting between the short parallel loops of a registration; when another
#: process takes a core, the spinning threads and the loop's own threads fight for it
#: and a parallel sum becomes several times slower than the serial one. With 1,000
#: spins it costs nothing alone and stays near the serial time under load
#: (``benchmarks/bench_threads_under_load.py``, table in ``docs/evidence/performance.md``). A value
#: the user set is kept; it must be set before OpenMP starts: numba starts it at the
#: first parallel loop, not at import.
GOMP_SPINCOUNT = "1000"
os.environ.setdefault("GOMP_SPINCOUNT", GOMP_SPINCOUNT)


__all__ = [
    "JIT_FLAGS",
    "PARALLEL_MIN_PAIRS",
    "gexp",
    "to_soa",
    "from_soa",
    "check_dim",
    "use_parallel",
]

#: Pairs below which a sum runs its serial loop: about a quarter of a millisecond of
#: work, below which starting the threads costs more than it saves (measured on the
#: 642-vertex registration: dense, 412,000 pairs a sum, 1.44 times faster on 2 threads;
#: grid, 29,000 pairs, slower). Batches of workers keep one thread each
#: (:mod:`manifolds.kernels.threads`), so the parallel loops run in lone computations.
PARALLEL_MIN_PAIRS = 100_000
JIT_FLAGS = {"fastmath": True, "cache": True, "nogil": True}


@njit(inline="always", **JIT_FLAGS)
def gexp(x):  # pragma: no cover - compiled
    """``exp(x)`` for ``x <= 0``: Taylor polynomial of ``exp(x / 64)`` raised to the 64th power."""
    t = x * 0.015625 + 0.3125
    p = 1.0 / 6227020800.0
    p = p * t + 1.0 / 479001600.0
    p = p * t + 1.0 / 39916800.0
    p = p * t + 1.0 / 3628800.0
    p = p * t + 1.0 / 362880.0
    p = p * t + 1.0 / 40320.0
    p = p * t + 1.0 / 5040.0
    p = p * t + 1.0 / 720.0
    p = p * t + 1.0 / 120.0
    p = p * t + 1.0 / 24.0
    p = p * t + 1.0 / 6.0
    p = p * t + 0.5
    p = p * t + 1.0
    p = p * t + 1.0
    p = p * 0.7316156289466418  # exp(-0.3125)
    p = p * p
    p = p * p
    p = p * p
    p = p * p
    p = p * p
    p = p * p
    return p if x > -40.0 else 0.0


def to_soa(arr: np.ndarray) -> np.ndarray:
    """``(n, d)`` -> contiguous ``(3, n)`` with zero padding for ``d < 3``."""
    arr = np.asarray(arr, dtype=np.float64)
    out = np.zeros((3, arr.shape[0]))
    out[: arr.shape[1]] = arr.T
    return out


def from_soa(arr: np.ndarray, d: int) -> np.ndarray:
    """Contiguous ``(3, n)`` -> ``(n, d)``: the inverse of :func:`to_soa`."""
    return np.ascontiguousarray(arr[:d].T)


def check_dim(*arrays):
    """Raise a ``ValueError`` unless every array is ``(n, d)`` with ``d <= 3``."""
    for arr in arrays:
        if arr.ndim != 2 or arr.shape[1] not in (1, 2, 3):
            raise ValueError(f"kernels_numba: expected (n, d) arrays with d <= 3, got {arr.shape}")


def use_parallel(n_pairs: int) -> bool:
    """Whether a sum over ``n_pairs`` pairs runs its parallel loop (above ``PARALLEL_MIN_PAIRS``)."""
    return n_pairs >= PARALLEL_MIN_PAIRS and numba.get_num_threads() > 1
