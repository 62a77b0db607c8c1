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
        Scales between which the root is searched. The measure is evaluated from
        ``low`` on a doubling grid of scales (``low + (high - low) 2^-m``, ``m = 7 .. 0``)
        and the root is the first sign change of the measure minus the target, refined by
        :func:`scipy.optimize.brentq`: the smallest scale that reaches the target. A
        measure that is not monotone over the bracket (e.g. a volume ratio once the
        shot surface folds at large scales) then still gives the root nearest ``low``.
    xtol : float
        Absolute tolerance on ``lam``.

    Returns
    -------
    tangent, float

    Raises
    ------
    ValueError
        ``target`` or a value of the measure is not finite, or the bracket holds no root
        (the message gives the measure at both ends and its smallest and largest values
        on the grid).
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

    g_low = gap(low)
    if g_low == 0.0:
        return low * tangent, low
    scales = [low + (high - low) * 2.0**-m for m in range(7, -1, -1)]
    previous, g_previous, seen = low, g_low, [g_low]
    for scale in scales:
        g = gap(scale)
        seen.append(g)
        if g == 0.0:
            return scale * tangent, scale
        if np.sign(g) != np.sign(g_previous):
            lam = float(brentq(gap, previous, scale, xtol=xtol))
            return lam * tangent, lam
        previous, g_previous = scale, g
    raise ValueError(
        f"bracket: the measure is {g_low + target:.6g} at scale {low:g} and "
        f"{seen[-1] + target:.6g} at {high:g}, between {min(seen) + target:.6g} and "
        f"{max(seen) + target:.6g} on the way, always on one side of the target {target:.6g}"
    )
