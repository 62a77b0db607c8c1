"""Nearest points and line intersections on a triangle surface, through libigl's AABB tree.

The preparation and the tracking of meshes ask the same two questions of a surface
thousands of times: the closest point of the surface to each of many points (ICP
steps, cropping, surface distances), and where the normal lines of a mesh meet it
(the normal wall motion). Both are answered by libigl (Jacobson, Panozzo et al.),
the field's standard geometry-processing library, whose axis-aligned bounding-box
tree answers a batch of queries in compiled code: on a cine frame's surface it is
tens of times faster than a tree rebuilt in Python for every moved mesh
(``benchmarks/bench_surface_queries.py``).

:func:`closest_points` is exact (the closest point on a triangle, degenerate
triangles included). :func:`line_hits` returns every intersection of each line
with the surface within ``max_distance`` of its origin: the tree proposes the
triangles a line meets, and each intersection is recomputed in double precision
(Moller-Trumbore), so that it does not depend on the triangles' orientation. A
line passing exactly through an edge or a vertex can be missed by the tree's
floating-point ray-triangle test, so :mod:`ladders.study.wall_motion` re-examines
the lines left without an intersection it can use (one facing the vertex's way) by its
exhaustive candidate search, which meets edges and corners with a tolerance.
"""

from __future__ import annotations

import igl
import numpy as np

__all__ = ["closest_points", "line_hits", "intersect_lines_triangles"]


def _arrays(vertices, faces):
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
        raise ValueError(
            f"surface: expected vertices (m, 3) and faces (g, 3) with g >= 1, got "
            f"{v.shape} and {f.shape}"
        )
    return v, f


def closest_points(points, vertices, faces) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The closest point of the surface ``(vertices, faces)`` to each point.

    Parameters
    ----------
    points : array_like, shape (n, 3)
    vertices, faces : arrays ``(m, 3)`` and ``(g, 3)``
        The surface (any triangulation; unreferenced vertices are ignored).

    Returns
    -------
    closest : ndarray, shape (n, 3)
    distance : ndarray, shape (n,)
        Euclidean distance of each point to the surface.
    triangle : ndarray of int, shape (n,)
        The triangle the closest point lies on.
    """
    p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    v, f = _arrays(vertices, faces)
    if len(p) == 0:
        return np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=np.int64)
    squared, triangle, closest = igl.point_mesh_squared_distance(p, v, f)
    return np.asarray(closest), np.sqrt(np.maximum(squared, 0.0)), np.asarray(triangle, np.int64)


def line_hits(origins, directions, vertices, faces, max_distance: float):
    """Intersections of the lines ``origins + t directions`` with the surface, ``|t| <= max_distance``.

    Parameters
    ----------
    origins, directions : arrays ``(n, 3)``
        The lines; ``t`` is in units of each direction's length.
    vertices, faces : arrays ``(m, 3)`` and ``(g, 3)``
    max_distance : float
        Only the intersections with ``|t| <= max_distance`` are returned.

    Returns
    -------
    line : ndarray of int, shape (h,)
    t : ndarray, shape (h,)
    point : ndarray, shape (h, 3)
    triangle : ndarray of int, shape (h,)
        One row per intersection, sorted by line then ``t``.
    """
    o = np.ascontiguousarray(origins, dtype=np.float64).reshape(-1, 3)
    d = np.ascontiguousarray(directions, dtype=np.float64).reshape(-1, 3)
    v, f = _arrays(vertices, faces)
    tree = igl.AABB()
    tree.init(v, f)
    start = np.ascontiguousarray(o - max_distance * d)
    found = tree.intersect_ray(v, f, start, d)
    pairs = [(i, face) for i, hits in enumerate(found) for face, s, _, _ in hits
             if s <= 2.0 * max_distance * (1.0 + 1e-9)]  # fmt: skip
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    line, tri = pairs[:, 0], pairs[:, 1]
    t, inside = intersect_lines_triangles(
        o[line], d[line], v[f[tri, 0]], v[f[tri, 1]], v[f[tri, 2]]
    )
    keep = inside & (np.abs(t) <= max_distance)
    line, t, tri = line[keep], t[keep], tri[keep]
    order = np.lexsort((t, line))
    line, t, tri = line[order], t[order], tri[order]
    return line, t, o[line] + t[:, None] * d[line], tri


def intersect_lines_triangles(o, d, a, b, c, eps: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Intersections of lines with triangles, row by row (Moller-Trumbore, double precision).

    Parameters
    ----------
    o, d : arrays ``(n, 3)``
        The lines ``o + t d``.
    a, b, c : arrays ``(n, 3)``
        The triangles' corners.
    eps : float
        Tolerance on the barycentric coordinates (edges and corners are met).

    Returns
    -------
    t : ndarray, shape (n,)
        The parameter of the intersection with the triangle's plane (0 where parallel).
    inside : ndarray of bool, shape (n,)
        Whether it lies in the triangle.
    """
    e1, e2 = b - a, c - a
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-12 * np.einsum("ij,ij->i", e1, e1)
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = o - a
    u = np.einsum("ij,ij->i", s, p) * inv
    q = np.cross(s, e1)
    w = np.einsum("ij,ij->i", d, q) * inv
    t = np.einsum("ij,ij->i", e2, q) * inv
    return t, ok & (u >= -eps) & (w >= -eps) & (u + w <= 1 + eps)
