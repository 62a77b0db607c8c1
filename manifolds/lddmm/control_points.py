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
* ``"vertices"``: a subset of the template's vertices, farthest-point sampled until
  every vertex lies within ``spacing`` (default ``VERTEX_SPACING * sigma``) of one
  (:func:`vertex_control_points`), or given by their indices, the same for every
  shape in correspondence (``indices``; the study draws them once, on the atlas).
  The points sit where the shape is, as dense control points do, at a density set
  by the kernel rather than by the mesh: a ventricle of 1,009 vertices gets 143
  points at ``sigma = 10`` mm instead of 270 grid points, most of which a grid puts
  inside or outside the surface, where their fields nearly cancel on it
  (``docs/lddmm.md``, "Control points");
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
    "policy_spacing",
    "vertex_control_points",
    "vertices_at",
    "check_vertex_indices",
    "farthest_point_indices",
    "POLICIES",
    "VERTEX_SPACING",
    "MAX_CONTROL_POINTS",
]

POLICIES = ("dense", "grid", "finegrid", "vertices", "auto")
#: Default spacing of the ``"vertices"`` policy, in units of ``sigma`` (chosen by
#: measurement on the study's cohort, ``docs/evidence/developer_notes.md``).
VERTEX_SPACING = 0.7
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


def grid_spacing(policy, sigma: float, spacing: float | None = None) -> float | None:
    """Spacing of the grid a policy builds (``spacing`` when given, else ``sigma`` for
    ``"grid"`` and ``sigma / 2`` for ``"finegrid"``), or ``None`` for a policy that
    builds no grid."""
    if not isinstance(policy, str) or policy not in ("grid", "finegrid"):
        return None
    return policy_spacing(policy, sigma, spacing)


def policy_spacing(policy, sigma: float, spacing: float | None = None) -> float | None:
    """Spacing between control points under ``policy``: ``spacing`` when given, else the
    policy's default multiple of ``sigma`` (grid 1, finegrid 1/2, vertices
    :data:`VERTEX_SPACING`); ``None`` for the policies without one."""
    defaults = {"grid": 1.0, "finegrid": 0.5, "vertices": VERTEX_SPACING}
    if not isinstance(policy, str) or policy not in defaults:
        return None
    return float(spacing) if spacing is not None else defaults[policy] * float(sigma)


def farthest_point_indices(points: np.ndarray, spacing: float) -> np.ndarray:
    """Indices of a farthest-point sample of ``points`` at ``spacing``.

    Greedy: start at the point nearest the centroid (the lowest index on a tie),
    then repeatedly add the point farthest from those chosen, until every point
    lies within ``spacing`` of a chosen one. Each added point is at least
    ``spacing`` from all the earlier ones, so the sample is both a cover and a
    packing at ``spacing`` (a ``spacing``-net). Deterministic: the same points give
    the same sample.

    Parameters
    ----------
    points : array, shape ``(k, d)``
    spacing : float
        Positive, in the points' unit.

    Returns
    -------
    int array, shape ``(n,)``, sorted, ``1 <= n <= k``.
    """
    pts = np.asarray(points, dtype=float)

    def sq_dist(centre):
        diff = pts - centre
        return np.einsum("ij,ij->i", diff, diff)

    chosen = [int(np.argmin(sq_dist(pts.mean(axis=0))))]
    sq = sq_dist(pts[chosen[0]])
    limit = float(spacing) ** 2
    while True:
        i = int(np.argmax(sq))
        if sq[i] < limit:
            break
        chosen.append(i)
        np.minimum(sq, sq_dist(pts[i]), out=sq)
    return np.sort(np.asarray(chosen, dtype=np.intp))


def vertex_control_points(points: np.ndarray, spacing: float) -> np.ndarray:
    """Control points of the ``"vertices"`` policy: a farthest-point sample of ``points``.

    Parameters
    ----------
    points : array, shape ``(k, d)``
        The template's vertices.
    spacing : float
        Every vertex lies within ``spacing`` of a control point, and control
        points are at least ``spacing`` apart (:func:`farthest_point_indices`).

    Returns
    -------
    array, shape ``(n_cp, d)``: rows of ``points`` (a copy), in the vertices' order.
    """
    points = np.asarray(points, dtype=float)
    if not np.isfinite(spacing) or spacing <= 0:
        raise ManifoldError(f"control_point_spacing: expected a finite number > 0, got {spacing!r}")
    return np.ascontiguousarray(points[farthest_point_indices(points, spacing)])


def check_vertex_indices(indices, n_vertices: int, label: str = "") -> np.ndarray:
    """``indices`` as an int array; a :class:`ManifoldError` (prefixed by ``label``)
    if one of them is out of range for shapes of ``n_vertices`` vertices."""
    idx = np.asarray(indices, dtype=np.intp)
    if idx.size and idx.max() >= n_vertices:
        raise ManifoldError(
            f"{label}control_point_indices: vertex index {int(idx.max())} is out of range "
            f"for shapes of {n_vertices} vertices"
        )
    return idx


def vertices_at(template: np.ndarray, indices) -> np.ndarray:
    """Rows ``indices`` of ``template`` ``(k, d)``, a contiguous copy
    (:func:`check_vertex_indices` first)."""
    return np.ascontiguousarray(template[check_vertex_indices(indices, template.shape[0])])


def resolve_control_points(
    template: np.ndarray,
    policy,
    sigma: float,
    auto_threshold: int = AUTO_THRESHOLD,
    max_points: int = MAX_CONTROL_POINTS,
    spacing: float | None = None,
    indices=None,
) -> np.ndarray:
    """Control points for ``template`` under ``policy``.

    Parameters
    ----------
    template : array, shape ``(k, d)``
    policy : {"dense", "grid", "finegrid", "vertices", "auto"} or array of shape ``(n_cp, d)``
    sigma : float
        Kernel width; the default spacing of the policies is a multiple of it
        (:func:`policy_spacing`).
    auto_threshold : int
        Largest vertex count for which ``"auto"`` chooses ``"dense"``.
    max_points : int
        Budget of a grid (see the module docstring).
    spacing : float, optional
        Spacing of the ``"grid"``, ``"finegrid"`` and ``"vertices"`` policies, in the
        shapes' unit (default: :func:`policy_spacing`).
    indices : sequence of int, optional
        With ``"vertices"``: the vertices to use (instead of a sample of ``template``).

    Returns
    -------
    array, shape ``(n_cp, d)``; for ``"dense"`` the template itself (not a copy).
    """
    if isinstance(policy, str):
        if policy == "auto":
            policy = "dense" if template.shape[0] <= auto_threshold else "grid"
        if policy == "dense":
            return template
        if policy == "vertices":
            if indices is not None:
                return vertices_at(template, indices)
            return vertex_control_points(template, policy_spacing(policy, sigma, spacing))
        step = grid_spacing(policy, sigma, spacing)
        if step is not None:
            return grid_control_points(template, step, max_points)
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
