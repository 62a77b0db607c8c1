"""The kernel layer, below every space that sums kernels (LDDMM landmarks, surface data terms).

- :mod:`.backends`: one registry of backends (numpy, numba; room for more) and one
  ``"auto"`` rule (:func:`resolve_backend`);
- :mod:`.numba_primitives`: the compiled primitives every compiled kernel is built
  from (the exponential, point layouts, the rule for parallel loops); imported by the
  compiled backends only, so that importing this package does not compile anything;
- :mod:`.threads`: how many threads the compiled sums use (:func:`kernel_threads`,
  :func:`threads_per_worker`): every core alone, one per worker in a batch.

This layer imports no space: :mod:`manifolds.lddmm` and :mod:`manifolds.data_terms`
import it, never each other.
"""

from .backends import (
    AUTO_ORDER,
    available_backends,
    backend_available,
    numba_available,
    register_backend,
    resolve_backend,
)
from .threads import kernel_threads, threads_per_worker

__all__ = [
    "AUTO_ORDER",
    "available_backends",
    "backend_available",
    "numba_available",
    "register_backend",
    "resolve_backend",
    "kernel_threads",
    "threads_per_worker",
]
