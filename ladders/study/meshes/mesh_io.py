"""Read and write one triangle mesh (PLY, OBJ, STL, OFF, VTK, VTU, VTP), keeping its vertex order.

Every mesh of a cohort must have the atlas's vertex count and faces, in the
same vertex order: vertex ``i`` of every file is the same anatomical point.
Files are read through meshio or, where they do better, trimesh or the readers
of this package (the choice per format is in
:mod:`ladders.study.meshes.mesh_readers`); no reader merges or reorders
vertices. STL stores a triangle soup in float32: its vertices are merged back
in order of first appearance in the faces (or, for a subject, by the atlas's
faces), which restores the vertex order of files written from the same
triangulation. Folders and tables of meshes are read by
:mod:`ladders.study.cohort`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import MeshFolderError
from ..files import atomic_path
from .mesh_readers import MESH_FORMATS, reader_for
from .vtk_io import read_vtk, write_vtk
from .vtk_xml import read_vtp

__all__ = [
    "MESH_EXTENSIONS",
    "OTHER_MESH_EXTENSIONS",
    "WRITE_EXTENSIONS",
    "MeshFolderError",
    "read_mesh",
    "write_mesh",
    "read_vtk",
    "read_vtp",
    "write_vtk",
]


#: Extensions :func:`read_mesh` reads (the registry :data:`~.mesh_readers.MESH_FORMATS`).
MESH_EXTENSIONS = tuple(MESH_FORMATS)
#: Extensions of mesh formats not read; such files in a cohort folder are listed in a warning.
OTHER_MESH_EXTENSIONS = (
    ".msh", ".mesh", ".xdmf", ".xmf", ".inp", ".med", ".gii", ".glb", ".gltf", ".pvtu", ".pvtp",
    ".vtm", ".wrl", ".x3d", ".dae", ".3ds", ".fbx", ".h5m", ".vol", ".ugrid", ".su2", ".nas",
    ".bdf", ".exo", ".vti", ".vts", ".vtr",
)  # fmt: skip
#: Extensions :func:`write_mesh` writes.
WRITE_EXTENSIONS = tuple(ext for ext, fmt in MESH_FORMATS.items() if fmt.write is not None)


def read_mesh(path, faces=None) -> tuple[np.ndarray, np.ndarray]:
    """Read one triangle mesh, keeping the file's vertex order.

    Parameters
    ----------
    path : str or Path
        A file with one of the extensions :data:`MESH_EXTENSIONS`: PLY, OBJ, OFF,
        STL, legacy VTK (polydata or unstructured grid), VTK XML unstructured
        grid (``.vtu``) or polydata (``.vtp``).
    faces : array_like of int, shape (f, 3), optional
        For STL only: the triangulation the file was written from, used to
        index its triangle soup (otherwise vertices are numbered by first appearance).

    Returns
    -------
    vertices : ndarray, shape (k, 3), float64
    faces : ndarray of int, shape (f, 3)
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in MESH_EXTENSIONS:
        raise MeshFolderError(f"{path}: unsupported extension, expected one of {MESH_EXTENSIONS}")
    if not path.is_file():
        raise MeshFolderError(f"{path}: no such file")
    v, f = reader_for(path, faces)()
    if len(v) == 0 or len(f) == 0:
        raise MeshFolderError(f"{path}: cannot be read as a triangle mesh (no vertices or faces)")
    if not np.isfinite(v).all():
        raise MeshFolderError(f"{path}: contains NaN or infinite coordinates")
    if f.min() < 0 or f.max() >= len(v):
        raise MeshFolderError(f"{path}: face indices out of range [0, {len(v)})")
    return v, f.astype(np.int64)


def write_mesh(path, vertices, faces, *, atomic: bool = False) -> Path:
    """Write a triangle mesh; the format follows the extension (see ``WRITE_EXTENSIONS``).

    PLY is written through meshio as binary little-endian with double coordinates,
    OBJ and OFF through trimesh with 17 significant digits, VTK as ASCII legacy
    polydata, VTU through meshio (double, zlib-compressed), STL through trimesh as
    binary float32 (the format's only precision). With ``atomic=True`` the file is
    written to a hidden temporary name in its folder and renamed: an interrupted
    write never leaves a partial file under ``path``.
    """
    path = Path(path)
    fmt = MESH_FORMATS.get(path.suffix.lower())
    if fmt is None or fmt.write is None:
        raise MeshFolderError(f"{path}: unsupported extension, expected one of {WRITE_EXTENSIONS}")
    v, f = np.asarray(vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64)
    if not atomic:
        fmt.write(path, v, f)
        return path
    with atomic_path(path) as tmp:
        fmt.write(tmp, v, f)
    return path
