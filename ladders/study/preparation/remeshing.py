"""Another triangulation of the same surface: subdivide, then decimate.

:func:`remesh` gives a mesh a different vertex count and triangulation while
keeping its surface, as a segmentation tool would produce it: the mesh is
subdivided (each triangle into four, ``subdivisions`` times) and decimated
back by quadric error simplification (:meth:`trimesh.Trimesh.simplify_quadric_decimation`,
through the ``fast-simplification`` package) to about ``n_faces`` triangles.
Zero-area triangles left by the decimation are removed. It serves to test
correspondence without correspondence (``tests/test_preparation_ground_truth.py``)
and in the tutorial.
"""

from __future__ import annotations

import numpy as np
import trimesh

from manifolds.data_terms.mesh_geometry import check_mesh
from manifolds.validation import check_int

__all__ = ["remesh"]


def remesh(vertices, faces, n_faces: int, subdivisions: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """The surface of ``(vertices, faces)`` with about ``n_faces`` new triangles.

    Parameters
    ----------
    vertices : array, shape ``(k, 3)``
    faces : int array, shape ``(f, 3)``
    n_faces : int
        Target triangle count (at most ``4**subdivisions * f``).
    subdivisions : int, default 2

    Returns
    -------
    vertices : array, shape ``(k', 3)``
    faces : int array, shape ``(f', 3)``, ``f'`` close to ``n_faces``
    """
    v, f = check_mesh(vertices, faces, "remesh: mesh")
    n_faces = check_int(n_faces, "remesh: n_faces", minimum=4)
    subdivisions = check_int(subdivisions, "remesh: subdivisions", minimum=0)
    if n_faces > 4**subdivisions * len(f):
        raise ValueError(
            f"remesh: n_faces: at most {4**subdivisions * len(f)} with {subdivisions} "
            f"subdivision(s) of {len(f)} faces, got {n_faces}"
        )
    mesh = trimesh.Trimesh(v, f, process=False)
    for _ in range(subdivisions):
        mesh = mesh.subdivide()
    mesh = mesh.simplify_quadric_decimation(face_count=n_faces)
    keep = mesh.nondegenerate_faces(height=1e-12)
    mesh.update_faces(keep)
    mesh.remove_unreferenced_vertices()
    return np.array(mesh.vertices, dtype=float), np.array(mesh.faces, dtype=np.int64)
