"""Local area strain (LAS) and area strain error (ASE) of the paper's Section 3.

For a vertex ``i`` that belongs to ``k_i`` triangles with areas ``a_j`` on a
first shape and ``a'_j`` on a second shape with the same triangulation,

    LAS_i = (1 / k_i) sum_j (a_j - a'_j) / a_j,

so a contraction gives a positive strain and a uniform scaling by ``s`` gives
``1 - s**2``. The paper compares the strain between a subject's ``S`` and
``S'`` with the strain between the atlas ``T`` and its transported ``T'``:

    ASE = sqrt( sum_i (LAS_i^{S-S'} - LAS_i^{T-T'})**2 ).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse

from manifolds.errors import ManifoldError
from manifolds.validation import check_array

__all__ = ["cell_areas", "area_strain", "area_strain_error"]

#: Cells with area below ``DEGENERATE_RTOL * (bounding-box diagonal)**2`` are degenerate.
DEGENERATE_RTOL = 1e-12


def _check_faces(faces, n_vertices: int, name: str = "faces") -> np.ndarray:
    arr = np.asarray(faces)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ManifoldError(f"{name}: expected an array of triangles (f, 3), got {arr.shape}")
    if arr.shape[0] == 0:
        raise ManifoldError(f"{name}: no triangle given")
    if not np.issubdtype(arr.dtype, np.integer):
        if not np.issubdtype(arr.dtype, np.floating) or not np.all(arr == np.round(arr)):
            raise ManifoldError(f"{name}: expected integer vertex indices, got dtype {arr.dtype}")
    arr = arr.astype(np.int64)
    lo, hi = int(arr.min()), int(arr.max())
    if lo < 0 or hi >= n_vertices:
        raise ManifoldError(
            f"{name}: vertex indices must lie in [0, {n_vertices}), got range [{lo}, {hi}]"
        )
    return arr


def cell_areas(vertices, faces) -> np.ndarray:
    """Areas of the triangles ``faces`` of the mesh(es) ``vertices``.

    Parameters
    ----------
    vertices : array_like, shape (..., k, 3)
    faces : array_like of int, shape (f, 3)

    Returns
    -------
    ndarray, shape (..., f)
    """
    v = check_array(vertices, (3,), "vertices")
    if v.ndim < 2:
        raise ManifoldError(f"vertices: expected shape (..., k, 3), got {v.shape}")
    f = _check_faces(faces, v.shape[-2])
    return _areas(v, f)


def _areas(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    a, b, c = v[..., f[:, 0], :], v[..., f[:, 1], :], v[..., f[:, 2], :]
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=-1)


def area_strain(vertices, vertices_deformed, faces) -> np.ndarray:
    """Local area strain at every vertex between two corresponding meshes (paper, Section 3).

    Parameters
    ----------
    vertices : array_like, shape (..., k, 3)
        First shape (``S`` or ``T``); its cells must have nonzero area.
    vertices_deformed : array_like, shape (..., k, 3)
        Second shape (``S'`` or ``T'``), same shape as ``vertices``.
    faces : array_like of int, shape (f, 3)
        Triangles shared by both shapes; every vertex must belong to one.

    Returns
    -------
    ndarray, shape (..., k)
        ``LAS_i = (1/k_i) sum_j (a_j - a'_j) / a_j`` over the ``k_i`` cells of vertex ``i``.

    Raises
    ------
    ManifoldError
        Mismatched shapes, NaN, face indices out of range, a vertex in no
        face, or a degenerate (zero-area) cell of ``vertices``.
    """
    v = check_array(vertices, (3,), "vertices")
    w = check_array(vertices_deformed, (3,), "vertices_deformed")
    if v.ndim < 2:
        raise ManifoldError(f"vertices: expected shape (..., k, 3), got {v.shape}")
    if w.shape != v.shape:
        raise ManifoldError(f"vertices_deformed: shape {w.shape} does not match vertices {v.shape}")
    k = v.shape[-2]
    f = _check_faces(faces, k)
    counts = np.bincount(f.ravel(), minlength=k)
    if np.any(counts == 0):
        lonely = np.flatnonzero(counts == 0)
        raise ManifoldError(
            f"faces: {lonely.size} vertex(es) belong to no triangle (first: {lonely[0]}); "
            "the local area strain is undefined there"
        )
    a = _areas(v, f)
    extent = np.ptp(v, axis=-2)
    scale = np.maximum((extent**2).sum(axis=-1), np.finfo(float).tiny)
    bad = a <= DEGENERATE_RTOL * scale[..., None]
    if np.any(bad):
        idx = np.argwhere(bad)[0]
        raise ManifoldError(
            f"vertices: {int(bad.sum())} degenerate (zero-area) cell(s), first is face "
            f"{int(idx[-1])} {f[idx[-1]].tolist()}; area strain divides by these areas"
        )
    ratio = (a - _areas(w, f)) / a
    # Vertex-by-face incidence, each row averaged over the k_i cells of the vertex.
    rows = f.ravel()
    cols = np.repeat(np.arange(f.shape[0]), 3)
    incidence = scipy.sparse.csr_matrix((1.0 / counts[rows], (rows, cols)), shape=(k, f.shape[0]))
    batch = ratio.shape[:-1]
    flat = ratio.reshape(-1, f.shape[0])
    return np.asarray(incidence @ flat.T).T.reshape(*batch, k)


def area_strain_error(las_subject, las_atlas) -> np.ndarray:
    """Area strain error ``ASE = sqrt(sum_i (LAS_i^{S-S'} - LAS_i^{T-T'})**2)`` (paper, Section 3).

    Parameters
    ----------
    las_subject : array_like, shape (..., k)
        Local area strain between the subject's ``S`` and ``S'``.
    las_atlas : array_like, shape (..., k)
        Local area strain between the atlas ``T`` and the transported ``T'``.

    Returns
    -------
    ndarray, shape (...)
        Zero-dimensional for single strain maps.
    """
    s = check_array(las_subject, (), "las_subject")
    t = check_array(las_atlas, (), "las_atlas")
    if s.ndim < 1:
        raise ManifoldError("las_subject: expected a strain map of shape (..., k), got a scalar")
    if t.shape[-1:] != s.shape[-1:] or t.ndim < 1:
        raise ManifoldError(
            f"las_atlas: shape {t.shape} does not match las_subject {s.shape} on the vertex axis"
        )
    try:
        diff = s - t
    except ValueError as exc:
        raise ManifoldError(
            f"las_atlas: shape {t.shape} does not broadcast with las_subject {s.shape}"
        ) from exc
    return np.sqrt((diff**2).sum(axis=-1))
