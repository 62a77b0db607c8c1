"""Convergence studies of transport schemes: errors against a reference and log-log slopes."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from manifolds.validation import check_float, check_int

__all__ = ["loglog_slope", "ConvergenceCurve", "ladder_convergence"]


def loglog_slope(x: Sequence[float], y: Sequence[float]) -> float:
    """Least-squares slope of ``log y`` against ``log x``.

    Parameters
    ----------
    x, y : sequences of positive numbers of equal length (at least 2)

    Returns
    -------
    float
        The measured order: ``y ~ x^slope``.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.shape != y.shape or x.ndim != 1 or x.size < 2:
        raise ValueError(
            f"x, y: expected two 1-D sequences of equal length >= 2, got {x.shape}, {y.shape}"
        )
    if np.any(x <= 0) or np.any(y <= 0) or not (np.isfinite(x).all() and np.isfinite(y).all()):
        raise ValueError("x, y: a log-log slope needs finite positive values")
    slope, _ = np.polyfit(np.log(x), np.log(y), 1)
    return float(slope)


@dataclass
class ConvergenceCurve:
    """Errors of a ladder for several numbers of rungs, with the fitted slope."""

    label: str
    n_rungs: np.ndarray
    errors: np.ndarray

    @property
    def slope(self) -> float:
        return loglog_slope(self.n_rungs, self.errors)


def ladder_convergence(
    space,
    ladder: Callable,
    base,
    end,
    tangent,
    reference,
    n_rungs: Sequence[int] = (2, 4, 8, 16, 32),
    scaling_exponent: float = 1.0,
    label: str = "",
    error: Callable | None = None,
) -> ConvergenceCurve:
    """Run ``ladder`` for each number of rungs and measure the error against ``reference``.

    Parameters
    ----------
    space : manifolds.Connection
    ladder : callable
        :func:`ladders.pole_ladder`, :func:`ladders.schild_ladder` or any function
        with their signature.
    base, end, tangent :
        Transport ``tangent`` from ``base`` to ``end``.
    reference : tangent vector at ``end``
        The exact (or reference) parallel transport.
    n_rungs : sequence of int
    scaling_exponent : float
    label : str
        Name used in tables and plots.
    error : callable, optional
        ``error(computed, reference) -> float``; default: relative Euclidean error
        of the coordinates, ``|computed - reference| / |reference|``.
    """
    if not callable(ladder):
        raise TypeError(f"ladder: expected a callable such as ladders.pole_ladder, got {ladder!r}")
    if error is not None and not callable(error):
        raise TypeError(f"error: expected a callable (computed, reference) -> float, got {error!r}")
    if isinstance(n_rungs, str | bytes) or not hasattr(n_rungs, "__len__") or len(n_rungs) == 0:
        raise ValueError(f"n_rungs: expected a non-empty sequence of integers, got {n_rungs!r}")
    n_rungs = [check_int(n, "n_rungs", minimum=1) for n in n_rungs]
    check_float(scaling_exponent, "scaling_exponent", minimum=0.0)
    if error is None:

        def error(computed, ref):
            return float(np.linalg.norm(np.asarray(computed) - ref) / np.linalg.norm(ref))

    errs = [
        error(
            ladder(space, base, end, tangent, n_rungs=n, scaling_exponent=scaling_exponent),
            reference,
        )
        for n in n_rungs
    ]
    return ConvergenceCurve(label, np.asarray(n_rungs, dtype=float), np.asarray(errs))
