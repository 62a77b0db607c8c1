"""Triangle geometry of a mesh and its reverse-mode derivative with respect to the vertices.

A triangle ``(a, b, c)`` has the centre ``(a + b + c) / 3``, the area-weighted
normal ``n = 1/2 (b - a) x (c - a)`` (its length is the area), the area
``|n|`` and the unit normal ``n / |n|``. The surface data terms
(:mod:`.current`, :mod:`.varifold`) are functions of the centres and normals;
their gradients reach the vertices through :func:`triangle_geometry_vjp`, the
chain rule through the mean and the cross product::

    d<g, u x v>/du = v x g,    d<g, u x v>/dv = g x u.

A triangle of zero area (repeated or collinear vertices) has a zero normal; its
unit normal is set to zero rather than ``0 / 0`` (see :func:`unit_normals`).
"""

from __future__ import annotations

import numpy as np

from ..validation import as_float_array, check_array

__all__ = [
    "check_faces",
    "check_mesh",
    "triangle_geometry",
    "triangle_geometry_vjp",
    "unit_normals",
]


def check_faces(faces, n_vertices: int | None, name: str) -> np.ndarray:
    """``faces`` as an ``(f, 3)`` int64 array indexing ``n_vertices`` vertices, or raise.

    Parameters
    ----------
    faces : array_like of int, shape ``(f, 3)``
    n_vertices : int or None
        Number of vertices the faces index; None skips the range check's upper bound.
    name : str
        Names the argument in messages.

    Raises
    ------
    ValueError
        Not an ``(f, 3)`` array of integers, no face, or an index out of range.
    """
    arr = np.asarray(faces)
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] == 0:
        raise ValueError(f"{name}: expected triangles of shape (f, 3) with f >= 1, got {arr.shape}")
    if arr.dtype.kind not in "iu":
        as_float = as_float_array(arr, name)
        if not np.isfinite(as_float).all() or not np.array_equal(as_float, np.round(as_float)):
            raise ValueError(f"{name}: expected integer vertex indices, got dtype {arr.dtype}")
    arr = arr.astype(np.int64)
    low, high = int(arr.min()), int(arr.max())
    if low < 0 or (n_vertices is not None and high >= n_vertices):
        allowed = "non-negative" if n_vertices is None else f"in [0, {n_vertices})"
        raise ValueError(
            f"{name}: vertex indices must be {allowed}; found indices from {low} to {high}"
        )
    return arr


def check_mesh(vertices, faces, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Checked ``(vertices (k, 3) float64, faces (f, 3) int64)`` of a triangle mesh.

    Raises a ``ValueError`` (a :class:`~manifolds.errors.ManifoldError` for the
    vertices) naming ``name`` on a wrong shape, NaN or out-of-range face index.
    """
    v = check_array(vertices, (3,), f"{name} vertices")
    if v.ndim != 2 or v.shape[0] < 3:
        raise ValueError(f"{name} vertices: expected shape (k, 3) with k >= 3, got {v.shape}")
    return v, check_faces(faces, v.shape[0], f"{name} faces")


def triangle_geometry(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centres and area-weighted normals of the triangles.

    Parameters
    ----------
    vertices : array, shape ``(k, 3)``
    faces : int array, shape ``(f, 3)``

    Returns
    -------
    centres : array, shape ``(f, 3)``
    normals : array, shape ``(f, 3)``
        ``1/2 (b - a) x (c - a)``; its norm is the triangle's area.
    """
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    return (a + b + c) / 3.0, 0.5 * np.cross(b - a, c - a)


def unit_normals(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Areas ``|n|`` and unit normals ``n / |n|``, the unit normal of a zero-area triangle zero.

    A zero unit normal makes the triangle's varifold mass ``a (u . v)^2`` and its
    gradient vanish, which is their limit as the area goes to zero; no NaN arises.

    Parameters
    ----------
    normals : array, shape ``(f, 3)``

    Returns
    -------
    areas : array, shape ``(f,)``
    units : array, shape ``(f, 3)``
    """
    areas = np.sqrt((normals * normals).sum(axis=1))
    units = np.zeros_like(normals)
    np.divide(normals, areas[:, None], out=units, where=areas[:, None] > 0.0)
    return areas, units


def triangle_geometry_vjp(
    vertices: np.ndarray, faces: np.ndarray, g_centres: np.ndarray, g_normals: np.ndarray
) -> np.ndarray:
    """Gradient with respect to the vertices of ``<g_centres, centres> + <g_normals, normals>``.

    Parameters
    ----------
    vertices : array, shape ``(k, 3)``
    faces : int array, shape ``(f, 3)``
    g_centres, g_normals : arrays, shape ``(f, 3)``
        Cotangents of :func:`triangle_geometry`'s outputs.

    Returns
    -------
    array, shape ``(k, 3)``
    """
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    e1, e2 = b - a, c - a
    g_e1 = 0.5 * np.cross(e2, g_normals)  # d<g, e1 x e2>/de1 = e2 x g
    g_e2 = 0.5 * np.cross(g_normals, e1)  # d<g, e1 x e2>/de2 = g x e1
    g_mean = g_centres / 3.0
    per_corner = (g_mean - g_e1 - g_e2, g_mean + g_e1, g_mean + g_e2)
    n = vertices.shape[0]
    out = np.zeros_like(vertices)
    for corner, g in enumerate(per_corner):
        idx = faces[:, corner]
        for axis in range(3):
            out[:, axis] += np.bincount(idx, weights=g[:, axis], minlength=n)
    return out
