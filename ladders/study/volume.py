"""The volume enclosed by a surface mesh, closed or open at one rim (e.g. the base of a ventricle).

A left-ventricle endocardium of the synthetic cohort is open at the base plane.
Its cavity volume is the volume of the surface closed by a cone from the centroid
of its boundary vertices: the sum over triangles ``(a, b, c)`` of the signed
volumes ``det(a - o, b - o, c - o) / 6`` with ``o`` that centroid. For a closed
surface the choice of ``o`` does not matter and this is the enclosed volume
(positive for outward normals).
"""

from __future__ import annotations

import numpy as np

from manifolds.data_terms.mesh_geometry import check_mesh

__all__ = ["boundary_edges", "boundary_vertices", "enclosed_volume"]


def boundary_edges(faces) -> np.ndarray:
    """The boundary edges (used by one triangle only), shape ``(b, 2)``, each sorted."""
    f = np.asarray(faces, dtype=np.int64)
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    return unique[counts == 1]


def boundary_vertices(faces) -> np.ndarray:
    """Indices of the vertices on boundary edges (edges used by one triangle only)."""
    return np.unique(boundary_edges(faces))


def enclosed_volume(vertices, faces) -> float | np.ndarray:
    """Signed volume enclosed by the surface, closed at its boundary by a cone (see module).

    Parameters
    ----------
    vertices : array, shape (k, 3) or (n, k, 3)
        One shape or a batch of shapes sharing ``faces`` (in the unit of the meshes:
        the volume is in that unit cubed).
    faces : int array, shape (f, 3)

    Returns
    -------
    float, or ndarray of shape (n,)
    """
    v = np.asarray(vertices, dtype=float)
    batch = v.ndim == 3
    if not batch:
        v = v[None]
    check_mesh(v[0], faces, "enclosed_volume: mesh")
    f = np.asarray(faces, dtype=np.int64)
    rim = boundary_vertices(f)
    origin = v[:, rim].mean(axis=1) if rim.size else v.mean(axis=1)
    a, b, c = (v[:, f[:, i]] - origin[:, None, :] for i in range(3))
    volume = np.einsum("nfi,nfi->n", a, np.cross(b, c)) / 6.0
    return volume if batch else float(volume[0])
