"""Control points of the LDDMM velocity fields (paper, Section 2.1).

A policy turns a template shape into the control points ``c`` that carry the
momenta:

* ``"dense"``: the template's own vertices (``n_cp = k``);
* ``"grid"``: a regular grid of spacing ``sigma`` centred on the template's
  bounding box (a 642-vertex ellipsoid with semi-axes 1, 0.7, 0.5 and
  ``sigma = 0.5`` gets 5 x 3 x 3 = 45 points);
* ``"auto"``: dense up to ``auto_threshold`` vertices, grid above;
* an array of shape ``(n_cp, d)``: the same user-given points for every template.
"""

from __future__ import annotations

import numpy as np

from ..errors import ManifoldError
from ..validation import check_array

__all__ = ["grid_control_points", "resolve_control_points", "POLICIES"]

POLICIES = ("dense", "grid", "auto")
AUTO_THRESHOLD = 1000


def grid_control_points(points: np.ndarray, spacing: float) -> np.ndarray:
    """Regular grid of step ``spacing`` covering the bounding box of ``points``.

    Along each axis the grid has ``floor(extent / spacing) + 1`` nodes centred
    on the box, so that it never extends beyond the box by more than half a step.

    Parameters
    ----------
    points : array, shape ``(k, d)``
    spacing : float

    Returns
    -------
    array, shape ``(n_cp, d)``
    """
    points = np.asarray(points, dtype=float)
    lo, hi = points.min(axis=0), points.max(axis=0)
    axes = []
    for a, b in zip(lo, hi):
        n = int(np.floor((b - a) / spacing + 1e-9)) + 1
        centre = 0.5 * (a + b)
        axes.append(centre + spacing * (np.arange(n) - 0.5 * (n - 1)))
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([m.ravel() for m in mesh], axis=1)


def resolve_control_points(
    template: np.ndarray,
    policy,
    sigma: float,
    auto_threshold: int = AUTO_THRESHOLD,
) -> np.ndarray:
    """Control points for ``template`` under ``policy``.

    Parameters
    ----------
    template : array, shape ``(k, d)``
    policy : {"dense", "grid", "auto"} or array of shape ``(n_cp, d)``
    sigma : float
        Kernel width, the grid spacing.
    auto_threshold : int
        Largest vertex count for which ``"auto"`` chooses ``"dense"``.

    Returns
    -------
    array, shape ``(n_cp, d)``; for ``"dense"`` the template itself (not a copy).
    """
    if isinstance(policy, str):
        if policy == "auto":
            policy = "dense" if template.shape[0] <= auto_threshold else "grid"
        if policy == "dense":
            return template
        if policy == "grid":
            return grid_control_points(template, sigma)
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
