"""The registry of mesh formats: one table of extensions, each with its reader and writer.

Every format is read so that vertex ``i`` of the file is vertex ``i`` of the
returned array (no merging, no reordering), since a study's meshes are in
vertex correspondence through their vertex order. :func:`reader_for` picks the
reader from the extension and, where one extension holds several kinds of file,
from the file's header; a header that does not belong to the extension's format
is refused with a message saying what the file starts with.

The readers and writers, by extension::

    ========  ==================================================================  ==============
    ext       read with (chosen by the header)                                    written with
    ========  ==================================================================  ==============
    ``.vtk``  ``DATASET POLYDATA``: :func:`ladders.study.meshes.vtk_io.read_vtk`   own writer
              (meshio 5 does not read polydata); any other dataset (e.g. the      (polydata)
              ``UNSTRUCTURED_GRID`` meshio writes): meshio
    ``.vtu``  meshio (``<VTKFile``)                                                meshio
    ``.vtp``  :func:`ladders.study.meshes.vtk_xml.read_vtp` (``<VTKFile``;         --
              meshio does not read VTK XML PolyData)
    ``.ply``  meshio (``ply``)                                                     meshio, binary
    ``.off``  meshio when the header is ``OFF``; trimesh for its variants          trimesh
              (``COFF``, ``NOFF``, ...), which meshio does not read
    ``.obj``  trimesh (``process=False, maintain_order=True``): meshio 5 fails     trimesh
              on OBJ files with texture coordinates or normals
    ``.stl``  trimesh, then the float32 triangle soup is indexed                  trimesh
              (see :func:`merge_soup`)
    ========  ==================================================================  ==============

meshio cells other than triangles are refused, except points (``vertex``) and
lines, which are ignored as in legacy VTK files.
"""

from __future__ import annotations

import io
import warnings
from collections.abc import Callable
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import MeshFolderError
from .vtk_io import read_vtk, write_vtk
from .vtk_xml import read_vtp

__all__ = [
    "MeshFormat",
    "MESH_FORMATS",
    "reader_for",
    "read_with_meshio",
    "read_with_trimesh",
    "merge_soup",
    "vtk_dataset",
]

_IGNORED_CELLS = ("vertex", "line", "line3")
_HEAD_BYTES = 1024


def read_with_meshio(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of a file meshio reads; other cell types are refused."""
    import meshio

    said = io.StringIO()
    try:
        with warnings.catch_warnings(), redirect_stdout(said), redirect_stderr(said):
            warnings.simplefilter("ignore")
            mesh = meshio.read(path)
    except (Exception, SystemExit) as exc:  # meshio raises many types, or exits, on bad files
        reason = " ".join(said.getvalue().split()) or str(exc) or type(exc).__name__
        raise MeshFolderError(f"{path}: cannot be read as a mesh ({reason})") from exc
    triangles, others = [], {}
    for block in mesh.cells:
        if block.type == "triangle":
            triangles.append(np.asarray(block.data))
        elif block.type not in _IGNORED_CELLS:
            others[block.type] = others.get(block.type, 0) + len(block.data)
    if others:
        found = ", ".join(f"{n} {kind}" for kind, n in others.items())
        raise MeshFolderError(
            f"{path}: expected triangle cells only, found {found} cell(s); "
            "triangulate the mesh (e.g. ParaView's Triangulate filter) and save it again"
        )
    points = np.asarray(mesh.points, dtype=np.float64)
    if points.ndim == 2 and points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    faces = np.concatenate(triangles) if triangles else np.empty((0, 3), dtype=np.int64)
    return points, faces.astype(np.int64)


def read_with_trimesh(path: Path, faces=None) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles through trimesh with ``process=False`` (no merge, no reorder)."""
    import trimesh

    ext = path.suffix.lower()
    kwargs = {"maintain_order": True} if ext == ".obj" else {}
    try:
        mesh = trimesh.load_mesh(path, process=False, **kwargs)
        v, f = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces)
    except Exception as exc:  # trimesh raises many types on corrupt files
        raise MeshFolderError(f"{path}: cannot be read as a mesh ({exc})") from exc
    if ext == ".stl" and len(f):
        v, f = merge_soup(v[f.reshape(-1)], faces)
    return v, f.astype(np.int64)


def merge_soup(soup: np.ndarray, faces=None) -> tuple[np.ndarray, np.ndarray]:
    """Index a triangle soup ``(3f, 3)``: by reference ``faces`` or by first appearance.

    STL stores every triangle's corners (float32) with no vertex index. With the
    triangulation ``faces`` the file was written from, the original vertices and
    their order are restored; otherwise equal corners are merged and numbered in
    order of first appearance.
    """
    if faces is not None and len(faces) * 3 == len(soup):
        faces = np.asarray(faces, dtype=np.int64)
        vertices = np.zeros((int(faces.max()) + 1, 3))
        vertices[faces.ravel()] = soup
        if np.array_equal(vertices[faces.ravel()], soup):
            return vertices, faces
    _, first, inverse = np.unique(soup, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return soup[first[order]], rank[inverse.ravel()].reshape(-1, 3)


def vtk_dataset(path: Path) -> str:
    """The ``DATASET`` type of a legacy VTK file (``""`` when the header is not found)."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(1024)
    except OSError as exc:
        raise MeshFolderError(f"{path}: cannot be read ({exc})") from exc
    for line in head.split(b"\n")[3:6]:
        tokens = line.split()
        if len(tokens) >= 2 and tokens[0].upper() == b"DATASET":
            return tokens[1].decode("ascii", "replace").upper()
    return ""


def _head(path: Path) -> bytes:
    try:
        with open(path, "rb") as fh:
            return fh.read(_HEAD_BYTES)
    except OSError as exc:
        raise MeshFolderError(f"{path}: cannot be read ({exc})") from exc


def _expect(path: Path, head: bytes, marker: bytes, what: str) -> None:
    """Refuse a file whose header does not hold ``marker`` (the format's signature)."""
    found = head.lstrip()[: len(marker)] == marker if marker == b"ply" else marker in head
    if not found:
        raise MeshFolderError(
            f"{path}: cannot be read as a mesh (not a {what} file: it starts with "
            f"{head.lstrip()[:20]!r}, expected {marker!r})"
        )


def _vtk_reader(path: Path, head: bytes):
    _expect(path, head, b"# vtk DataFile", "legacy VTK")
    return read_vtk if vtk_dataset(path) == "POLYDATA" else read_with_meshio


def _off_reader(path: Path, head: bytes):
    first = head.lstrip().split(maxsplit=1)[:1]
    if not first or not first[0].endswith(b"OFF"):
        _expect(path, head, b"OFF", "OFF")
    return read_with_meshio if first[0] == b"OFF" else read_with_trimesh


def _with_header(marker: bytes, what: str, reader: Callable):
    def choose(path: Path, head: bytes):
        _expect(path, head, marker, what)
        return reader

    return choose


def _write_meshio(file_format: str):
    def write(path: Path, v: np.ndarray, f: np.ndarray) -> None:
        import meshio

        mesh = meshio.Mesh(v, [("triangle", f.astype(np.int32))])
        meshio.write(path, mesh, file_format=file_format, binary=True)

    return write


def _write_trimesh(path: Path, v: np.ndarray, f: np.ndarray) -> None:
    import trimesh
    from trimesh.exchange.obj import export_obj
    from trimesh.exchange.off import export_off

    mesh = trimesh.Trimesh(v, f, process=False)
    ext = path.suffix.lower()
    if ext == ".obj":
        path.write_text(
            export_obj(
                mesh,
                include_normals=False,
                include_color=False,
                include_texture=False,
                digits=17,
                header=None,
            )  # fmt: skip
        )
    elif ext == ".off":
        path.write_text(export_off(mesh, digits=17))
    else:
        mesh.export(path, file_type="stl")


@dataclass(frozen=True)
class MeshFormat:
    """One row of the registry.

    Attributes
    ----------
    name : str
    choose_reader : callable ``(path, header bytes) -> reader``
        Checks the header and returns ``reader(path, faces) -> (vertices, faces)``.
    write : callable ``(path, vertices, faces)``, or None when the format is read only
    """

    name: str
    choose_reader: Callable
    write: Callable | None = None


def _trimesh_only(path: Path, head: bytes):
    return read_with_trimesh


#: The formats, by extension: the single table of readers and writers.
MESH_FORMATS = {
    ".ply": MeshFormat("PLY", _with_header(b"ply", "PLY", read_with_meshio), _write_meshio("ply")),
    ".obj": MeshFormat("OBJ", _trimesh_only, _write_trimesh),
    ".stl": MeshFormat("STL", _trimesh_only, _write_trimesh),
    ".off": MeshFormat("OFF", _off_reader, _write_trimesh),
    ".vtk": MeshFormat("legacy VTK", _vtk_reader, lambda p, v, f: write_vtk(p, v, f)),
    ".vtu": MeshFormat(
        "VTK XML unstructured grid",
        _with_header(b"<VTKFile", "VTK XML", read_with_meshio),
        _write_meshio("vtu"),
    ),
    ".vtp": MeshFormat("VTK XML PolyData", _with_header(b"<VTKFile", "VTK XML", read_vtp)),
}


def reader_for(path: Path, faces=None) -> Callable[[], tuple[np.ndarray, np.ndarray]]:
    """The reader of ``path`` (by its extension and header), bound to the file.

    ``faces`` is used by the STL reader only (see :func:`merge_soup`).
    """
    fmt = MESH_FORMATS[path.suffix.lower()]
    reader = fmt.choose_reader(path, _head(path))
    if reader is read_with_trimesh:
        return lambda: read_with_trimesh(path, faces)
    return lambda: reader(path)
