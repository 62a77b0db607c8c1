"""Wall thickness: each endocardial vertex paired with its closest point on the epicardium.

The endocardium is the mesh in the atlas's correspondence (a corresponded ED mesh, or
a tracked frame); the epicardium is any triangulation of the outer surface of the
myocardium at the same instant (:func:`~ladders.study.imaging.extract_epicardium`, or
the epicardium followed through the cycle by ``symladders track``). The thickness at
endocardial vertex ``x_i`` is its distance to the epicardium,
``T_i = min over y of the epicardium of |x_i - y|``, and ``y_i``, the closest point, is
the epicardial point paired with it: the endocardial mesh's triangulation with its vertices moved to the ``y_i`` is an epicardium in the
atlas's correspondence. Where the wall's two surfaces are parallel this is the distance
along the normal of either; it is defined at every vertex (the apex, the base's rim)
and does not depend on the endocardial normal, which a mesh of a label image has
noisy (a ray along it would lengthen the thickness by ``T (1 / cos(e) - 1)`` for a
normal ``e`` off). It is taken at every instant from that instant's surfaces (an
Eulerian pairing): thickening needs no material point of the epicardium, which label
images do not show.

A vertex whose closest point lies on the epicardium's rim (its boundary at the base,
where the epicardium was cut lower than the vertex) gets the distance to that rim,
longer than the wall: it is flagged ``on_rim``.

:func:`thickening` gives the absolute thickening ``T(t) - T(0)`` (mm) and the relative
one ``T(t) / T(0) - 1``, the radial strain of :mod:`.strain`'s definitions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manifolds.data_terms.mesh_geometry import check_mesh

from ..preparation.surface_distance import on_rim
from ..surface_queries import closest_points

__all__ = ["WallThickness", "wall_thickness", "thickening"]


@dataclass(frozen=True)
class WallThickness:
    """The wall thickness at every endocardial vertex (:func:`wall_thickness`).

    Attributes
    ----------
    thickness : ndarray, shape (k,)
        Distance to the epicardium, in the meshes' unit divided by ``scale`` (mm).
    points : ndarray, shape (k, 3)
        The paired epicardial points (the closest points), in the meshes' frame.
    on_rim : ndarray of bool, shape (k,)
        The closest point lies on the epicardium's boundary (see the module).
    """

    thickness: np.ndarray
    points: np.ndarray
    on_rim: np.ndarray


def wall_thickness(endocardium, epicardium_vertices, epicardium_faces, scale: float = 1.0
                   ) -> WallThickness:  # fmt: skip
    """The wall thickness at every vertex of the endocardium (see the module).

    Parameters
    ----------
    endocardium : array, shape (k, 3)
        The endocardial vertices.
    epicardium_vertices, epicardium_faces : arrays ``(m, 3)``, ``(g, 3)``
        The epicardium at the same instant, in the same frame (any triangulation).
    scale : float, default 1.0
        The meshes' frame's scale relative to mm (e.g. a correspondence's similarity
        transform, which scales by ``s``): thicknesses are divided by it.

    Returns
    -------
    WallThickness

    Raises
    ------
    ValueError
        Misshaped or non-finite points, a bad epicardium, a scale not > 0.
    """
    x = np.asarray(endocardium, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 3 or len(x) == 0 or not np.isfinite(x).all():
        raise ValueError(f"endocardium: expected finite points (k, 3), got shape {x.shape}")
    v, f = check_mesh(epicardium_vertices, epicardium_faces, "wall_thickness: epicardium")
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"scale: expected a number > 0, got {scale!r}")
    v = np.asarray(v, dtype=np.float64)
    points, distance, triangle = closest_points(x, v, f)
    rim = on_rim(points, v, f, triangle)
    return WallThickness(distance / float(scale), points, rim)


def thickening(thickness) -> tuple[np.ndarray, np.ndarray]:
    """Absolute and relative thickening of thickness curves, from their first frame.

    Parameters
    ----------
    thickness : array, shape (..., n_frames, k)
        Wall thickness at every frame (frame 0 the reference, end-diastole).

    Returns
    -------
    absolute : ndarray, shape (..., n_frames, k)
        ``T(t) - T(0)`` (the thickness's unit).
    relative : ndarray, shape (..., n_frames, k)
        ``T(t) / T(0) - 1`` (dimensionless; the radial strain).

    Raises
    ------
    ValueError
        Fewer than two axes, or a thickness at frame 0 that is not > 0 (naming the
        first such vertex).
    """
    t = np.asarray(thickness, dtype=np.float64)
    if t.ndim < 2 or t.shape[-2] < 1:
        raise ValueError(f"thickness: expected shape (..., n_frames, k), got {t.shape}")
    ref = t[..., :1, :]
    bad = ~(ref > 0)
    if bad.any():
        vertex = int(np.argwhere(bad)[0][-1])
        raise ValueError(
            f"thickness: {int(bad.sum())} vertex(es) with a thickness at frame 0 that is not "
            f"> 0 (first: vertex {vertex}): the epicardium touches or crosses the endocardium"
        )
    return t - ref, t / ref - 1.0
