"""Schild's ladder: parallel transport by geodesic parallelograms."""

from __future__ import annotations

from .rungs import LadderTrajectory, check_ladder_args, rung_points

__all__ = ["schild_ladder"]


def schild_ladder(
    space,
    base,
    end,
    tangent,
    n_rungs: int = 1,
    scaling_exponent: float = 2.0,
    return_trajectory: bool = False,
):
    """Transport ``tangent`` from ``base`` to ``end`` with Schild's ladder.

    Each rung from ``x_i`` to ``x_{i+1}`` with vector ``w_i``: ``p = Exp_{x_i}(w_i)``,
    ``m = midpoint(p, x_{i+1})``, ``q = s_m(x_i)`` and ``w_{i+1} = Log_{x_{i+1}}(q)``.
    A rung is second order only, so the error after ``n`` rungs decreases as
    ``n^-1`` with ``scaling_exponent = 1`` and as ``n^-2`` with ``scaling_exponent = 2``.

    The parameters and return values are those of :func:`ladders.pole_ladder`
    (here ``pivots`` holds the rung diagonals' midpoints).
    """
    n = check_ladder_args(space, n_rungs, scaling_exponent)
    scale = float(n) ** scaling_exponent
    main, _ = rung_points(space, base, end, n, with_halves=False)
    traj = LadderTrajectory(main_points=main) if return_trajectory else None
    w = tangent if scale == 1.0 else tangent * (1.0 / scale)
    for i in range(n):
        tip = space.exp(main[i], w)
        pivot = space.midpoint(tip, main[i + 1])
        reflected = space.symmetry(pivot, main[i])
        w = space.log(main[i + 1], reflected)
        if traj is not None:
            traj.pivots.append(pivot)
            traj.rung_tips.append(tip)
            traj.reflected.append(reflected)
    transported = w if scale == 1.0 else w * scale
    if traj is None:
        return transported
    traj.end_point = space.exp(end, transported)
    return transported, traj
