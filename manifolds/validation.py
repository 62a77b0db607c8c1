"""Cheap input checks shared by every space.

Each check names the offending argument, says what was expected and what was
given, so that a user reading the message knows which input to fix. Array
checks return the input converted to a float64 array; scalar checks return the
converted value.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence

import numpy as np

from .errors import ManifoldError

__all__ = [
    "as_float_array",
    "check_shape",
    "check_finite",
    "check_array",
    "check_batch_shapes",
    "check_finite_result",
    "check_rng",
    "check_n_samples",
    "check_int",
    "check_float",
]


def _describe(value) -> str:
    """Short description of a given value for error messages."""
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({type(value).__name__})"


def as_float_array(x, name: str) -> np.ndarray:
    """Convert ``x`` to a float64 ndarray or raise a :class:`ManifoldError`.

    Complex input is refused (not silently cast to its real part), as are
    strings and ragged or object sequences.
    """
    if isinstance(x, str | bytes):
        raise ManifoldError(f"{name}: expected a real array, got the string {x!r}")
    try:
        raw = np.asarray(x)
    except (TypeError, ValueError) as exc:
        raise ManifoldError(f"{name}: expected a real array, got {_describe(x)} ({exc})") from exc
    if np.iscomplexobj(raw):
        raise ManifoldError(f"{name}: expected a real array, got a complex array ({raw.dtype})")
    if raw.dtype.kind in "USV":
        raise ManifoldError(f"{name}: expected a real array, got an array of {raw.dtype}")
    try:
        arr = np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ManifoldError(f"{name}: expected a real array, got {_describe(x)} ({exc})") from exc
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
        raise ManifoldError(
            f"{name}: contains {n_bad} NaN or infinite value(s) (expected finite values)"
        )
    return arr


def check_array(x, trailing: Sequence[int], name: str) -> np.ndarray:
    """Float64 conversion, trailing-shape check and finiteness check in one call."""
    arr = as_float_array(x, name)
    check_shape(arr, trailing, name)
    return check_finite(arr, name)


def check_batch_shapes(point_ndim: int, where: str, **arrays: np.ndarray) -> tuple[int, ...]:
    """Check that the batch (leading) shapes of ``arrays`` broadcast together.

    Parameters
    ----------
    point_ndim : int
        Number of trailing axes making up one point (``len(point_shape)``).
    where : str
        Prefix of the message (e.g. the space's name).
    **arrays
        The arrays, keyed by argument name.

    Returns
    -------
    tuple of int
        The broadcast batch shape.
    """
    leads = {k: np.shape(a)[: np.ndim(a) - point_ndim] for k, a in arrays.items()}
    try:
        return np.broadcast_shapes(*leads.values())
    except ValueError:
        given = ", ".join(f"{k} {v}" for k, v in leads.items())
        raise ManifoldError(
            f"{where}: batch shapes of {', '.join(leads)} do not broadcast: expected equal "
            f"(or broadcastable) leading axes, got {given}"
        ) from None


def check_finite_result(arr: np.ndarray, name: str, what: str) -> np.ndarray:
    """Raise if a result computed from finite input is not finite (overflow).

    ``name`` is the argument responsible (e.g. ``"Hyperbolic: tangent"``) and
    ``what`` explains the likely cause.
    """
    if not np.isfinite(arr).all():
        raise ManifoldError(f"{name}: {what}; the result overflowed to NaN or infinity")
    return arr


def check_rng(rng, name: str = "rng") -> np.random.Generator:
    """Check that ``rng`` is a :class:`numpy.random.Generator`."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(
            f"{name}: expected a numpy.random.Generator (np.random.default_rng(seed)), "
            f"got {_describe(rng)}"
        )
    return rng


def check_int(value, name: str, minimum: int | None = None) -> int:
    """``value`` as an int, refusing bools, non-integral numbers and values below ``minimum``."""
    ok = isinstance(value, numbers.Integral) and not isinstance(value, bool)
    if not ok and isinstance(value, numbers.Real) and not isinstance(value, bool):
        ok = math.isfinite(value) and float(value) == int(value)
    bound = "" if minimum is None else f" >= {minimum}"
    if not ok or (minimum is not None and int(value) < minimum):
        raise ManifoldError(f"{name}: expected an integer{bound}, got {_describe(value)}")
    return int(value)


def check_float(
    value,
    name: str,
    minimum: float | None = None,
    strict: bool = False,
) -> float:
    """``value`` as a finite float, at least ``minimum`` (strictly above it if ``strict``)."""
    bound = "" if minimum is None else f" {'>' if strict else '>='} {minimum:g}"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        if not (isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "fiu"):
            raise ManifoldError(f"{name}: expected a finite number{bound}, got {_describe(value)}")
    x = float(value)
    low_ok = minimum is None or (x > minimum if strict else x >= minimum)
    if not math.isfinite(x) or not low_ok:
        raise ManifoldError(f"{name}: expected a finite number{bound}, got {_describe(value)}")
    return x


def check_n_samples(n_samples, name: str = "n_samples") -> int | None:
    """``None`` (one point) or an integer ``>= 1``."""
    if n_samples is None:
        return None
    return check_int(n_samples, name, minimum=1)
