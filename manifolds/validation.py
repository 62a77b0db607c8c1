"""Cheap input checks shared by every space.

Each check names the offending argument so that a user reading the traceback
knows which input to fix. Checks return the input converted to a float64 array.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .errors import ManifoldError

__all__ = ["as_float_array", "check_shape", "check_finite", "check_array"]


def as_float_array(x, name: str) -> np.ndarray:
    """Convert ``x`` to a float64 ndarray or raise a :class:`ManifoldError`."""
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ManifoldError(f"{name}: cannot be converted to a float array ({exc})") from exc
    return arr


def check_shape(arr: np.ndarray, trailing: Sequence[int], name: str) -> np.ndarray:
    """Check that the trailing axes of ``arr`` equal ``trailing`` (leading axes are batch)."""
    trailing = tuple(trailing)
    nd = len(trailing)
    if arr.ndim < nd or arr.shape[arr.ndim - nd :] != trailing:
        raise ManifoldError(
            f"{name}: expected shape (..., {', '.join(map(str, trailing))}) but got {arr.shape}"
        )
    return arr


def check_finite(arr: np.ndarray, name: str) -> np.ndarray:
    """Raise if ``arr`` holds NaN or infinite entries."""
    if not np.isfinite(arr).all():
        n_bad = int(arr.size - np.count_nonzero(np.isfinite(arr)))
        raise ManifoldError(f"{name}: contains {n_bad} NaN or infinite value(s)")
    return arr


def check_array(x, trailing: Sequence[int], name: str) -> np.ndarray:
    """Float64 conversion, trailing-shape check and finiteness check in one call."""
    arr = as_float_array(x, name)
    check_shape(arr, trailing, name)
    return check_finite(arr, name)
