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

A ventricle's wall is close to a tube: sliding it along its long axis, or
stretching it there, barely changes its distance to another wall, so the
surfaces alone leave the affine fit's stretch along the axis set by the rim
(where the mesh was cut) and the apex's curvature. Where the apex and the
base-plane centre are known on both meshes (a landmark table, or the landmarks
of a label image), they enter the least squares as ``anchors``: point pairs of
weight ``anchor_weight`` times the number of surface pairs each, or with
``anchor_direction`` their components along that direction only (the heights
along the long axis). What this changes on label-image meshes, whose rim lies
below the true base, is measured in ``benchmarks/bench_image_route.py``.
"""

from __future__ import annotations

import numpy as np
import trimesh

from manifolds.data_terms.mesh_geometry import check_mesh
from manifolds.validation import check_array, check_float, check_int

from ..surface_queries import closest_points
from ..volume import boundary_edges
from .surface_distance import on_rim

__all__ = ["affine_icp", "apply_affine"]


def apply_affine(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``points @ A^T + b`` for the 4 x 4 matrix ``[[A, b], [0, 1]]``; shape ``(n, 3)``."""
    return np.asarray(points, dtype=float) @ matrix[:3, :3].T + matrix[:3, 3]


def _fit(source_h, target_pts, anchors=None, anchor_weight: float = 0.0, direction=None):
    """The affine matrix ``(4, 4)`` of the least-squares fit ``source_h -> target_pts``.

    Pairs with a non-finite coordinate (a point carried back through a degenerate
    triangle) are left out. ``anchors`` ``(source, target)``: point pairs of weight
    ``anchor_weight`` times the number of the other pairs each; with ``direction``
    (a unit vector of the target's frame) only their components along it count."""
    keep = np.isfinite(source_h).all(axis=1) & np.isfinite(target_pts).all(axis=1)
    source_h, target_pts = source_h[keep], target_pts[keep]
    if anchors is None or anchor_weight == 0:
        sol = np.linalg.lstsq(source_h, target_pts, rcond=None)[0]
    else:
        root = np.sqrt(anchor_weight * len(source_h))
        a = np.c_[anchors[0], np.ones(len(anchors[0]))]
        if direction is None:
            sol = np.linalg.lstsq(np.r_[source_h, root * a],
                                  np.r_[target_pts, root * anchors[1]], rcond=None)[0]  # fmt: skip
        else:  # the three coordinates' columns solved together: 12 unknowns
            blocks = np.kron(np.eye(3), source_h)
            rows = root * np.kron(direction[None, :], a)
            rhs = np.r_[target_pts.T.ravel(), root * (anchors[1] @ direction)]
            sol = np.linalg.lstsq(np.r_[blocks, rows], rhs, rcond=None)[0].reshape(3, 4).T
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = sol[:3].T, sol[3]
    return out


def _step(matrix, sv_h, sf, tv, tf, anchors=None, anchor_weight: float = 0.0, direction=None,
          rims=None):  # fmt: skip
    """One step: closest points both ways, the way back by barycentric coordinates; with
    ``rims`` (the boundary edges of the target and of the source) the pairs whose
    closest point lies on a rim are left out."""
    moved = apply_affine(matrix, sv_h[:, :3])
    to_target, _, to_tri = closest_points(moved, tv, tf)
    points, _, tri = closest_points(tv, moved, sf)
    with np.errstate(divide="ignore", invalid="ignore"):  # degenerate triangles: left out
        bary = trimesh.triangles.points_to_barycentric(moved[sf[tri]], points)
    back = np.einsum("nk,nkd->nd", bary, sv_h[sf[tri]])
    if rims is not None:  # NaN pairs are left out of the fit
        to_target[on_rim(to_target, tv, tf, to_tri, rims[0])] = np.nan
        back[on_rim(points, moved, sf, tri, rims[1])] = np.nan
    return _fit(np.r_[sv_h, back], np.r_[to_target, tv], anchors, anchor_weight, direction)


def affine_icp(
    source_vertices, source_faces, target_vertices, target_faces, *, iterations: int = 30,
    tol: float = 1e-5, anchors=None, anchor_weight: float = 0.1, anchor_direction=None,
    skip_rim: bool = False,
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
    anchors : tuple of two arrays ``(n, 3)``, optional
        ``(source_points, target_points)``: points known to correspond (the apex and
        the base-plane centre of a ventricle), in the frames of the two meshes.
    anchor_weight : float, default 0.1
        Weight of each anchor pair, as a multiple of the number of surface pairs (each
        of weight 1); ``docs/preparation.md`` says how it was chosen.
    anchor_direction : array (3,), optional
        A direction of the target's frame (the long axis): only the anchors'
        components along it enter the fit, the three coordinates then solved together.
    skip_rim : bool, default False
        Leave out the pairs whose closest point lies on the other mesh's rim (its
        boundary edges; Turk and Levoy, 1994): the part of a mesh that goes on beyond
        the other's rim does not pull the fit onto that rim. Without anchors the rim
        then no longer sets the stretch along a tube's axis.

    Returns
    -------
    array, shape ``(4, 4)``
        ``[[A, b], [0, 0, 0, 1]]``.
    """
    sv, sf = check_mesh(source_vertices, source_faces, "affine_icp: source")
    tv, tf = check_mesh(target_vertices, target_faces, "affine_icp: target")
    iterations = check_int(iterations, "affine_icp: iterations", minimum=1)
    anchor_weight = check_float(anchor_weight, "affine_icp: anchor_weight", minimum=0.0)
    if anchors is not None:
        if len(anchors) != 2:
            raise ValueError("affine_icp: anchors: expected (source_points, target_points)")
        anchors = tuple(check_array(a, (3,), f"affine_icp: anchors[{i}]") for i, a in enumerate(anchors))  # fmt: skip
        if anchors[0].ndim != 2 or anchors[0].shape != anchors[1].shape:
            raise ValueError(
                "affine_icp: anchors: expected two arrays of the same shape (n, 3), got "
                f"{anchors[0].shape} and {anchors[1].shape}"
            )
    direction = None
    if anchor_direction is not None:
        direction = check_array(anchor_direction, (3,), "affine_icp: anchor_direction")
        norm = float(np.linalg.norm(direction))
        if direction.shape != (3,) or norm == 0.0:
            raise ValueError("affine_icp: anchor_direction: expected a non-zero vector (3,)")
        direction = direction / norm
    sv_h = np.c_[sv, np.ones(len(sv))]
    extent = float(np.ptp(sv, axis=0).max()) or 1.0
    matrix = np.eye(4)
    rims = (boundary_edges(tf), boundary_edges(sf)) if skip_rim else None
    for _ in range(iterations):
        new = _step(matrix, sv_h, sf, tv, tf, anchors, anchor_weight, direction, rims)
        change = np.abs(new - matrix)
        matrix = new
        if max(change[:3, :3].max(), change[:3, 3].max() / extent) < tol:
            break
    return matrix
