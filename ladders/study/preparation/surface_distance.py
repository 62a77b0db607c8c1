"""Distances between two triangulated surfaces: Hausdorff and mean surface distance.

For meshes ``A`` and ``B`` the distance of every vertex of one to the other's
surface (closest point on a triangle, :func:`~ladders.study.surface_queries.closest_points`)
gives the two one-sided sets of distances. Their maximum over both sides is
the (vertex-sampled) Hausdorff distance; the mean of the two one-sided means is
the symmetric mean surface distance. Both are in the meshes' unit and do not
depend on either triangulation's vertex order.
"""

from __future__ import annotations

import numpy as np

from manifolds.data_terms.mesh_geometry import check_mesh

from ..surface_queries import closest_points

__all__ = ["surface_distances", "distances_to_surface"]


def distances_to_surface(points, vertices, faces) -> np.ndarray:
    """Distance of each point ``(n, 3)`` to the surface ``(vertices, faces)``, shape ``(n,)``."""
    return closest_points(points, vertices, faces)[1]


def surface_distances(vertices_a, faces_a, vertices_b, faces_b) -> dict:
    """Hausdorff and mean surface distances between two meshes.

    Returns
    -------
    dict
        ``hausdorff``, ``mean_surface_distance`` and the one-sided means
        ``mean_a_to_b``, ``mean_b_to_a`` (floats, in the meshes' unit).
    """
    va, fa = check_mesh(vertices_a, faces_a, "surface_distances: first mesh")
    vb, fb = check_mesh(vertices_b, faces_b, "surface_distances: second mesh")
    ab = distances_to_surface(va, vb, fb)
    ba = distances_to_surface(vb, va, fa)
    return {
        "hausdorff": float(max(ab.max(), ba.max())),
        "mean_surface_distance": float((ab.mean() + ba.mean()) / 2.0),
        "mean_a_to_b": float(ab.mean()),
        "mean_b_to_a": float(ba.mean()),
    }
