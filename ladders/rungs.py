"""The rung driver shared by the pole ladder and Schild's ladder.

Both ladders cut the geodesic from ``base`` to ``end`` into ``n`` segments, scale
the vector down by ``n**a``, carry it through one rung per segment and scale it
back; they differ only in the rung (a :data:`Rung`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from manifolds.connection import Connection
from manifolds.validation import check_float, check_int

__all__ = ["LadderTrajectory", "Rung", "check_ladder_args", "rung_points", "run_ladder"]

#: ``rung(space, x_i, x_next, half, tip) -> (pivot, reflected, w_next)``: one rung from
#: ``x_i`` to ``x_next`` given the tip ``Exp_{x_i}(w_i)`` (``half`` is the main
#: geodesic's point half-way, or ``None`` when the ladder does not ask for it).
Rung = Callable


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
    check_float(scaling_exponent, "scaling_exponent", minimum=0.0)
    return check_int(n_rungs, "n_rungs", minimum=1)


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


def run_ladder(
    space,
    base,
    end,
    tangent,
    rung: Rung,
    n_rungs: int,
    scaling_exponent: float,
    return_trajectory: bool,
    with_halves: bool,
):
    """Transport ``tangent`` from ``base`` to ``end`` through ``n_rungs`` applications of ``rung``.

    The vector is divided by ``n_rungs ** scaling_exponent`` before the first
    rung and multiplied back after the last. Returns the transported vector at
    ``end`` and, if ``return_trajectory``, a :class:`LadderTrajectory`.
    """
    n = check_ladder_args(space, n_rungs, scaling_exponent)
    space.check_point(base, "base")
    space.check_point(end, "end")
    scale = float(n) ** scaling_exponent
    main, halves = rung_points(space, base, end, n, with_halves=with_halves)
    traj = LadderTrajectory(main_points=main) if return_trajectory else None
    w = tangent if scale == 1.0 else tangent * (1.0 / scale)
    for i in range(n):
        tip = space.exp(main[i], w)
        half = halves[i] if with_halves else None
        pivot, reflected, w = rung(space, main[i], main[i + 1], half, tip)
        if traj is not None:
            traj.pivots.append(pivot)
            traj.rung_tips.append(tip)
            traj.reflected.append(reflected)
    transported = w if scale == 1.0 else w * scale
    if traj is None:
        return transported
    traj.end_point = space.exp(end, transported)
    return transported, traj
