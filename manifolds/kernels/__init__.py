"""The kernel layer, below every space that sums kernels (LDDMM landmarks, surface data terms).

- :mod:`.backends`: one registry of backends (numpy, numba; room for more) and one
  ``"auto"`` rule (:func:`resolve_backend`);
- :mod:`.numba_primitives`: the compiled primitives every compiled kernel is built
  from (the exponential, point layouts, the rule for parallel loops); imported by the
  compiled backends only, so that importing this package does not compile anything.

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

__all__ = [
    "AUTO_ORDER",
    "available_backends",
    "backend_available",
    "numba_available",
    "register_backend",
    "resolve_backend",
]
