"""The readers behind :func:`ladders.study.meshes.mesh_io.read_mesh`, one per library, and their choice.

Every format is read so that vertex ``i`` of the file is vertex ``i`` of the
returned array (no merging, no reordering), since a study's meshes are in
vertex correspondence through their vertex order:

========  =========================================================================
``.vtk``  legacy VTK: ``DATASET POLYDATA`` by :func:`ladders.study.meshes.vtk_io.read_vtk`
          (meshio 5 does not read polydata), every other dataset (e.g. the
          ``UNSTRUCTURED_GRID`` meshio writes) by meshio
``.vtu``  meshio
``.vtp``  :func:`ladders.study.meshes.vtk_xml.read_vtp` (meshio does not read VTK XML PolyData)
``.ply``  meshio, then trimesh if meshio fails
``.off``  meshio, then trimesh if meshio fails
``.obj``  trimesh (``process=False, maintain_order=True``), then meshio: meshio 5
          fails on OBJ files with texture coordinates or normals
``.stl``  trimesh, then the float32 triangle soup is indexed (see :func:`merge_soup`)
========  =========================================================================

meshio cells other than triangles are refused, except points (``vertex``) and
lines, which are ignored as in legacy VTK files.
"""

from __future__ import annotations

import io
import warnings
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np

from ..errors import MeshFolderError

__all__ = ["read_with_meshio", "read_with_trimesh", "merge_soup", "vtk_dataset"]

_IGNORED_CELLS = ("vertex", "line", "line3")


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


def read_first(path: Path, readers) -> tuple[np.ndarray, np.ndarray]:
    """The result of the first of ``readers`` (``(label, function)`` pairs) that succeeds.

    A file one reader reads but refuses (e.g. quadrilateral cells) raises that
    reader's error; a file none can parse raises one error naming every cause.
    """
    causes = []
    for label, reader in readers:
        try:
            return reader(path)
        except MeshFolderError as exc:
            text = str(exc).removeprefix(f"{path}: ")
            if not text.startswith("cannot be read as a mesh ("):
                raise
            causes.append(f"{label}: {text.removeprefix('cannot be read as a mesh (')[:-1]}")
    raise MeshFolderError(f"{path}: cannot be read as a mesh ({'; '.join(causes)})")
