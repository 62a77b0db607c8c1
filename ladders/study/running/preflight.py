"""Checks of a study's inputs that run before any registration (a kernel width in another unit).

They belong to the study, not to its command line: :func:`ladders.study.run` and
``symladders study`` both call them.
"""

from __future__ import annotations

import numpy as np
from scipy import spatial

from manifolds.errors import ManifoldError
from manifolds.lddmm.control_points import check_grid_budget, grid_spacing

__all__ = ["check_sigma"]


def check_sigma(points, settings) -> None:
    """Before a study starts: refuse a ``--sigma`` in another unit than the meshes.

    Two tests, both before anything is allocated:

    * the kernel width against the atlas: below a tenth of its median vertex spacing
      (nearest-neighbour distance) the kernel moves every vertex alone, above a hundred
      times its extent it moves the whole shape rigidly; either is the mark of a unit
      slip (``--sigma 0.01`` for meshes in mm, ``--sigma 20`` for meshes in m);
    * for the policies that build a grid (``"grid"``, ``"finegrid"``), the grid's
      size against the budget ``max_control_points``.

    Parameters
    ----------
    points : array, shape (k, 3)
        The atlas.
    settings : manifolds.lddmm.RegistrationSettings
        The study's registration settings (kernel width, policy, budget).

    Raises :class:`~manifolds.errors.ManifoldError` naming sigma, the atlas's vertex
    spacing and extent (or the grid's count).
    """
    points = np.asarray(points, dtype=float)
    extent = float(np.ptp(points, axis=0).max())
    spacing_nn = float(np.median(spatial.cKDTree(points).query(points, k=2)[0][:, 1]))
    sigma = settings.sigma
    if sigma < 0.1 * spacing_nn or sigma > 100.0 * extent:
        side = "below a tenth of" if sigma < 0.1 * spacing_nn else "above 100 times"
        raise ManifoldError(
            f"sigma: a kernel width of {sigma:g} is {side} the atlas's "
            f"{'vertex spacing' if side.startswith('below') else 'extent'} (median "
            f"vertex spacing {spacing_nn:.3g}, extent {extent:.3g}, in the meshes' unit): is "
            "it given in another unit than the meshes? Use a sigma between a few vertex "
            "spacings and the extent (docs/lddmm.md, 'Choosing sigma')."
        )
    grid = grid_spacing(settings.control_points_policy, sigma, settings.control_point_spacing)
    if grid is not None:
        check_grid_budget(points, grid, settings.max_control_points)
