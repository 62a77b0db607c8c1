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
import trimesh
from trimesh.exchange.obj import export_obj
from trimesh.exchange.off import export_off

from ..errors import MeshFolderError
from .mesh_readers import read_first, read_with_meshio, read_with_trimesh, vtk_dataset
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


#: Extensions :func:`read_mesh` reads.
MESH_EXTENSIONS = (".ply", ".obj", ".stl", ".off", ".vtk", ".vtu", ".vtp")
#: Extensions of mesh formats not read; such files in a cohort folder are listed in a warning.
OTHER_MESH_EXTENSIONS = (
    ".msh", ".mesh", ".xdmf", ".xmf", ".inp", ".med", ".gii", ".glb", ".gltf", ".pvtu", ".pvtp",
    ".vtm", ".wrl", ".x3d", ".dae", ".3ds", ".fbx", ".h5m", ".vol", ".ugrid", ".su2", ".nas",
    ".bdf", ".exo", ".vti", ".vts", ".vtr",
)  # fmt: skip
#: Extensions :func:`write_mesh` writes.
WRITE_EXTENSIONS = (".ply", ".obj", ".stl", ".off", ".vtk", ".vtu")


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
    meshio = ("meshio", read_with_meshio)
    trimesh_ = ("trimesh", lambda p: read_with_trimesh(p, faces))
    if ext == ".vtk":
        v, f = read_vtk(path) if vtk_dataset(path) == "POLYDATA" else read_with_meshio(path)
    elif ext == ".vtp":
        v, f = read_vtp(path)
    elif ext == ".vtu":
        v, f = read_with_meshio(path)
    elif ext in (".ply", ".off"):
        v, f = read_first(path, [meshio, trimesh_])
    elif ext == ".obj":
        v, f = read_first(path, [trimesh_, meshio])
    else:
        v, f = read_with_trimesh(path, faces)
    if len(v) == 0 or len(f) == 0:
        raise MeshFolderError(f"{path}: cannot be read as a triangle mesh (no vertices or faces)")
    if not np.isfinite(v).all():
        raise MeshFolderError(f"{path}: contains NaN or infinite coordinates")
    if f.min() < 0 or f.max() >= len(v):
        raise MeshFolderError(f"{path}: face indices out of range [0, {len(v)})")
    return v, f.astype(np.int64)


def write_mesh(path, vertices, faces) -> Path:
    """Write a triangle mesh; the format follows the extension (see ``WRITE_EXTENSIONS``).

    PLY is written as binary little-endian with double coordinates, OBJ and OFF
    with 17 significant digits, VTK as ASCII legacy polydata, VTU through meshio
    (double, zlib-compressed), STL as binary float32 (the format's only precision).
    """
    path = Path(path)
    ext = path.suffix.lower()
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if ext == ".vtk":
        return write_vtk(path, v, f)
    if ext == ".vtu":
        import meshio

        meshio.write(path, meshio.Mesh(v, [("triangle", f)]), file_format="vtu")
        return path
    if ext == ".ply":
        header = (
            f"ply\nformat binary_little_endian 1.0\nelement vertex {len(v)}\n"
            "property double x\nproperty double y\nproperty double z\n"
            f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n"
        )
        packed = np.zeros(len(f), dtype=[("n", "u1"), ("idx", "<i4", (3,))])
        packed["n"], packed["idx"] = 3, f
        path.write_bytes(header.encode() + v.astype("<f8").tobytes() + packed.tobytes())
        return path
    mesh = trimesh.Trimesh(v, f, process=False)
    if ext == ".obj":
        text = export_obj(
            mesh, include_normals=False, include_color=False, include_texture=False,
            digits=17, header=None,
        )  # fmt: skip
        path.write_text(text)
    elif ext == ".off":
        path.write_text(export_off(mesh, digits=17))
    elif ext == ".stl":
        mesh.export(path, file_type="stl")
    else:
        raise MeshFolderError(f"{path}: unsupported extension, expected one of {WRITE_EXTENSIONS}")
    return path
