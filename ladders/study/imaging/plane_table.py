"""The cut-plane table: a plane per image (and per frame of a series) that trims its surface.

A CSV table with the columns ``image,x,y,z,nx,ny,nz`` and an optional ``frame``
column (0-based): ``image`` names an image file (its name or its path as given) or,
for a series, its subject or its series' file name; ``x,y,z`` is a point of the plane
and ``nx,ny,nz`` its normal, in world mm (e.g. the valve plane, the part beyond it
removed). A row without a frame holds for every frame of its image; a row with one,
for that frame only (e.g. the valve plane moving with the base, as
``symladders cohort --cycle`` writes ``valve_planes.csv``). ``symladders mesh`` and
``symladders track`` read it with :func:`read_plane_table` (and :func:`write_plane_table`
writes it, as ``symladders cohort --cycle`` and ``symladders track`` do); a second row for one image
and frame, a non-numeric value, a column the table does not have and, with
:func:`check_plane_table`, an image that is not given or a frame beyond its series are
refused in one line naming the file, the line and the column.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Mapping
from pathlib import Path

from ladders.tables import Column, Table, read_table

from ..files import atomic_write_text

__all__ = [
    "PLANE_COLUMNS",
    "PLANES_FILE",
    "read_plane_table",
    "write_plane_table",
    "check_plane_table",
    "planes_by_image",
    "plane_for",
    "image_names",
]

#: The per-frame valve planes of a series, as a cut-plane table: the synthetic cohort's
#: truth (``symladders cohort --cycle``), the planes ``symladders track`` estimates.
PLANES_FILE = "valve_planes.csv"

#: The columns of a cut-plane table (``frame`` optional: empty or absent for every frame).
PLANE_COLUMNS = (
    Column("image"),
    *(Column(name, "number") for name in ("x", "y", "z", "nx", "ny", "nz")),
    Column("frame", "frame", required=False),
)


def read_plane_table(path) -> Table:
    """The rows of a cut-plane table (see the module), each image and frame once.

    Raises
    ------
    ladders.tables.TableError
        One line naming the file, the line and the column.
    """
    return read_table(path, PLANE_COLUMNS, what="cut-plane table", key=("image", "frame"))


def write_plane_table(path, planes: Mapping) -> Path:
    """Write ``{image: {frame: (x, y, z, nx, ny, nz)}}`` as a cut-plane table.

    One row per image and frame, columns ``image,frame,x,y,z,nx,ny,nz`` (world mm), what
    :func:`read_plane_table` reads; written atomically. Returns the path.
    """
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["image", "frame", "x", "y", "z", "nx", "ny", "nz"])
    for image, frames in planes.items():
        for frame, plane in frames.items():
            writer.writerow([image, frame, *(f"{float(x):.6f}" for x in plane)])
    atomic_write_text(Path(path), buffer.getvalue())
    return Path(path)


def check_plane_table(table: Table, frames: Mapping[str, int | None]) -> None:
    """Refuse a row naming no image of ``frames`` or a frame outside its image's series.

    Parameters
    ----------
    table : Table
        Of :func:`read_plane_table`.
    frames : mapping
        ``{name: frame count}`` of every name an image may be given by (file name, path,
        subject); ``None`` or 1 for a 3-D image (only frame 0, or no frame).

    Raises
    ------
    ladders.tables.TableError
    """
    table.refuse_unknown("image", frames, what="image")
    limits = {name: 1 if n is None else int(n) for name, n in frames.items()}
    table.refuse_beyond("frame", limits, key="image", what="image")


def planes_by_image(table: Table) -> dict[str, dict[str, tuple]]:
    """``{image: {frame or "all": (x, y, z, nx, ny, nz)}}`` of a cut-plane table."""
    planes: dict[str, dict[str, tuple]] = {}
    for row in table.rows:
        frame = "all" if row["frame"] is None else str(row["frame"])
        planes.setdefault(row["image"], {})[frame] = tuple(
            float(row[k]) for k in ("x", "y", "z", "nx", "ny", "nz")
        )
    return planes


def plane_for(planes: Mapping | None, names, frame: int | None) -> tuple | None:
    """The plane of an image known by ``names`` at ``frame`` (its own, else its "all"), or None."""
    if not planes:
        return None
    entry = next((planes[n] for n in names if n in planes), None)
    if entry is None:
        return None
    if not isinstance(entry, Mapping):  # one plane for every frame
        return tuple(entry)
    plane = entry.get(str(frame), entry.get("all")) if frame is not None else entry.get("all")
    if plane is None and frame is None:
        plane = entry.get("0")
    return None if plane is None else tuple(plane)


def image_names(path) -> list[str]:
    """The names a cut-plane table may give an image file by: its file name, its path, and
    its subject (the name without ``.nii.gz``, as ``symladders mesh`` names its meshes)."""
    from .label_images import image_stem

    path = Path(path)
    return [path.name, str(path), image_stem(path)]
