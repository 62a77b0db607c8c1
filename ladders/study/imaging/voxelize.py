"""Label images of known shapes: the ground truth of the meshing (and the tutorial's data).

:func:`voxelize` writes the inside of a closed surface into a label image of a
chosen grid: the voxel centres ``affine @ (i, j, k, 1)`` inside the surface get the
label. An open surface (the synthetic ventricle, open at its base) is first closed
by :func:`close_surface` (a cone from its boundary's centroid), so that the label is
the cavity up to the base plane. :func:`short_axis_affine` builds the affine of a
cardiac short-axis stack: in-plane pixels, thick slices along the long axis,
optionally tilted (an oblique acquisition) and flipped.
"""

from __future__ import annotations

from pathlib import Path

import nibabel as nib
import numpy as np

from manifolds.data_terms.mesh_geometry import check_mesh

from ..volume import boundary_vertices

__all__ = ["close_surface", "voxelize", "short_axis_affine", "write_label_image"]


def close_surface(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """A surface open at one rim closed by a fan of triangles from the rim's centroid."""
    v, f = check_mesh(vertices, faces, "close_surface: mesh")
    rim = boundary_vertices(f)
    if rim.size == 0:
        return v, f
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    key = np.sort(edges, axis=1)
    _, index, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    boundary = edges[index[counts == 1]]  # oriented as in their face
    centre = len(v)
    cap = np.column_stack([boundary[:, 1], boundary[:, 0], np.full(len(boundary), centre)])
    return np.vstack([v, v[rim].mean(axis=0)]), np.vstack([f, cap]).astype(np.int64)


def short_axis_affine(
    origin, in_plane: float, slice_thickness: float, tilt_deg: float = 0.0, flip: bool = False
) -> np.ndarray:
    """The affine of a short-axis stack: pixels ``in_plane`` mm, slices ``slice_thickness`` mm.

    The slices are stacked along ``+z`` (the synthetic ventricle's long axis), tilted
    by ``tilt_deg`` about the ``x`` axis (an oblique acquisition); ``flip`` reverses
    the first index axis (a left-right flip, negative determinant).
    """
    t = np.radians(tilt_deg)
    rotation = np.array(
        [[1.0, 0.0, 0.0], [0.0, np.cos(t), -np.sin(t)], [0.0, np.sin(t), np.cos(t)]]
    )
    scale = np.diag([-in_plane if flip else in_plane, in_plane, slice_thickness])
    affine = np.eye(4)
    affine[:3, :3] = rotation @ scale
    affine[:3, 3] = np.asarray(origin, dtype=float)
    return affine


def voxelize(vertices, faces, affine, shape, label: int = 1) -> np.ndarray:
    """Label image ``shape`` whose voxels with centres inside the surface have ``label``.

    Exact for a closed surface (parity of ray crossings): the surface is mapped to
    index space by the inverse affine and, for every column ``(i, j)`` of voxel
    centres, the crossings of the line along ``k`` with the triangles are found; a
    centre is inside when an odd number of crossings lies below it. The columns are
    shifted by 1e-7 voxel so that no line meets an edge or a vertex exactly.

    Parameters
    ----------
    vertices, faces : the surface (closed, or open at one rim: closed by :func:`close_surface`)
    affine : array (4, 4)
        Voxel indices to world coordinates (the surface's unit, mm).
    shape : (int, int, int)
    label : int

    Returns
    -------
    ndarray of int16, shape ``shape``
    """
    v, f = close_surface(vertices, faces)
    a = np.asarray(affine, dtype=float)
    index = (v - a[:3, 3]) @ np.linalg.inv(a[:3, :3]).T
    ni, nj, nk = (int(n) for n in shape)
    crossings = np.zeros((ni, nj, nk + 1), dtype=np.int32)
    shift = np.array([1e-7 * np.pi, 1e-7 * np.e])
    for tri in index[f]:
        lo = np.maximum(np.ceil(tri[:, :2].min(axis=0) - shift), 0).astype(int)
        hi = np.minimum(np.floor(tri[:, :2].max(axis=0) - shift), [ni - 1, nj - 1]).astype(int)
        if np.any(hi < lo):
            continue
        ii, jj = np.meshgrid(
            np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1), indexing="ij"
        )
        p = np.stack([ii.ravel(), jj.ravel()], axis=1) + shift
        (x0, y0), (x1, y1), (x2, y2) = tri[:, :2]
        det = (y1 - y2) * (x0 - x2) + (x2 - x1) * (y0 - y2)
        if det == 0.0:
            continue
        w0 = ((y1 - y2) * (p[:, 0] - x2) + (x2 - x1) * (p[:, 1] - y2)) / det
        w1 = ((y2 - y0) * (p[:, 0] - x2) + (x0 - x2) * (p[:, 1] - y2)) / det
        w2 = 1.0 - w0 - w1
        hit = (w0 >= 0) & (w1 >= 0) & (w2 >= 0)
        if not hit.any():
            continue
        k = w0[hit] * tri[0, 2] + w1[hit] * tri[1, 2] + w2[hit] * tri[2, 2]
        first = np.clip(np.ceil(k), 0, nk).astype(int)
        np.add.at(crossings, (ii.ravel()[hit], jj.ravel()[hit], first), 1)
    inside = (np.cumsum(crossings, axis=2)[:, :, :nk] % 2).astype(bool)
    return np.where(inside, label, 0).astype(np.int16)


def write_label_image(path, labels, affine) -> Path:
    """Write a label image (int16) with ``affine`` as its sform and qform (NIfTI-1)."""
    img = nib.Nifti1Image(np.asarray(labels, dtype=np.int16), np.asarray(affine, dtype=float))
    img.set_sform(np.asarray(affine, dtype=float), code=1)
    img.set_qform(np.asarray(affine, dtype=float), code=1)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    nib.save(img, str(path))
    return path
