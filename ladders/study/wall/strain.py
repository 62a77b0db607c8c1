"""Circumferential and longitudinal strain of a surface followed through the cycle.

Definitions (Lagrangian, end-diastole the reference), for a mesh in vertex
correspondence with itself through the frames (a tracked endocardium):

* directions at an ED vertex ``x`` with outward unit normal ``n``, the long axis ``a``
  (unit, from the apex to the base-plane centre): the *circumferential* direction
  ``e_c = (a x n) / |a x n|``, the tangent of the short-axis contour through ``x``
  (tangent to the surface and orthogonal to the long axis); the *longitudinal*
  direction ``e_l = n x e_c``, the tangent orthogonal to it, pointing towards the base.
  Where the normal is along the axis (``|a x n| < 1e-3``: the apex of a symmetric
  mesh) ``a x (x - apex)`` takes the place of ``a x n``, and on the axis itself any
  tangent does;
* the stretch of a unit tangent ``e`` at a vertex is that of the material direction
  ``e`` through the deformation of each triangle around the vertex: on triangle ``f``
  with ED edges ``E_f = [b - a, c - a]`` and deformed edges ``E'_f``, the direction
  ``e`` projected onto the triangle's plane and normalised, ``e_f = E_f alpha``, is
  mapped to ``E'_f alpha`` (the triangle's deformation gradient, exact for a motion
  affine on the triangle), and ``lambda^2`` is the mean over the triangles of
  ``|E'_f alpha|^2``, weighted by their ED areas (the mean of the Green-Lagrange
  strain ``(lambda_f^2 - 1) / 2`` along ``e``);
* the strain is the engineering (Lagrangian) strain ``lambda - 1``: the change of
  length of the material line per unit ED length, negative when it shortens, as
  cardiac MR reports it (circumferential and longitudinal strain about -0.2 in
  systole).

The radial strain is not a surface's: it is the relative thickening of the wall,
``T(t) / T(0) - 1`` (:func:`~.thickness.thickening`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse

from manifolds.data_terms.mesh_geometry import check_mesh

from ..wall_motion import outward_vertex_normals

__all__ = ["cardiac_directions", "directional_stretch", "surface_strains"]

#: Below this ``|a x n|`` the normal is taken to lie along the axis.
_ALONG_AXIS = 1e-3


def _unit(x: np.ndarray) -> np.ndarray:
    norm = np.linalg.norm(x, axis=-1, keepdims=True)
    return x / np.where(norm > 0, norm, 1.0)


def _axis(apex, base) -> tuple[np.ndarray, np.ndarray]:
    p = np.asarray(apex, dtype=np.float64)
    q = np.asarray(base, dtype=np.float64)
    if p.shape != (3,) or q.shape != (3,) or not (np.isfinite(p).all() and np.isfinite(q).all()):
        raise ValueError("apex, base: expected two points of 3 finite coordinates")
    length = np.linalg.norm(q - p)
    if length <= 1e-12 * max(1.0, float(np.abs(p).max()), float(np.abs(q).max())):
        raise ValueError("apex, base: the apex and the base-plane centre coincide")
    return p, (q - p) / length


def cardiac_directions(vertices, faces, apex, base) -> tuple[np.ndarray, np.ndarray]:
    """The circumferential and longitudinal unit tangents at every vertex (see the module).

    Parameters
    ----------
    vertices : array, shape (k, 3)
        The reference (ED) mesh.
    faces : int array, shape (f, 3)
    apex, base : array, shape (3,)
        The apex and the base-plane centre, which place the long axis.

    Returns
    -------
    circumferential, longitudinal : ndarray, shape (k, 3)
        Unit vectors, orthogonal to each other and to the outward vertex normal;
        ``longitudinal`` points towards the base.
    """
    v, f = check_mesh(vertices, faces, "cardiac_directions: mesh")
    origin, a = _axis(apex, base)
    n = outward_vertex_normals(v, f)
    c = np.cross(a, n)
    weak = np.linalg.norm(c, axis=1) < _ALONG_AXIS
    if weak.any():
        c[weak] = np.cross(a, v[weak] - origin)
        c[weak] -= np.einsum("ij,ij->i", c[weak], n[weak])[:, None] * n[weak]
        scale = max(1.0, float(np.ptp(v, axis=0).max()))
        on_axis = weak & (np.linalg.norm(c, axis=1) < 1e-9 * scale)
        if on_axis.any():  # any tangent: the one off the coordinate axis least along n
            least = np.eye(3)[np.argmin(np.abs(n[on_axis]), axis=1)]
            c[on_axis] = np.cross(n[on_axis], least)
    c -= np.einsum("ij,ij->i", c, n)[:, None] * n
    c = _unit(c)
    ell = np.cross(n, c)
    ell *= np.where(ell @ a < 0, -1.0, 1.0)[:, None]
    return c, ell


def directional_stretch(reference, deformed, faces, directions) -> np.ndarray:
    """The stretch ``lambda`` of a tangent direction at every vertex (see the module).

    Parameters
    ----------
    reference : array, shape (k, 3)
        The reference (ED) mesh; its triangles must have nonzero area.
    deformed : array, shape (..., k, 3)
        The same mesh deformed (any number of frames).
    faces : int array, shape (f, 3)
    directions : array, shape (k, 3)
        A unit tangent at every reference vertex (e.g. :func:`cardiac_directions`).

    Returns
    -------
    ndarray, shape (..., k)
        ``lambda`` (1: no change of length).

    Raises
    ------
    ValueError
        Misshaped or non-finite input, a degenerate reference triangle, a vertex in no
        triangle.
    """
    ref, f = check_mesh(reference, faces, "directional_stretch: reference")
    ref = np.asarray(ref, dtype=np.float64)
    k = len(ref)
    x = np.asarray(deformed, dtype=np.float64)
    if x.shape[-2:] != (k, 3) or not np.isfinite(x).all():
        raise ValueError(f"deformed: expected finite points (..., {k}, 3), got shape {x.shape}")
    d = np.asarray(directions, dtype=np.float64)
    if d.shape != (k, 3) or not np.isfinite(d).all():
        raise ValueError(f"directions: expected finite vectors ({k}, 3), got shape {d.shape}")
    counts = np.bincount(f.ravel(), minlength=k)
    if (counts == 0).any():
        raise ValueError(f"faces: vertex {int(np.argmin(counts))} belongs to no triangle")
    e1, e2 = ref[f[:, 1]] - ref[f[:, 0]], ref[f[:, 2]] - ref[f[:, 0]]
    normal = np.cross(e1, e2)
    area = 0.5 * np.linalg.norm(normal, axis=1)
    extent = float(np.ptp(ref, axis=0).max()) or 1.0
    bad = area <= 1e-12 * extent**2
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"reference: {int(bad.sum())} degenerate triangle(s), first face {i} "
                         f"{f[i].tolist()}: the stretch is undefined there")  # fmt: skip
    normal /= (2.0 * area)[:, None]
    vertex, face = f.ravel(), np.repeat(np.arange(len(f)), 3)
    e = d[vertex] - np.einsum("ij,ij->i", d[vertex], normal[face])[:, None] * normal[face]
    length = np.linalg.norm(e, axis=1)
    weight = np.where(length > 1e-6, area[face], 0.0)  # a direction along the face's normal
    e = e / np.where(length > 0, length, 1.0)[:, None]
    g11, g12, g22 = (np.einsum("ij,ij->i", p, q) for p, q in ((e1, e1), (e1, e2), (e2, e2)))
    r1, r2 = np.einsum("ij,ij->i", e1[face], e), np.einsum("ij,ij->i", e2[face], e)
    det = (g11 * g22 - g12**2)[face]
    alpha1 = (g22[face] * r1 - g12[face] * r2) / det
    alpha2 = (g11[face] * r2 - g12[face] * r1) / det
    d1 = x[..., f[:, 1], :] - x[..., f[:, 0], :]
    d2 = x[..., f[:, 2], :] - x[..., f[:, 0], :]
    mapped = alpha1[:, None] * d1[..., face, :] + alpha2[:, None] * d2[..., face, :]
    squared = np.einsum("...ij,...ij->...i", mapped, mapped)
    total = np.bincount(vertex, weights=weight, minlength=k)
    if (total == 0).any():
        raise ValueError(f"directions: vertex {int(np.argmin(total))}: the direction is along "
                         "the normal of every triangle around it (not a tangent)")  # fmt: skip
    mean = scipy.sparse.csr_matrix((weight / total[vertex], (vertex, np.arange(len(vertex)))),
                                   shape=(k, len(vertex)))  # fmt: skip
    batch = squared.shape[:-1]
    flat = squared.reshape(-1, len(vertex))
    return np.sqrt(np.asarray(mean @ flat.T).T).reshape(*batch, k)


def surface_strains(frames, faces, apex, base) -> tuple[np.ndarray, np.ndarray]:
    """Circumferential and longitudinal strain of a tracked surface at every frame.

    Parameters
    ----------
    frames : array, shape (n_frames, k, 3)
        The surface at every frame in vertex correspondence, frame 0 the reference (ED).
    faces : int array, shape (f, 3)
    apex, base : array, shape (3,)
        The long axis (in the frames' frame), as in :func:`cardiac_directions`.

    Returns
    -------
    circumferential, longitudinal : ndarray, shape (n_frames, k)
        ``lambda - 1`` of the ED directions (0 at frame 0).
    """
    x = np.asarray(frames, dtype=np.float64)
    if x.ndim != 3 or x.shape[-1] != 3 or len(x) == 0:
        raise ValueError(f"frames: expected shape (n_frames, k, 3), got {x.shape}")
    circ, lon = cardiac_directions(x[0], faces, apex, base)
    return (directional_stretch(x[0], x, faces, circ) - 1.0,
            directional_stretch(x[0], x, faces, lon) - 1.0)  # fmt: skip
