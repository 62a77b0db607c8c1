"""Schild's ladder: parallel transport by geodesic parallelograms."""

from __future__ import annotations

from .rungs import run_ladder

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
    return run_ladder(
        space, base, end, tangent, _schild_rung, n_rungs, scaling_exponent, return_trajectory, False
    )


def _schild_rung(space, x, x_next, half, tip):
    """Geodesic parallelogram: ``m = midpoint(tip, x_next)``, ``w = Log_{x_next}(s_m(x))``."""
    pivot = space.midpoint(tip, x_next)
    reflected = space.symmetry(pivot, x)
    return pivot, reflected, space.log(x_next, reflected)
