"""A cohort listed in a CSV table instead of named by the folder layout.

The table has a header row with (at least) the columns ``subject``, ``ed`` and
``es``, in any order and any letter case; ``ed`` and ``es`` are paths of the
end-diastole and end-systole meshes, absolute or relative to the table's
folder::

    subject,ed,es
    patient01,scans/p01/frame_00.vtp,scans/p01/frame_09.vtp
    patient02,scans/p02/frame_00.vtp,scans/p02/frame_11.vtp

Subjects keep the table's order. The atlas is given by ``atlas=PATH`` or is the
``atlas.<ext>`` file next to the table.
"""

from __future__ import annotations

from pathlib import Path

from ladders.tables import Column, read_table

from ..errors import MeshFolderError, MissingAtlasError
from ..meshes.mesh_io import MESH_EXTENSIONS, OTHER_MESH_EXTENSIONS
from .cohort import Cohort
from .mesh_folder import assemble_cohort, warn_unused

__all__ = ["read_cohort_table", "COHORT_COLUMNS"]

#: The columns of a cohort table (no other: it would be ignored).
COHORT_COLUMNS = (Column("subject"), Column("ed"), Column("es"))


def _rows(table: Path) -> list[tuple[int, dict[str, str]]]:
    """``(line, row)`` of every subject of the table (:func:`ladders.tables.read_table`)."""
    rows = read_table(table, COHORT_COLUMNS, what="cohort table", key=("subject",),
                      error=MeshFolderError)  # fmt: skip
    return list(zip(rows.lines, rows.rows))


def _mesh_path(table: Path, line: int, value: str, column: str) -> Path:
    path = Path(value).expanduser()
    path = path if path.is_absolute() else table.parent / path
    if path.suffix.lower() not in MESH_EXTENSIONS:
        raise MeshFolderError(
            f"cohort table {table}, line {line}, column {column!r}: {path} has an "
            f"unsupported extension, expected one of {MESH_EXTENSIONS}"
        )
    if not path.is_file():
        raise MeshFolderError(
            f"cohort table {table}, line {line}, column {column!r}: {path} does not exist"
        )
    return path


def _atlas_next_to(table: Path) -> Path:
    found = [
        p for p in sorted(table.parent.iterdir())
        if p.stem.lower() == "atlas" and p.suffix.lower() in MESH_EXTENSIONS
    ]  # fmt: skip
    if len(found) != 1:
        what = "no" if not found else f"{len(found)} ({', '.join(p.name for p in found)})"
        raise MissingAtlasError(f"{table}: {what} atlas file 'atlas.<ext>' next to the table")
    return found[0]


def _unused(table: Path, used: set[Path]) -> list[tuple[Path, str]]:
    """Mesh files in the table's folder and its direct subfolders that the cohort leaves out."""
    candidates = []
    for path in sorted(table.parent.iterdir()):
        if path.is_dir() and not path.name.startswith("."):
            candidates.extend(sorted(path.iterdir()))
        else:
            candidates.append(path)
    unused = []
    for path in candidates:
        ext = path.suffix.lower()
        if path.name.startswith(".") or not path.is_file() or path.resolve() in used:
            continue
        if ext in MESH_EXTENSIONS:
            unused.append((path, f"not in {table.name}"))
        elif ext in OTHER_MESH_EXTENSIONS:
            unused.append((path, "format not read"))
    return unused


def read_cohort_table(table, atlas=None) -> Cohort:
    """Read the cohort listed in a CSV table (format in the module docstring).

    Parameters
    ----------
    table : str or Path
        CSV file with the columns ``subject``, ``ed``, ``es``.
    atlas : str or Path, optional
        The atlas mesh; default: the one ``atlas.<ext>`` next to the table.

    Returns
    -------
    Cohort
        Subjects in the table's order; ``source`` is the table's path.

    Warns
    -----
    UnusedMeshFilesWarning
        Lists the mesh files of the table's folder (and of its direct
        subfolders) that neither the table nor the atlas uses.

    Raises
    ------
    MeshFolderError
        A missing table or column, an empty or duplicated subject name, a
        missing mesh file (naming the table's line), or meshes that do not
        correspond to the atlas (naming the file).
    """
    table = Path(table)
    if not table.is_file():
        raise MeshFolderError(f"{table}: no such cohort table")
    entries: dict[str, dict[str, Path]] = {}
    for line, row in _rows(table):
        name = row["subject"]
        if any(c in name for c in "/\\") or name in (".", ".."):
            raise MeshFolderError(
                f"cohort table {table}, line {line}, column 'subject': {name!r} must not be a path "
                "(it names the subject's result files)"
            )
        entries[name] = {c: _mesh_path(table, line, row[c], c) for c in ("ed", "es")}
    atlas_path = Path(atlas) if atlas is not None else _atlas_next_to(table)
    if not atlas_path.is_file():
        raise MeshFolderError(f"{atlas_path}: no such atlas file")
    used = {atlas_path.resolve()} | {p.resolve() for s in entries.values() for p in s.values()}
    warn_unused(_unused(table, used))
    return assemble_cohort(atlas_path, entries, source=str(table))
