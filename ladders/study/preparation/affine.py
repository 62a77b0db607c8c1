"""Affine pre-alignment of a template onto a surface: symmetric affine ICP.

A subject's shape differs from the atlas's by a large, nearly affine part
(size, eccentricity, for the heart's end-systole a shortening and a radial
contraction) and a smaller non-affine part. A deformation that only minimises
its RKHS norm does not reproduce the affine part's uniform stretch along the
surface: it slides vertices tangentially, which no surface data term sees. Fitting
the affine part first and registering the affinely moved template removes most
of that sliding (on the synthetic cohort the vertex error to the generating
correspondence falls from 4-7 mm to about 1.2 mm at end-systole).

:func:`affine_icp` alternates closest points in both directions with a
least-squares affine fit: template vertices are paired with their closest points
on the target surface, and target vertices with their closest points on the
moved template's triangles, carried back to the template by barycentric
coordinates (which prevents a collapse onto part of the surface). Pairing
samples (vertices and triangle centres) by k-d trees instead is faster but was
measured to give a worse affine start (end-systole error 2.4-2.8 mm instead of
1.2-1.4 mm).
"""

from __future__ import annotations

import numpy as np
import trimesh

from manifolds.data_terms.mesh_geometry import check_mesh
from manifolds.validation import check_int

from ..surface_queries import closest_points

__all__ = ["affine_icp", "apply_affine"]


def apply_affine(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``points @ A^T + b`` for the 4 x 4 matrix ``[[A, b], [0, 1]]``; shape ``(n, 3)``."""
    return np.asarray(points, dtype=float) @ matrix[:3, :3].T + matrix[:3, 3]


def _fit(source_h, target_pts):
    """The affine matrix ``(4, 4)`` of the least-squares fit ``source_h -> target_pts``.

    Pairs with a non-finite coordinate (a point carried back through a degenerate
    triangle) are left out."""
    keep = np.isfinite(source_h).all(axis=1) & np.isfinite(target_pts).all(axis=1)
    sol = np.linalg.lstsq(source_h[keep], target_pts[keep], rcond=None)[0]
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = sol[:3].T, sol[3]
    return out


def _step(matrix, sv_h, sf, tv, tf):
    """One step: closest points both ways, the way back by barycentric coordinates."""
    moved = apply_affine(matrix, sv_h[:, :3])
    to_target = closest_points(moved, tv, tf)[0]
    points, _, tri = closest_points(tv, moved, sf)
    with np.errstate(divide="ignore", invalid="ignore"):  # degenerate triangles: left out
        bary = trimesh.triangles.points_to_barycentric(moved[sf[tri]], points)
    back = np.einsum("nk,nkd->nd", bary, sv_h[sf[tri]])
    return _fit(np.r_[sv_h, back], np.r_[to_target, tv])


def affine_icp(
    source_vertices, source_faces, target_vertices, target_faces, *, iterations: int = 30,
    tol: float = 1e-5,
) -> np.ndarray:  # fmt: skip
    """The affine map bringing the source mesh onto the target surface (see the module).

    Parameters
    ----------
    source_vertices, source_faces : arrays ``(k, 3)``, ``(f, 3)``
        The mesh moved (e.g. the atlas).
    target_vertices, target_faces : arrays ``(m, 3)``, ``(g, 3)``
    iterations : int, default 30
    tol : float, default 1e-5
        Stop when the matrix changes by less than ``tol`` (largest entry, relative
        to the source's extent for the translation).

    Returns
    -------
    array, shape ``(4, 4)``
        ``[[A, b], [0, 0, 0, 1]]``.
    """
    sv, sf = check_mesh(source_vertices, source_faces, "affine_icp: source")
    tv, tf = check_mesh(target_vertices, target_faces, "affine_icp: target")
    iterations = check_int(iterations, "affine_icp: iterations", minimum=1)
    sv_h = np.c_[sv, np.ones(len(sv))]
    extent = float(np.ptp(sv, axis=0).max()) or 1.0
    matrix = np.eye(4)
    for _ in range(iterations):
        new = _step(matrix, sv_h, sf, tv, tf)
        change = np.abs(new - matrix)
        matrix = new
        if max(change[:3, :3].max(), change[:3, 3].max() / extent) < tol:
            break
    return matrix
