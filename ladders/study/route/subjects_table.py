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

import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

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
_RESERVED = ("subject", *IMAGE_COLUMNS, *FRAME_COLUMNS, *_LANDMARK_COLUMNS)
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


def _fail(path: Path, line: int | None, column: str | None, message: str):
    where = f"{path}" + ("" if line is None else f", line {line}")
    where += "" if column is None else f", column {column!r}"
    raise SubjectsTableError(f"subjects table {where}: {message}")


def _frames_of(path: Path) -> int:
    """The frame count of a NIfTI file from its header (1 for a 3-D image)."""
    import nibabel as nib

    shape = nib.load(str(path)).shape
    if len(shape) == 3:
        return 1
    if len(shape) == 4:
        return int(shape[3])
    raise ValueError(f"expected a 3-D image or a 4-D series, got {len(shape)} dimensions")


def _image(table: Path, line: int, column: str, cell: str) -> tuple[Path, int]:
    path = Path(cell).expanduser()
    path = path if path.is_absolute() else table.parent / path
    if not path.is_file():
        what = "a folder" if path.is_dir() else "no such file"
        _fail(table, line, column, f"{cell!r}: {what}")
    if not path.name.lower().endswith((".nii", ".nii.gz")):
        _fail(table, line, column, f"{cell!r}: expected a NIfTI file (.nii or .nii.gz)")
    try:
        return path.resolve(), _frames_of(path)
    except Exception as exc:  # noqa: BLE001 - nibabel raises many kinds for a bad file
        _fail(table, line, column, f"{cell!r}: cannot be read as NIfTI ({exc})")


def _frame(table: Path, line: int, column: str, cell: str, n_frames: int) -> int | None:
    if not cell:
        return None
    try:
        value = int(cell)
    except ValueError:
        _fail(table, line, column, f"expected a whole frame number (0-based), got {cell!r}")
    if not 0 <= value < n_frames:
        _fail(table, line, column, f"frame {value} outside the series' {n_frames} frames "
                                   f"(0 to {n_frames - 1})")  # fmt: skip
    return value


def _landmarks(table: Path, line: int, row: dict, present: list[str]) -> np.ndarray | None:
    if not present:
        return None
    cells = [row.get(c, "").strip() for c in _LANDMARK_COLUMNS]
    if not any(cells):
        return None
    values = []
    for column, cell in zip(_LANDMARK_COLUMNS, cells):
        try:
            value = float(cell)
        except ValueError:
            _fail(table, line, column, f"expected a coordinate in mm, got {cell!r} (a landmark "
                                       "needs all nine cells, or none)")  # fmt: skip
        if not np.isfinite(value):
            _fail(table, line, column, f"expected a finite coordinate, got {cell!r}")
        values.append(value)
    return np.array(values, float).reshape(3, 3)


def _entry(table: Path, line: int, row: dict, covariates: list[str], landmarks: list[str]):
    subject = row["subject"].strip()
    if not subject:
        _fail(table, line, "subject", "empty subject name")
    if not _NAME.match(subject):
        _fail(table, line, "subject", f"{subject!r}: a subject's name must start with a letter or "
                                      "digit and hold only letters, digits, '-', '_' and '.'")  # fmt: skip
    cells = {c: row.get(c, "").strip() for c in (*IMAGE_COLUMNS, *FRAME_COLUMNS)}
    series = ed = es = None
    if cells["image"]:
        if cells["ed_image"] or cells["es_image"]:
            column = "ed_image" if cells["ed_image"] else "es_image"
            _fail(table, line, column, "give either 'image' (a 4-D series) or 'ed_image' and "
                                       "'es_image' (two 3-D images), not both")  # fmt: skip
        series, n_frames = _image(table, line, "image", cells["image"])
        if n_frames < 2:
            _fail(table, line, "image", f"{cells['image']!r} is a 3-D image: a series needs the "
                                        "frames on a fourth axis; two 3-D images go in 'ed_image' "
                                        "and 'es_image'")  # fmt: skip
    elif cells["ed_image"] or cells["es_image"]:
        for column in ("ed_image", "es_image"):
            if not cells[column]:
                _fail(table, line, column, "empty: 'ed_image' and 'es_image' go together")
        ed, n_ed = _image(table, line, "ed_image", cells["ed_image"])
        es, n_es = _image(table, line, "es_image", cells["es_image"])
        for column, n in (("ed_image", n_ed), ("es_image", n_es)):
            if n != 1:
                _fail(table, line, column, f"a 4-D series of {n} frames: give it in 'image'")
        n_frames = 2
    else:
        _fail(table, line, "image", "no image: give 'image' (a 4-D series) or 'ed_image' and "
                                    "'es_image'")  # fmt: skip
    frames = {}
    for column in FRAME_COLUMNS:
        if cells[column] and series is None:
            _fail(table, line, column, "a frame goes with a series in 'image'")
        frames[column] = _frame(table, line, column, cells[column], n_frames)
    if None not in frames.values() and frames["ed_frame"] == frames["es_frame"]:
        _fail(table, line, "es_frame", f"the same frame as ed_frame ({frames['ed_frame']})")
    values = {}
    for column in covariates:
        cell = row.get(column, "").strip()
        if not cell:
            _fail(table, line, column, "empty covariate: fill it, or leave the subject out of "
                                       "the table")  # fmt: skip
        values[column] = cell
    return SubjectEntry(subject, line, series, ed, es, n_frames, frames["ed_frame"],
                        frames["es_frame"], _landmarks(table, line, row, landmarks), values)  # fmt: skip


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
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        _fail(path, None, None, f"cannot be read ({getattr(exc, 'strerror', None) or exc})")
    reader = csv.reader(io.StringIO(text))
    header = [h.strip() for h in next(reader, [])]
    if not any(header):
        _fail(path, None, None, "the file is empty: expected a header line such as "
                                "'subject,image,group'")  # fmt: skip
    seen = {}
    for i, name in enumerate(header):
        if not name:
            _fail(path, 1, f"#{i + 1}", "a column without a name")
        if name in seen:
            _fail(path, 1, name, "a second column of this name")
        seen[name] = i
    if "subject" not in seen:
        _fail(path, 1, "subject", f"missing (columns: {', '.join(header)})")
    unknown_ignored = [c for c in ignore if c not in seen]
    if unknown_ignored:
        _fail(path, 1, unknown_ignored[0], "listed under 'ignore' but not in the table")
    landmarks = [c for c in _LANDMARK_COLUMNS if c in seen]
    if landmarks and len(landmarks) != len(_LANDMARK_COLUMNS):
        missing = [c for c in _LANDMARK_COLUMNS if c not in seen]
        _fail(path, 1, missing[0], "missing: the landmarks need all nine columns "
                                   f"{', '.join(_LANDMARK_COLUMNS)}")  # fmt: skip
    covariates = [c for c in header if c not in _RESERVED and c not in ignore]
    entries, lines = [], {}
    for line, cells in enumerate(reader, start=2):
        if not any(c.strip() for c in cells):
            continue
        if len(cells) > len(header):
            _fail(path, line, None, f"{len(cells)} cells for {len(header)} columns")
        row = dict(zip(header, cells))
        entry = _entry(path, line, row, covariates, landmarks)
        if entry.subject in lines:
            _fail(path, line, "subject", f"{entry.subject!r} again (first on line "
                                         f"{lines[entry.subject]})")  # fmt: skip
        lines[entry.subject] = line
        entries.append(entry)
    if not entries:
        _fail(path, None, None, "no subject: the table has a header and no row")
    return SubjectsTable(path.resolve(), entries, covariates, list(ignore))
