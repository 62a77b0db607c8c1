"""Distances between two triangulated surfaces: Hausdorff and mean surface distance.

For meshes ``A`` and ``B`` the distance of every vertex of one to the other's
surface (closest point on a triangle, :func:`~ladders.study.surface_queries.closest_points`)
gives the two one-sided sets of distances. Their maximum over both sides is
the (vertex-sampled) Hausdorff distance; the mean of the two one-sided means is
the symmetric mean surface distance. Both are in the meshes' unit and do not
depend on either triangulation's vertex order.

With ``skip_beyond_rim`` the first mesh is an open template (an atlas cut at its
base) and the second a mesh that may go on beyond it (the flat lid a label image
gives a ventricle at its valve plane, a wall cut higher): the second mesh's vertices
whose closest point on the first lies on the first's rim (its boundary edges) are
left out of the distances, as pairs at a boundary are left out of ICP (Turk and
Levoy, 1994), and their fraction is returned. A vertex the template does not model
then does not count as a distance the template failed to close.
"""

from __future__ import annotations

import numpy as np

from manifolds.data_terms.mesh_geometry import check_mesh

from ..surface_queries import closest_points
from ..volume import boundary_edges

__all__ = ["surface_distances", "distances_to_surface", "on_rim"]


def distances_to_surface(points, vertices, faces) -> np.ndarray:
    """Distance of each point ``(n, 3)`` to the surface ``(vertices, faces)``, shape ``(n,)``."""
    return closest_points(points, vertices, faces)[1]


def on_rim(closest: np.ndarray, vertices: np.ndarray, faces: np.ndarray,
           triangles: np.ndarray | None = None, edges: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
    """Which of the ``closest`` points (on the surface) lie on its boundary edges.

    ``triangles`` (optional, the triangle each point lies on, as
    :func:`~ladders.study.surface_queries.closest_points` returns it): only the points on
    a triangle with a vertex on the boundary are tested. ``edges`` (optional): the
    surface's :func:`~ladders.study.volume.boundary_edges`, when already known."""
    edges = boundary_edges(faces) if edges is None else edges
    out = np.zeros(len(closest), dtype=bool)
    if len(edges) == 0 or len(closest) == 0:
        return out
    test = np.arange(len(closest))
    if triangles is not None:
        rim = np.zeros(len(vertices), dtype=bool)
        rim[edges.ravel()] = True
        test = np.flatnonzero(rim[np.asarray(faces)[triangles]].any(axis=1))
        if len(test) == 0:
            return out
    a, b = vertices[edges[:, 0]], vertices[edges[:, 1]]
    ab = b - a
    points = closest[test]
    t = np.einsum("ned,ed->ne", points[:, None, :] - a[None], ab) / np.einsum("ed,ed->e", ab, ab)
    foot = a[None] + np.clip(t, 0.0, 1.0)[..., None] * ab[None]
    gap = np.linalg.norm(points[:, None, :] - foot, axis=2).min(axis=1)
    scale = np.ptp(vertices, axis=0).max()
    out[test] = gap <= 1e-9 * scale
    return out


def surface_distances(
    vertices_a, faces_a, vertices_b, faces_b, skip_beyond_rim: bool = False
) -> dict:
    """Hausdorff and mean surface distances between two meshes.

    Parameters
    ----------
    vertices_a, faces_a, vertices_b, faces_b : arrays
        The two meshes.
    skip_beyond_rim : bool, default False
        Leave out of the distances from the second mesh to the first the vertices
        whose closest point on the first lies on its rim (see the module).

    Returns
    -------
    dict
        ``hausdorff``, ``mean_surface_distance`` and the one-sided means
        ``mean_a_to_b``, ``mean_b_to_a`` (floats, in the meshes' unit); with
        ``skip_beyond_rim``, ``beyond_rim_fraction``: the fraction of the second
        mesh's vertices left out.
    """
    va, fa = check_mesh(vertices_a, faces_a, "surface_distances: first mesh")
    vb, fb = check_mesh(vertices_b, faces_b, "surface_distances: second mesh")
    ab = distances_to_surface(va, vb, fb)
    closest, ba, _ = closest_points(vb, va, fa)
    out = {}
    if skip_beyond_rim:
        used = np.unique(fb)  # vertices of the second mesh's triangles
        beyond = np.zeros(len(vb), dtype=bool)
        beyond[used] = on_rim(closest[used], np.asarray(va, dtype=np.float64), fa)
        kept = np.zeros(len(vb), dtype=bool)
        kept[used] = ~beyond[used]
        out["beyond_rim_fraction"] = float(beyond[used].mean())
        ba = ba[kept] if kept.any() else ab[:0]
    mean_ba = float(ba.mean()) if len(ba) else float(ab.mean())
    return {
        "hausdorff": float(max(ab.max(), ba.max() if len(ba) else 0.0)),
        "mean_surface_distance": float((ab.mean() + mean_ba) / 2.0),
        "mean_a_to_b": float(ab.mean()),
        "mean_b_to_a": mean_ba,
        **out,
    }
