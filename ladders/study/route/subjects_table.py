"""The subjects table: one row per subject, the one description of a study's inputs.

A CSV file with a header line and one row per subject:

* ``subject`` (required): the subject's name, unique; it names every file the route
  writes for the subject (letters, digits, ``-``, ``_`` and ``.``);
* the images, either ``image`` (a 4-D label series, frames on the fourth axis; with
  three frames or more the subject is also tracked through the cycle) or ``ed_image``
  and ``es_image`` (two 3-D label images of one grid); paths relative to the table's
  folder or absolute;
* ``ed_frame`` and ``es_frame`` (optional, with ``image``, 0-based): end-diastole and
  end-systole. Empty cells take the defaults: ED at frame 0 and ES at the frame of
  least cavity volume (chosen when the series is meshed, and recorded);
* ``apex_x`` ... ``septum_z`` (optional, all nine or none): the subject's apex,
  base-plane centre and septal point in the image's world millimetres; without them,
  the landmarks come from the right ventricle's label when the settings name it;
* ``group`` and any other column: the covariates of the linear model (numbers, or
  categories such as ``sex``). A column the model would not use is refused unless the
  settings list it under ``ignore``.

:func:`read_subjects_table` refuses, in one line naming the file, the line and the
column, whatever it cannot use: a missing or duplicate subject, a missing image, both
or neither kind of image, a frame that is not a whole number or lies outside the
series, an incomplete landmark, an empty covariate.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ladders.tables import Column, Table, TableError, read_table

from ..errors import CohortError
from ..preparation.landmarks import LANDMARK_COLUMNS

__all__ = [
    "SubjectsTableError",
    "SubjectEntry",
    "SubjectsTable",
    "read_subjects_table",
    "IMAGE_COLUMNS",
    "FRAME_COLUMNS",
]

#: The columns naming a subject's images.
IMAGE_COLUMNS = ("image", "ed_image", "es_image")
#: The columns naming a series' end-diastolic and end-systolic frames.
FRAME_COLUMNS = ("ed_frame", "es_frame")
_LANDMARK_COLUMNS = LANDMARK_COLUMNS[1:]
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


class SubjectsTableError(CohortError):
    """A subjects table that cannot be used; the message names the file, line and column."""


@dataclass(frozen=True)
class SubjectEntry:
    """One row of the subjects table.

    Attributes
    ----------
    subject : str
    line : int
        The row's line in the file (the header is line 1).
    series : Path or None
        The 4-D label series (``image``), absolute.
    ed_image, es_image : Path or None
        The two 3-D label images, absolute.
    n_frames : int
        Frames of the series (2 for a pair of 3-D images).
    ed_frame, es_frame : int or None
        The frames given (None: the default).
    landmarks : ndarray, shape (3, 3), or None
        Rows apex, base-plane centre, septal point (mm), when the table gives them.
    covariates : dict of str to str
        The covariate cells, as written.
    """

    subject: str
    line: int
    series: Path | None
    ed_image: Path | None
    es_image: Path | None
    n_frames: int
    ed_frame: int | None = None
    es_frame: int | None = None
    landmarks: np.ndarray | None = None
    covariates: dict = field(default_factory=dict)

    @property
    def tracked(self) -> bool:
        """True for a series of three frames or more: the subject is followed through it."""
        return self.series is not None and self.n_frames >= 3


@dataclass(frozen=True)
class SubjectsTable:
    """A read and checked subjects table.

    Attributes
    ----------
    path : Path
    entries : list of SubjectEntry
        In the file's order.
    covariates : list of str
        The covariate columns in the file's order (``group`` among them when present).
    ignored : list of str
        The columns the settings said to ignore.
    """

    path: Path
    entries: list
    covariates: list
    ignored: list = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.entries)

    @property
    def subjects(self) -> list[str]:
        return [e.subject for e in self.entries]

    @property
    def tracked(self) -> list[SubjectEntry]:
        """The subjects with a series of three frames or more."""
        return [e for e in self.entries if e.tracked]

    @property
    def has_landmarks(self) -> bool:
        return any(e.landmarks is not None for e in self.entries)

    def column(self, name: str) -> list[str]:
        """A covariate column, one cell per subject."""
        return [e.covariates[name] for e in self.entries]

    def entry(self, subject: str) -> SubjectEntry:
        for e in self.entries:
            if e.subject == subject:
                return e
        raise KeyError(subject)


_COLUMNS = (
    Column("subject"),
    *(Column(c, required=False) for c in IMAGE_COLUMNS),
    *(Column(c, "frame", required=False) for c in FRAME_COLUMNS),
    *(Column(c, "number", required=False) for c in _LANDMARK_COLUMNS),
)


def _frames_of(path: Path) -> int:
    """The frame count of a NIfTI file from its header (1 for a 3-D image)."""
    import nibabel as nib

    shape = nib.load(str(path)).shape
    if len(shape) == 3:
        return 1
    if len(shape) == 4:
        return int(shape[3])
    raise ValueError(f"expected a 3-D image or a 4-D series, got {len(shape)} dimensions")


class _Row:
    """One row being checked: its cells and a way to refuse it naming its line."""

    def __init__(self, table: Table, index: int):
        self.table, self.index, self.cells = table, index, table.rows[index]

    def fail(self, column: str | None, problem: str):
        raise SubjectsTableError(str(self.table.error(self.index, column, problem)))

    def image(self, column: str) -> tuple[Path, int]:
        cell = self.cells[column]
        path = Path(cell).expanduser()
        path = path if path.is_absolute() else self.table.path.parent / path
        if not path.is_file():
            self.fail(column, f"{cell!r}: {'a folder' if path.is_dir() else 'no such file'}")
        if not path.name.lower().endswith((".nii", ".nii.gz")):
            self.fail(column, f"{cell!r}: expected a NIfTI file (.nii or .nii.gz)")
        try:
            return path.resolve(), _frames_of(path)
        except Exception as exc:  # noqa: BLE001 - nibabel raises many kinds for a bad file
            self.fail(column, f"{cell!r}: cannot be read as NIfTI ({exc})")


def _images(row: _Row):
    """``(series, ed_image, es_image, n_frames)`` of a row."""
    cells = row.cells
    if cells["image"]:
        if cells["ed_image"] or cells["es_image"]:
            row.fail("ed_image" if cells["ed_image"] else "es_image",
                     "give either 'image' (a 4-D series) or 'ed_image' and 'es_image' (two 3-D "
                     "images), not both")  # fmt: skip
        series, n_frames = row.image("image")
        if n_frames < 2:
            row.fail("image", f"{cells['image']!r} is a 3-D image: a series has its frames on "
                              "a fourth axis; two 3-D images go in 'ed_image' and 'es_image'")  # fmt: skip
        return series, None, None, n_frames
    if not (cells["ed_image"] or cells["es_image"]):
        row.fail("image", "no image: give 'image' (a 4-D series) or 'ed_image' and 'es_image'")
    for column in ("ed_image", "es_image"):
        if not cells[column]:
            row.fail(column, "empty: 'ed_image' and 'es_image' go together")
    images = []
    for column in ("ed_image", "es_image"):
        path, n = row.image(column)
        if n != 1:
            row.fail(column, f"a 4-D series of {n} frames: give it in 'image'")
        images.append(path)
    return None, *images, 2


def _entry(row: _Row, covariates: list[str]) -> SubjectEntry:
    cells = row.cells
    subject = cells["subject"]
    if not _NAME.match(subject):
        row.fail("subject", f"{subject!r}: a subject's name must start with a letter or digit "
                            "and hold only letters, digits, '-', '_' and '.'")  # fmt: skip
    series, ed, es, n_frames = _images(row)
    for column in FRAME_COLUMNS:
        frame = cells[column]
        if frame is None:
            continue
        if series is None:
            row.fail(column, "a frame goes with a series in 'image'")
        if frame >= n_frames:
            row.fail(column, f"frame {frame} outside the series' {n_frames} frames (0 to "
                             f"{n_frames - 1})")  # fmt: skip
    if cells["ed_frame"] is not None and cells["ed_frame"] == cells["es_frame"]:
        row.fail("es_frame", f"the same frame as ed_frame ({cells['ed_frame']})")
    points = [cells[c] for c in _LANDMARK_COLUMNS]
    landmarks = None
    if any(p is not None for p in points):
        missing = next((c for c, p in zip(_LANDMARK_COLUMNS, points) if p is None), None)
        if missing is not None:
            row.fail(missing, "empty: a landmark needs all nine cells, or none")
        landmarks = np.array(points, float).reshape(3, 3)
    values = {}
    for column in covariates:
        if not cells[column]:
            row.fail(column, "empty covariate: fill it, or leave the subject out of the table")
        values[column] = cells[column]
    return SubjectEntry(subject, row.table.lines[row.index], series, ed, es, n_frames,
                        cells["ed_frame"], cells["es_frame"], landmarks, values)  # fmt: skip


def read_subjects_table(path, ignore=()) -> SubjectsTable:
    """Read and check a subjects table (see the module).

    Parameters
    ----------
    path : path
        The CSV file.
    ignore : sequence of str
        Columns to leave out (neither covariates nor refused).

    Raises
    ------
    SubjectsTableError
        One line naming the file, the line and the column.
    """
    path = Path(path)
    try:
        table = read_table(path, _COLUMNS, what="subjects table", key=("subject",), extra=True)
    except TableError as exc:
        raise SubjectsTableError(str(exc)) from None
    present = [c for c in _LANDMARK_COLUMNS if c in table.columns]
    if present and len(present) != len(_LANDMARK_COLUMNS):
        missing = next(c for c in _LANDMARK_COLUMNS if c not in table.columns)
        raise SubjectsTableError(f"subjects table {path}, line 1, column {missing!r}: missing: "
                                 f"the landmarks need all nine columns "
                                 f"{', '.join(_LANDMARK_COLUMNS)}")  # fmt: skip
    for column in ignore:
        if column not in table.columns:
            raise SubjectsTableError(f"subjects table {path}, line 1, column {column!r}: listed "
                                     "under 'ignore' but not in the table")  # fmt: skip
    declared = {c.name for c in _COLUMNS}
    covariates = [c for c in table.columns if c not in declared and c not in ignore]
    entries = [_entry(_Row(table, i), covariates) for i in range(len(table))]
    return SubjectsTable(path.resolve(), entries, covariates, list(ignore))
