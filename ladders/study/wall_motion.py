"""Normal wall motion: how far each vertex of one surface moves along its normal to reach another.

The motion a pair of surfaces (end-diastole, end-systole) shows is the motion
across the wall: a surface carries no material landmark, so how the wall slid
along itself is not in it. For each vertex ``x_i`` of the first mesh, with its
outward unit normal ``n_i``, :func:`normal_wall_motion` casts the line
``x_i + t n_i`` and keeps the intersection with the second surface nearest to
``x_i`` (smallest ``|t|``) whose triangle faces the same way (outward normals in
the same half-space: the near wall, not the opposite one), within
``max_distance``. ``t`` is the signed normal wall motion (negative inward: a
contracting ventricle has ``t < 0``), the intersection the vertex's normal
projection onto the second surface. A vertex whose line meets no such triangle
(e.g. past the rim of a surface open at its base) takes the closest point of the
second surface instead, and is marked as such (``hit`` False).

This is the centreline measure of regional wall motion of echocardiography and
cine MRI, on a surface: ``symladders correspond`` uses the projection as the
end-systolic correspondence of a subject (each corresponded ED vertex moved
along its normal to the ES surface), and the group analysis tests ``t`` per
atlas vertex (``wall_motion``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from manifolds.data_terms.mesh_geometry import check_mesh

from .surface_queries import closest_points, intersect_lines_triangles, line_hits
from .volume import enclosed_volume

__all__ = ["NormalProjection", "normal_wall_motion", "outward_vertex_normals"]


def outward_vertex_normals(vertices, faces) -> np.ndarray:
    """Unit vertex normals ``(k, 3)``, oriented outward (the enclosed volume positive)."""
    normals = np.asarray(trimesh.Trimesh(vertices, faces, process=False).vertex_normals, float)
    return normals if enclosed_volume(vertices, faces) >= 0 else -normals


def _outward_face_normals(vertices, faces) -> np.ndarray:
    normals = np.asarray(trimesh.Trimesh(vertices, faces, process=False).face_normals, float)
    return normals if enclosed_volume(vertices, faces) >= 0 else -normals


@dataclass(frozen=True)
class NormalProjection:
    """The normal projection of a mesh's vertices onto another surface.

    Attributes
    ----------
    points : ndarray, shape (k, 3)
        Each vertex moved along its normal onto the other surface (or to its closest
        point there where ``hit`` is False).
    distance : ndarray, shape (k,)
        Signed motion along the outward normal, ``(points - vertices) . normals``.
    hit : ndarray of bool, shape (k,)
        Whether the normal line met the surface within ``max_distance``.
    normals : ndarray, shape (k, 3)
        The outward unit normals used.
    """

    points: np.ndarray
    distance: np.ndarray
    hit: np.ndarray
    normals: np.ndarray

    @property
    def hit_fraction(self) -> float:
        """Fraction of vertices whose normal line met the surface."""
        return float(self.hit.mean()) if self.hit.size else 1.0


def _candidates(origins, directions, centres, reach, max_distance, budget=200_000):
    """``(line, triangle)`` pairs holding every triangle a line meets within ``max_distance``.

    ``reach`` bounds the distance from a triangle's centre to any of its points (its
    largest centre-corner distance, with a margin for the barycentric tolerance), so a
    triangle met at ``t`` has its centre within ``reach`` of ``origin + t direction``.
    That point is within half a spacing of one of the points sampled along the segment
    ``|t| <= max_distance``: the triangle's centre lies in the ball of radius
    ``spacing / 2 + reach`` around that sample. The pairs are those balls' contents (a
    k-d tree of the samples against one of the centres), without repetition, sorted by
    line then triangle. Exact: no triangle met within the segment is left out.
    """
    from scipy.spatial import cKDTree

    n_samples = min(int(np.ceil(max_distance / reach)) + 1, 64)  # spacing ~ 2 reach
    offsets = np.linspace(-max_distance, max_distance, n_samples)
    radius = 0.5 * (offsets[1] - offsets[0]) + reach  # n_samples >= 2 as max_distance > 0
    tree = cKDTree(centres)
    n_tri = len(centres)
    per_chunk = max(1, budget // n_samples)
    codes = []
    for s in range(0, len(origins), per_chunk):
        o, d = origins[s : s + per_chunk], directions[s : s + per_chunk]
        samples = (o[:, None, :] + offsets[None, :, None] * d[:, None, :]).reshape(-1, 3)
        pairs = cKDTree(samples).sparse_distance_matrix(tree, radius, output_type="ndarray")
        codes.append((pairs["i"] // n_samples + s) * n_tri + pairs["j"])
    codes = np.unique(np.concatenate(codes)) if codes else np.zeros(0, np.int64)
    return codes // n_tri, codes % n_tri


#: A triangle whose bounding radius exceeds this many times the median is "large" (the flat
#: lid a label image leaves at the base is a fan of such triangles).
_LARGE = 4.0


def _pairs(origins, directions, centres, radius, margin, max_distance):
    """Candidate ``(line, triangle)`` pairs, sorted by line then triangle (exact).

    The few large triangles of a mesh would make every ball of :func:`_candidates` as
    large as theirs: they are paired with every line instead, and the pruning runs on
    the others with their own reach. A mesh with more than a tenth of its triangles
    large is pruned as one class.
    """
    large = radius > _LARGE * float(np.median(radius)) if len(radius) else radius > 0
    if not large.any() or large.mean() > 0.1:
        reach = float(radius.max(initial=0.0)) * (1.0 + 1e-6) + margin
        return _candidates(origins, directions, centres, reach, max_distance)
    small = np.flatnonzero(~large)
    reach = float(radius[small].max()) * (1.0 + 1e-6) + margin
    lines, tris = _candidates(origins, directions, centres[small], reach, max_distance)
    big = np.flatnonzero(large)
    lines = np.concatenate([lines, np.repeat(np.arange(len(origins)), len(big))])
    tris = np.concatenate([small[tris], np.tile(big, len(origins))])
    order = np.lexsort((tris, lines))
    return lines[order], tris[order]


def _line_hits(origins, directions, tv, tf, max_distance, chunk=200_000):
    """Intersections of the lines ``origins + t directions`` with the triangles (Moller-Trumbore).

    Candidate triangles of a line are those whose bounding sphere may meet the line
    within ``|t| <= max_distance`` (:func:`_candidates`; intersections up to a
    triangle's size beyond it may be returned too). Returns the line index, ``t``,
    the point and the triangle of every intersection, sorted by line then triangle.
    """
    a, b, c = tv[tf[:, 0]], tv[tf[:, 1]], tv[tf[:, 2]]
    centres = (a + b + c) / 3.0
    radius = np.sqrt(np.max([((p - centres) ** 2).sum(1) for p in (a, b, c)], axis=0))
    margin = 1e-12 * float(np.abs(tv).max(initial=1.0))
    lines, tris = _pairs(origins, directions, centres, radius, margin, max_distance)
    out = []
    for s in range(0, len(lines), chunk):
        i, j = lines[s : s + chunk], tris[s : s + chunk]
        o, d = origins[i], directions[i]
        t, inside = intersect_lines_triangles(o, d, a[j], b[j], c[j])
        out.append((i[inside], t[inside], o[inside] + t[inside, None] * d[inside], j[inside]))
    if not out:
        return np.zeros(0, int), np.zeros(0), np.zeros((0, 3)), np.zeros(0, int)
    return tuple(np.concatenate(parts) for parts in zip(*out))


def normal_wall_motion(
    vertices, faces, target_vertices, target_faces, *, max_distance: float | None = None,
    max_detour: float | None = None,
) -> NormalProjection:  # fmt: skip
    """Move every vertex of ``(vertices, faces)`` along its normal onto the target (see module).

    Parameters
    ----------
    vertices, faces : arrays ``(k, 3)``, ``(f, 3)``
        The moving surface (e.g. a corresponded end-diastole); its normals are used.
    target_vertices, target_faces : arrays ``(m, 3)``, ``(g, 3)``
        The surface reached (e.g. end-systole), any triangulation, same frame and unit.
    max_distance : float, optional
        Ignore intersections farther than this (default: a fifth of the target's
        bounding-box diagonal).
    max_detour : float, optional
        An intersection farther from the vertex than the closest point of the target by
        more than this is taken for another part of the surface (a line through a
        narrow cavity near an apex, past a staircase of thick slices): the vertex takes
        the closest point instead (``hit`` False). None (default): no such test.

    Returns
    -------
    NormalProjection
    """
    v, f = check_mesh(vertices, faces, "normal_wall_motion: mesh")
    tv, tf = check_mesh(target_vertices, target_faces, "normal_wall_motion: target")
    if max_distance is None:
        max_distance = 0.2 * float(np.linalg.norm(tv.max(0) - tv.min(0)))
    elif not (np.isfinite(max_distance) and max_distance > 0):
        raise ValueError(f"normal_wall_motion: max_distance: expected > 0, got {max_distance}")
    if max_detour is not None and not (np.isfinite(max_detour) and max_detour >= 0):
        raise ValueError(f"normal_wall_motion: max_detour: expected >= 0, got {max_detour}")
    normals = outward_vertex_normals(v, f)
    target_normals = _outward_face_normals(tv, tf)

    def facing_hits(found, lines):
        vertex, t, loc, tri = found
        vertex = lines[vertex]
        keep = (np.einsum("ij,ij->i", target_normals[tri], normals[vertex]) > 0) & (
            np.abs(t) <= max_distance
        )
        return vertex[keep], loc[keep], np.abs(t[keep])

    every = np.arange(len(v))
    vertex, loc, dist = facing_hits(line_hits(v, normals, tv, tf, max_distance), every)
    missed = np.setdiff1d(every, vertex)
    if len(missed):  # e.g. a line through an edge or a vertex: the tolerant test of this module
        found = _line_hits(v[missed], normals[missed], tv, tf, max_distance)
        more = facing_hits(found, missed)
        vertex, loc, dist = (np.concatenate(pair) for pair in zip((vertex, loc, dist), more))
    order = np.lexsort((dist, vertex))  # by vertex, the nearest hit first (stable on ties)
    nearest = order[np.unique(vertex[order], return_index=True)[1]]
    hit = np.zeros(len(v), dtype=bool)
    points = np.zeros((len(v), 3))
    hit[vertex[nearest]] = True
    points[vertex[nearest]] = loc[nearest]
    if max_detour is not None:
        closest, gap = closest_points(v, tv, tf)[:2]
        hit &= np.linalg.norm(points - v, axis=1) <= gap + max_detour
        points[~hit] = closest[~hit]
    elif not hit.all():
        points[~hit] = closest_points(v[~hit], tv, tf)[0]
    distance = np.einsum("ij,ij->i", points - v, normals)
    return NormalProjection(points, distance, hit, normals)
