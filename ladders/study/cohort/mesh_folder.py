"""Cohorts as folders of mesh files: the layout read by :func:`read_cohort`, written by :func:`write_cohort`.

Folder layout (details in ``docs/cohort.md``)::

    meshes/
        atlas.vtk                 population atlas T
        subject001_ed.vtk         end-diastole S of subject "subject001"
        subject001_es.vtk         end-systole S' of subject "subject001"
        subject002/ed.ply         or one subfolder per subject
        subject002/es.ply
        epicardium/               not a subject: the epicardia ``symladders mesh
                                  --myocardium-label`` writes beside the meshes

Every mesh must have the atlas's vertex count and faces, in the same vertex
order (:func:`assemble_cohort` checks it); single files are read and written by
:mod:`ladders.study.meshes`.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from ..errors import MeshFolderError, MissingAtlasError
from ..meshes.mesh_io import (
    MESH_EXTENSIONS,
    OTHER_MESH_EXTENSIONS,
    WRITE_EXTENSIONS,
    read_mesh,
    write_mesh,
)
from .cohort import Cohort, Subject

__all__ = [
    "EPICARDIUM_FOLDER",
    "UnusedMeshFilesWarning",
    "read_cohort",
    "assemble_cohort",
    "warn_unused",
    "write_cohort",
    "scan_mesh_folder",
    "natural_key",
]


#: The sub-folder of a mesh folder (``symladders mesh --myocardium-label``) or of a tracked
#: subject's folder (``symladders track``) that holds the epicardia; not a subject's.
EPICARDIUM_FOLDER = "epicardium"


class UnusedMeshFilesWarning(UserWarning):
    """Files with a mesh extension next to a cohort that the cohort does not use."""


def natural_key(name: str):
    """Sort key of subject names with numbers in numeric order (``s2`` before ``s10``)."""
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", name)]


def scan_mesh_folder(folder: Path) -> tuple[Path | None, dict[str, dict[str, Path]], list[Path]]:
    """Atlas, ``{subject: {phase: path}}`` and the files of formats not read."""
    atlas, subjects, other = None, {}, []

    def add(name: str, phase: str, path: Path):
        if not name:
            raise MeshFolderError(f"{path}: empty subject name")
        slot = subjects.setdefault(name, {})
        if phase in slot:
            raise MeshFolderError(
                f"subject {name!r}: two {phase.upper()} files, {slot[phase]} and {path}"
            )
        slot[phase] = path

    def usable(path: Path) -> bool:
        if path.name.startswith(".") or not path.is_file():
            return False
        if path.suffix.lower() in OTHER_MESH_EXTENSIONS:
            other.append(path)
        return path.suffix.lower() in MESH_EXTENSIONS

    for path in sorted(folder.iterdir()):
        if path.name.startswith("."):
            continue
        if path.is_dir():
            if path.name == EPICARDIUM_FOLDER:
                continue
            for inner in sorted(path.iterdir()):
                if not usable(inner):
                    continue
                phase = inner.stem.lower()
                if phase not in ("ed", "es"):
                    raise MeshFolderError(
                        f"{inner}: expected 'ed.<ext>' or 'es.<ext>' in a subject folder"
                    )
                add(path.name, phase, inner)
            continue
        if not usable(path):
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
    return atlas, subjects, other


def warn_unused(unused: list[tuple[Path, str]]) -> None:
    """Warn (:class:`UnusedMeshFilesWarning`) about files with a mesh extension left out."""
    if not unused:
        return
    listed = "; ".join(f"{path} ({why})" for path, why in unused[:20])
    more = f"; and {len(unused) - 20} more" if len(unused) > 20 else ""
    warnings.warn(
        f"{len(unused)} mesh file(s) not used: {listed}{more}", UnusedMeshFilesWarning, stacklevel=3
    )


def assemble_cohort(atlas_path: Path, entries: dict, source: str) -> Cohort:
    """Read the atlas and every subject's ED and ES files, checking their correspondence.

    ``entries`` maps subject names, in cohort order, to ``{"ed": path, "es": path}``.
    """
    atlas_v, faces = read_mesh(atlas_path)
    subjects = []
    for name, slot in entries.items():
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
        subjects.append(Subject(name, shapes["ed"], shapes["es"], files=(slot["ed"], slot["es"])))
    return Cohort(atlas_v, faces, subjects, source=source, atlas_file=atlas_path)


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

    Warns
    -----
    UnusedMeshFilesWarning
        Lists the files of the folder (and of its subject subfolders) with the
        extension of a mesh format that is not read (:data:`OTHER_MESH_EXTENSIONS`),
        and ``atlas.<ext>`` when another atlas is given.

    Raises
    ------
    MeshFolderError
        Missing folder or atlas, a subject without ED or ES, an unreadable file,
        or a mesh whose vertex count or faces differ from the atlas's.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise MeshFolderError(f"{folder}: not a folder")
    found_atlas, entries, other = scan_mesh_folder(folder)
    atlas_path = Path(atlas) if atlas is not None else found_atlas
    if atlas_path is None:
        raise MissingAtlasError(
            f"{folder}: no atlas file 'atlas.<ext>' ({', '.join(MESH_EXTENSIONS)})"
        )
    if not entries:
        raise MeshFolderError(f"{folder}: no subject files '<name>_ed.<ext>' / '<name>_es.<ext>'")
    for name, slot in entries.items():
        for phase in ("ed", "es"):
            if phase not in slot:
                found = next(iter(slot.values()))
                raise MeshFolderError(
                    f"subject {name!r}: no {phase.upper()} mesh (found {found.name}; expected "
                    f"'{name}_{phase}.<ext>' or '{name}/{phase}.<ext>')"
                )
    unused = [(p, "format not read") for p in other]
    if (
        found_atlas is not None
        and atlas is not None
        and found_atlas.resolve() != atlas_path.resolve()
    ):
        unused.append((found_atlas, f"the atlas given is {atlas_path}"))
    warn_unused(unused)
    ordered = {name: entries[name] for name in sorted(entries, key=natural_key)}
    return assemble_cohort(atlas_path, ordered, source=str(folder))


def write_cohort(cohort: Cohort, folder, ext: str = "ply", layout: str = "flat") -> Path:
    """Write ``cohort`` in the layout read by :func:`read_cohort`.

    Parameters
    ----------
    cohort : Cohort
    folder : str or Path
        Created if needed; existing files with the same names are overwritten.
    ext : str
        One of ``ply``, ``obj``, ``off``, ``stl``, ``vtk``, ``vtu``.
    layout : {"flat", "subfolders"}
        ``<name>_ed.<ext>`` next to the atlas, or ``<name>/ed.<ext>``.

    Returns
    -------
    Path
        The folder.
    """
    ext = "." + ext.lower().lstrip(".")
    if ext not in WRITE_EXTENSIONS:
        raise MeshFolderError(f"ext: expected one of {WRITE_EXTENSIONS}, got {ext!r}")
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
