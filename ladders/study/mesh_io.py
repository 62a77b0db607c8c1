"""Read and write cohorts of corresponding triangle meshes (PLY, OBJ, STL, OFF, legacy VTK).

Folder layout read by :func:`read_cohort` (details in ``docs/cohort.md``)::

    meshes/
        atlas.vtk                 population atlas T
        subject001_ed.vtk         end-diastole S of subject "subject001"
        subject001_es.vtk         end-systole S' of subject "subject001"
        subject002/ed.ply         or one subfolder per subject
        subject002/es.ply

Every mesh must have the atlas's vertex count and faces, in the same vertex
order: vertex ``i`` of every file is the same anatomical point. PLY, OBJ and
OFF are read through trimesh with ``process=False`` so that no vertex is merged
or reordered. STL stores a triangle soup in float32: its vertices are merged
back in order of first appearance in the faces (or, for a subject, by the
atlas's faces), which restores the vertex order of files written from the same
triangulation. Legacy VTK polydata (``DATASET POLYDATA``, ASCII or binary,
file versions 2 to 5) is read by a small reader of this module.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import trimesh
from trimesh.exchange.obj import export_obj
from trimesh.exchange.off import export_off

from .cohort import Cohort, MeshFolderError, Subject
from .vtk_io import read_vtk, write_vtk

__all__ = [
    "MESH_EXTENSIONS",
    "MeshFolderError",
    "read_mesh",
    "write_mesh",
    "read_vtk",
    "write_vtk",
    "read_cohort",
    "write_cohort",
]

MESH_EXTENSIONS = (".ply", ".obj", ".stl", ".off", ".vtk")


def _merge_soup(soup: np.ndarray, faces=None) -> tuple[np.ndarray, np.ndarray]:
    """Index a triangle soup ``(3f, 3)``: by reference ``faces`` or by first appearance."""
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


def read_mesh(path, faces=None) -> tuple[np.ndarray, np.ndarray]:
    """Read one triangle mesh, keeping the file's vertex order.

    Parameters
    ----------
    path : str or Path
        A ``.ply``, ``.obj``, ``.off``, ``.stl`` or ``.vtk`` file.
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
    if ext == ".vtk":
        v, f = read_vtk(path)
    else:
        kwargs = {"maintain_order": True} if ext == ".obj" else {}
        try:
            mesh = trimesh.load_mesh(path, process=False, **kwargs)
            v, f = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces)
        except Exception as exc:  # trimesh raises many types on corrupt files
            raise MeshFolderError(f"{path}: cannot be read as a mesh ({exc})") from exc
        if ext == ".stl" and len(f):
            v, f = _merge_soup(v[f.reshape(-1)], faces)
    if len(v) == 0 or len(f) == 0:
        raise MeshFolderError(f"{path}: cannot be read as a triangle mesh (no vertices or faces)")
    if not np.isfinite(v).all():
        raise MeshFolderError(f"{path}: contains NaN or infinite coordinates")
    if f.min() < 0 or f.max() >= len(v):
        raise MeshFolderError(f"{path}: face indices out of range [0, {len(v)})")
    return v, f.astype(np.int64)


def write_mesh(path, vertices, faces) -> Path:
    """Write a triangle mesh; the format follows the extension (see ``MESH_EXTENSIONS``).

    PLY is written as binary little-endian with double coordinates, OBJ and OFF
    with 17 significant digits, VTK as ASCII legacy polydata, STL as binary
    float32 (the format's only precision).
    """
    path = Path(path)
    ext = path.suffix.lower()
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if ext == ".vtk":
        return write_vtk(path, v, f)
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
        raise MeshFolderError(f"{path}: unsupported extension, expected one of {MESH_EXTENSIONS}")
    return path


# --------------------------------------------------------------------------- folders
def _natural_key(name: str):
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", name)]


def _scan(folder: Path) -> tuple[Path | None, dict[str, dict[str, Path]]]:
    atlas, subjects = None, {}

    def add(name: str, phase: str, path: Path):
        if not name:
            raise MeshFolderError(f"{path}: empty subject name")
        slot = subjects.setdefault(name, {})
        if phase in slot:
            raise MeshFolderError(
                f"subject {name!r}: two {phase.upper()} files, {slot[phase]} and {path}"
            )
        slot[phase] = path

    for path in sorted(folder.iterdir()):
        if path.name.startswith("."):
            continue
        if path.is_dir():
            for inner in sorted(path.iterdir()):
                if inner.suffix.lower() not in MESH_EXTENSIONS or inner.name.startswith("."):
                    continue
                phase = inner.stem.lower()
                if phase not in ("ed", "es"):
                    raise MeshFolderError(
                        f"{inner}: expected 'ed.<ext>' or 'es.<ext>' in a subject folder"
                    )
                add(path.name, phase, inner)
            continue
        if path.suffix.lower() not in MESH_EXTENSIONS:
            continue
        stem = path.stem
        if stem.lower() == "atlas":
            if atlas is not None:
                raise MeshFolderError(f"two atlas files: {atlas} and {path}")
            atlas = path
        elif stem[-3:].lower() in ("_ed", "_es"):
            add(stem[:-3], stem[-2:].lower(), path)
        else:
            raise MeshFolderError(
                f"{path}: name does not follow the layout 'atlas.<ext>', '<name>_ed.<ext>', "
                "'<name>_es.<ext>'"
            )
    return atlas, subjects


def read_cohort(folder, atlas=None) -> Cohort:
    """Read a folder of meshes into a :class:`~ladders.cohort.Cohort`.

    Parameters
    ----------
    folder : str or Path
        Folder with ``atlas.<ext>`` and, per subject, ``<name>_ed.<ext>`` and
        ``<name>_es.<ext>`` (or a subfolder ``<name>/`` with ``ed.<ext>``, ``es.<ext>``).
        Subjects are ordered by natural sort of their names.
    atlas : str or Path, optional
        Atlas file to use instead of ``folder/atlas.<ext>``.

    Raises
    ------
    MeshFolderError
        Missing folder or atlas, a subject without ED or ES, an unreadable file,
        or a mesh whose vertex count or faces differ from the atlas's.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise MeshFolderError(f"{folder}: not a folder")
    found_atlas, entries = _scan(folder)
    atlas_path = Path(atlas) if atlas is not None else found_atlas
    if atlas_path is None:
        raise MeshFolderError(
            f"{folder}: no atlas file 'atlas.<ext>' ({', '.join(MESH_EXTENSIONS)})"
        )
    if not entries:
        raise MeshFolderError(f"{folder}: no subject files '<name>_ed.<ext>' / '<name>_es.<ext>'")
    atlas_v, faces = read_mesh(atlas_path)
    subjects = []
    for name in sorted(entries, key=_natural_key):
        slot = entries[name]
        for phase in ("ed", "es"):
            if phase not in slot:
                other = next(iter(slot.values()))
                raise MeshFolderError(
                    f"subject {name!r}: no {phase.upper()} mesh (found {other.name}; expected "
                    f"'{name}_{phase}.<ext>' or '{name}/{phase}.<ext>')"
                )
        shapes = {}
        for phase in ("ed", "es"):
            path = slot[phase]
            v, f = read_mesh(path, faces=faces)
            if len(v) != len(atlas_v):
                raise MeshFolderError(
                    f"{path} has {len(v)} vertices but the atlas {atlas_path} has {len(atlas_v)}: "
                    "the meshes are not in vertex correspondence"
                )
            if f.shape != faces.shape or not np.array_equal(f, faces):
                raise MeshFolderError(
                    f"{path}: faces differ from those of the atlas {atlas_path} "
                    "(every mesh must share the atlas's triangulation and vertex order)"
                )
            shapes[phase] = v
        subjects.append(Subject(name, shapes["ed"], shapes["es"]))
    return Cohort(atlas_v, faces, subjects, source=str(folder))


def write_cohort(cohort: Cohort, folder, ext: str = "ply", layout: str = "flat") -> Path:
    """Write ``cohort`` in the layout read by :func:`read_cohort`.

    Parameters
    ----------
    cohort : Cohort
    folder : str or Path
        Created if needed; existing files with the same names are overwritten.
    ext : str
        One of ``ply``, ``obj``, ``off``, ``stl``, ``vtk``.
    layout : {"flat", "subfolders"}
        ``<name>_ed.<ext>`` next to the atlas, or ``<name>/ed.<ext>``.

    Returns
    -------
    Path
        The folder.
    """
    ext = "." + ext.lower().lstrip(".")
    if ext not in MESH_EXTENSIONS:
        raise MeshFolderError(f"ext: expected one of {MESH_EXTENSIONS}, got {ext!r}")
    if layout not in ("flat", "subfolders"):
        raise MeshFolderError(f"layout: expected 'flat' or 'subfolders', got {layout!r}")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    write_mesh(folder / f"atlas{ext}", cohort.atlas, cohort.faces)
    for s in cohort.subjects:
        for phase, v in (("ed", s.ed), ("es", s.es)):
            if layout == "flat":
                target = folder / f"{s.name}_{phase}{ext}"
            else:
                (folder / s.name).mkdir(exist_ok=True)
                target = folder / s.name / f"{phase}{ext}"
            write_mesh(target, v, cohort.faces)
    return folder
