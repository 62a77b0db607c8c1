"""Control points of the LDDMM velocity fields (paper, Section 2.1).

A policy turns a template shape into the control points ``c`` that carry the
momenta:

* ``"dense"``: the template's own vertices (``n_cp = k``). This is the one meaning of
  "dense" in the package: control points that are the template's vertices, which
  :func:`is_dense` tells (the registration and
  :meth:`~manifolds.lddmm.LDDMMLandmarks.shoot` then carry the template as the
  control points themselves);
* ``"grid"``: a regular grid of spacing ``sigma`` centred on the template's
  bounding box (a 642-vertex ellipsoid with semi-axes 1, 0.7, 0.5 and
  ``sigma = 0.5`` gets 5 x 3 x 3 = 45 points);
* ``"finegrid"``: the same with spacing ``sigma / 2`` (about 8 times as many points);
* ``"auto"``: dense up to ``auto_threshold`` vertices, grid above;
* an array of shape ``(n_cp, d)``: the same user-given points for every template.

A grid has a budget, ``MAX_CONTROL_POINTS = 20000`` points by default: the
cost of a registration grows like ``n_cp^2`` (kernel sums), and a grid beyond
that size almost always comes from a ``sigma`` given in the wrong unit (e.g.
``sigma = 0.01`` for meshes in millimetres). The count is computed from the
bounding box before anything is allocated, and a clear error names ``sigma``,
the shape's extent and the count. The budget is a parameter
(``max_points`` here, ``max_control_points`` of :class:`~manifolds.lddmm.LDDMMLandmarks`).
"""

from __future__ import annotations

import numpy as np

from ..errors import ManifoldError
from ..validation import check_array

__all__ = [
    "is_dense",
    "grid_control_points",
    "grid_size",
    "check_grid_budget",
    "resolve_control_points",
    "grid_spacing",
    "POLICIES",
    "MAX_CONTROL_POINTS",
]

POLICIES = ("dense", "grid", "finegrid", "auto")
AUTO_THRESHOLD = 1000
MAX_CONTROL_POINTS = 20_000


def is_dense(template: np.ndarray, control_points: np.ndarray) -> bool:
    """Whether the control points are the template's vertices themselves (the ``"dense"`` policy)."""
    return control_points is template or (
        control_points.shape == template.shape and np.array_equal(control_points, template)
    )


def grid_size(points: np.ndarray, spacing: float) -> tuple[np.ndarray, float]:
    """Nodes per axis ``floor(extent / spacing) + 1`` and their product, as floats.

    Computed in floating point so that a tiny ``spacing`` cannot overflow.

    Parameters
    ----------
    points : array, shape ``(k, d)``
    spacing : float

    Returns
    -------
    per_axis : array, shape ``(d,)``
    total : float
    """
    extent = np.ptp(np.asarray(points, dtype=float), axis=0)
    per_axis = np.floor(extent / spacing + 1e-9) + 1.0
    return per_axis, float(np.prod(per_axis))


def check_grid_budget(points: np.ndarray, spacing: float, max_points: int) -> None:
    """Raise a :class:`ManifoldError` if the grid of ``spacing`` over ``points`` is too big."""
    per_axis, total = grid_size(points, spacing)
    if total > max_points:
        extent = np.ptp(np.asarray(points, dtype=float), axis=0)
        raise ManifoldError(
            f"sigma: a grid of control points of spacing sigma = {spacing:g} over the "
            f"shape's extent {' x '.join(f'{e:.4g}' for e in extent)} would have "
            f"{total:.3g} points ({' x '.join(f'{n:.0f}' for n in per_axis)}), above the "
            f"budget of {max_points} (max_control_points). sigma is in the shapes' units: "
            f"is it given in the wrong unit (e.g. m or cm for meshes in mm)? Use a sigma "
            f"comparable to the extent, or raise max_control_points."
        )


def grid_control_points(
    points: np.ndarray, spacing: float, max_points: int = MAX_CONTROL_POINTS
) -> np.ndarray:
    """Regular grid of step ``spacing`` covering the bounding box of ``points``.

    Along each axis the grid has ``floor(extent / spacing) + 1`` nodes centred
    on the box, so that it never extends beyond the box by more than half a step.

    Parameters
    ----------
    points : array, shape ``(k, d)``
    spacing : float
    max_points : int, default ``MAX_CONTROL_POINTS``
        Budget: raise before allocating if the grid would be larger.

    Returns
    -------
    array, shape ``(n_cp, d)``
    """
    points = np.asarray(points, dtype=float)
    check_grid_budget(points, spacing, max_points)
    lo, hi = points.min(axis=0), points.max(axis=0)
    axes = []
    for a, b in zip(lo, hi):
        n = int(np.floor((b - a) / spacing + 1e-9)) + 1
        centre = 0.5 * (a + b)
        axes.append(centre + spacing * (np.arange(n) - 0.5 * (n - 1)))
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([m.ravel() for m in mesh], axis=1)


def grid_spacing(policy, sigma: float) -> float | None:
    """Spacing of the grid a policy builds (``sigma`` for ``"grid"``, ``sigma / 2`` for
    ``"finegrid"``), or ``None`` for a policy that builds no grid."""
    return {"grid": sigma, "finegrid": 0.5 * sigma}.get(policy) if isinstance(policy, str) else None


def resolve_control_points(
    template: np.ndarray,
    policy,
    sigma: float,
    auto_threshold: int = AUTO_THRESHOLD,
    max_points: int = MAX_CONTROL_POINTS,
) -> np.ndarray:
    """Control points for ``template`` under ``policy``.

    Parameters
    ----------
    template : array, shape ``(k, d)``
    policy : {"dense", "grid", "finegrid", "auto"} or array of shape ``(n_cp, d)``
    sigma : float
        Kernel width, the grid spacing (half of it for ``"finegrid"``).
    auto_threshold : int
        Largest vertex count for which ``"auto"`` chooses ``"dense"``.
    max_points : int
        Budget of a grid (see the module docstring).

    Returns
    -------
    array, shape ``(n_cp, d)``; for ``"dense"`` the template itself (not a copy).
    """
    if isinstance(policy, str):
        if policy == "auto":
            policy = "dense" if template.shape[0] <= auto_threshold else "grid"
        if policy == "dense":
            return template
        spacing = grid_spacing(policy, sigma)
        if spacing is not None:
            return grid_control_points(template, spacing, max_points)
        raise ManifoldError(
            f"control_points: unknown policy {policy!r}; use one of {POLICIES} or an array"
        )
    cp = check_array(policy, (template.shape[1],), "control_points")
    if cp.ndim != 2 or cp.shape[0] == 0:
        raise ManifoldError(
            f"control_points: expected an array of shape (n_cp, {template.shape[1]}), "
            f"got {cp.shape}"
        )
    return cp
