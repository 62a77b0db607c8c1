"""Shared bookkeeping of the ladders: validation, rung points and trajectories."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from manifolds.connection import Connection

__all__ = ["LadderTrajectory", "check_ladder_args", "rung_points"]


@dataclass
class LadderTrajectory:
    """Points built by a ladder, for plotting and diagnostics.

    Attributes
    ----------
    main_points : list of arrays
        ``x_0 = base, ..., x_n = end`` along the main geodesic.
    pivots : list of arrays
        Per rung, the centre of the symmetry (pole ladder: the midpoint on the
        main geodesic; Schild's ladder: the midpoint of the rung's diagonal).
    rung_tips : list of arrays
        Per rung, ``Exp_{x_i}(w_i)``: the tip of the vector being transported.
    reflected : list of arrays
        Per rung, the image of the symmetry.
    end_point : array
        ``Exp_end(transported)``, e.g. the deformed atlas ``T'``.
    """

    main_points: list = field(default_factory=list)
    pivots: list = field(default_factory=list)
    rung_tips: list = field(default_factory=list)
    reflected: list = field(default_factory=list)
    end_point: np.ndarray | None = None


def check_ladder_args(space, n_rungs, scaling_exponent) -> int:
    """Validate the arguments common to the ladders; return ``n_rungs`` as int."""
    if not isinstance(space, Connection):
        raise TypeError(f"space: expected a manifolds.Connection, got {type(space).__name__}")
    if isinstance(n_rungs, bool) or int(n_rungs) != n_rungs or n_rungs < 1:
        raise ValueError(f"n_rungs: expected a positive integer, got {n_rungs!r}")
    if not np.isfinite(scaling_exponent) or scaling_exponent < 0:
        raise ValueError(
            f"scaling_exponent: expected a finite number >= 0, got {scaling_exponent!r}"
        )
    return int(n_rungs)


def rung_points(space, base, end, n_rungs: int, with_halves: bool = True):
    """Points ``x_0 = base, ..., x_n = end`` and half-way points ``x_{i+1/2}``.

    The main geodesic is shot from ``end`` (as the paper's midpoint
    ``M = Exp_T(1/2 Log_T(S))``), so that a single ``log`` is needed; the
    end points are the given ``base`` and ``end`` themselves.
    """
    if n_rungs == 1:
        return [base, end], ([space.midpoint(end, base)] if with_halves else [])
    v = space.log(end, base)
    main = [base]
    main += [space.exp(end, (1.0 - i / n_rungs) * v) for i in range(1, n_rungs)]
    main.append(end)
    if not with_halves:
        return main, []
    halves = [space.exp(end, (1.0 - (i + 0.5) / n_rungs) * v) for i in range(n_rungs)]
    return main, halves
