"""Amplitude normalisation of a tangent vector: the scale at which a measure of its shot reaches a target.

Transported deformations keep their norm, not what a clinician reads off the
motion: a contraction transported from a large heart to a small atlas empties the
atlas by a larger fraction of its volume. Guigui, Moceri, Sermesant and Pennec
(ISBI 2021, "Cardiac motion modeling with parallel transport and shape splines")
therefore normalise the amplitude of transported deformations.
:func:`normalize_amplitude` generalises it: it finds the scale ``lam`` at which a
scalar measure of ``Exp_base(lam u)`` equals a target (e.g. the atlas's relative
volume change equal to the subject's, which keeps the subject's ejection fraction).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.optimize import brentq

__all__ = ["normalize_amplitude"]


def normalize_amplitude(
    space,
    base,
    tangent,
    measure: Callable,
    target: float,
    bracket: tuple[float, float] = (0.0, 4.0),
    xtol: float = 1e-10,
):
    """``(lam * tangent, lam)`` with ``measure(space.exp(base, lam * tangent)) == target``.

    Parameters
    ----------
    space : manifolds.Connection
    base : point of ``space``
    tangent : tangent vector at ``base``
    measure : callable
        A scalar function of a point of ``space``.
    target : float
    bracket : (float, float), default (0, 4)
        Scales between which the root is searched (:func:`scipy.optimize.brentq`);
        the measure minus the target must change sign between them.
    xtol : float
        Absolute tolerance on ``lam``.

    Returns
    -------
    tangent, float

    Raises
    ------
    ValueError
        ``target`` or a value of the measure is not finite, or the bracket holds no root
        (the message gives the measure at both ends).
    """
    target = float(target)
    if not np.isfinite(target):
        raise ValueError(f"target: expected a finite number, got {target}")
    low, high = (float(b) for b in bracket)
    if not low < high:
        raise ValueError(f"bracket: expected (low, high) with low < high, got {bracket}")

    def gap(lam: float) -> float:
        value = float(measure(space.exp(base, lam * tangent)))
        if not np.isfinite(value):
            raise ValueError(f"measure: not finite at the scale {lam:g}")
        return value - target

    g_low, g_high = gap(low), gap(high)
    if g_low == 0.0:
        return low * tangent, low
    if np.sign(g_low) == np.sign(g_high):
        raise ValueError(
            f"bracket: the measure is {g_low + target:.6g} at scale {low:g} and "
            f"{g_high + target:.6g} at {high:g}, both on one side of the target {target:.6g}"
        )
    lam = float(brentq(gap, low, high, xtol=xtol))
    return lam * tangent, lam
