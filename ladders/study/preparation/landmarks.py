"""Anatomical landmarks of a left ventricle: apex, base-plane centre and a septal point.

A surface fit cannot tell how a near surface of revolution is turned about its
long axis; three landmarks can. :class:`Landmarks` holds them for one mesh and
gives its anatomical frame (:meth:`Landmarks.frame`: the long axis from the apex
to the base-plane centre, the septal direction orthogonal to it, their cross
product). :func:`landmark_transform` is the rigid (or similarity) transform
that maps one frame onto another.

A landmark table (:func:`read_landmarks`, :func:`write_landmarks`) is a CSV file
with one row per subject (the atlas's own row is named ``atlas``)::

    subject,apex_x,apex_y,apex_z,base_x,base_y,base_z,septum_x,septum_y,septum_z
    case01,0.0,0.0,0.0,0.0,0.0,85.0,-24.1,0.0,40.2

in the coordinates and unit of the subject's mesh files. The septal point is any
point of the septal wall (its direction from the long axis is what counts); the
apex and the septal point lie on the surface, the base-plane centre on the axis
(:func:`check_landmarks` refuses a table that contradicts its meshes).
``symladders mesh`` writes such a table from label images with a right-ventricle
label (the septum is where the right ventricle is, as in the UK Biobank pipeline).
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ladders.tables import Column, TableDict, locate, read_table

from ..errors import CohortError
from ..files import atomic_write_text
from .alignment import SimilarityTransform

__all__ = [
    "LANDMARKS_FILE",
    "LANDMARK_COLUMNS",
    "Landmarks",
    "LandmarkError",
    "landmark_transform",
    "read_landmarks",
    "write_landmarks",
    "landmarks_csv",
    "check_landmarks",
    "axial_angle",
    "atlas_landmarks_path",
    "refuse_unknown_subjects",
]

#: The table's default file name in a folder of meshes.
LANDMARKS_FILE = "landmarks.csv"
_NAMES = ("apex", "base", "septum")
LANDMARK_COLUMNS = ("subject", *(f"{n}_{c}" for n in _NAMES for c in "xyz"))
_TABLE_COLUMNS = (Column("subject"), *(Column(c, "number") for c in LANDMARK_COLUMNS[1:]))


def atlas_landmarks_path(atlas) -> Path:
    """Where the landmarks of the atlas file ``atlas`` are kept: ``<stem>_landmarks.csv``."""
    atlas = Path(atlas)
    return atlas.with_name(f"{atlas.stem}_landmarks.csv")


class LandmarkError(CohortError):
    """A landmark table or landmark that cannot be used; the message names the culprit."""


@dataclass(frozen=True)
class Landmarks:
    """Apex, base-plane centre and a septal point of one mesh, each of shape ``(3,)``."""

    apex: np.ndarray
    base: np.ndarray
    septum: np.ndarray

    def __post_init__(self):
        for name in _NAMES:
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (3,) or not np.isfinite(value).all():
                raise LandmarkError(
                    f"landmarks: {name}: expected 3 finite coordinates, got {value}"
                )
            object.__setattr__(self, name, value)
        length = np.linalg.norm(self.base - self.apex)
        if length == 0:
            raise LandmarkError("landmarks: the apex and the base-plane centre coincide")
        axis = (self.base - self.apex) / length
        radial = self.septum - self.apex
        if np.linalg.norm(radial - (radial @ axis) * axis) <= 1e-6 * length:
            raise LandmarkError("landmarks: the septal point lies on the long axis")

    @classmethod
    def from_array(cls, array) -> Landmarks:
        """From rows ``(apex, base, septum)``, shape ``(3, 3)``."""
        a = np.asarray(array, dtype=float)
        if a.shape != (3, 3):
            raise LandmarkError(f"landmarks: expected an array (3, 3), got {a.shape}")
        return cls(*a)

    def as_array(self) -> np.ndarray:
        """Rows ``(apex, base, septum)``, shape ``(3, 3)``."""
        return np.stack([self.apex, self.base, self.septum])

    @property
    def long_axis(self) -> np.ndarray:
        """Unit vector from the apex to the base-plane centre, shape ``(3,)``."""
        d = self.base - self.apex
        return d / np.linalg.norm(d)

    @property
    def septal_direction(self) -> np.ndarray:
        """Unit vector from the long axis towards the septal point, orthogonal to it."""
        axis = self.long_axis
        r = self.septum - self.apex
        r = r - (r @ axis) * axis
        return r / np.linalg.norm(r)

    def frame(self) -> np.ndarray:
        """The anatomical frame, a rotation ``(3, 3)`` with columns long axis, septal, their cross."""
        e1, e2 = self.long_axis, self.septal_direction
        return np.stack([e1, e2, np.cross(e1, e2)], axis=1)

    def transformed(self, transform: SimilarityTransform) -> Landmarks:
        """The landmarks moved by ``transform``."""
        return Landmarks.from_array(transform.apply(self.as_array()))

    def scaled(self, factor: float) -> Landmarks:
        """The landmarks in another unit (coordinates times ``factor``)."""
        return Landmarks.from_array(self.as_array() * float(factor))


def landmark_transform(
    source: Landmarks, target: Landmarks, *, scale: bool = False
) -> SimilarityTransform:
    """The transform mapping the frame of ``source`` onto that of ``target``.

    The rotation takes the source's long axis and septal direction onto the
    target's; the translation matches the midpoints of apex and base; with
    ``scale`` the apex-to-base lengths are matched too.
    """
    rotation = target.frame() @ source.frame().T
    s = 1.0
    if scale:
        s = np.linalg.norm(target.base - target.apex) / np.linalg.norm(source.base - source.apex)
    centre_s = 0.5 * (source.apex + source.base)
    centre_t = 0.5 * (target.apex + target.base)
    return SimilarityTransform(rotation, centre_t - s * rotation @ centre_s, float(s))


def axial_angle(direction, reference, axis) -> float:
    """Signed angle in degrees from ``reference`` to ``direction`` about ``axis``.

    Both directions are first projected onto the plane orthogonal to ``axis``.
    """
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    u = np.asarray(direction, dtype=float)
    v = np.asarray(reference, dtype=float)
    u = u - (u @ a) * a
    v = v - (v @ a) * a
    return float(np.degrees(np.arctan2(np.cross(v, u) @ a, v @ u)))


def landmarks_csv(table: dict) -> str:
    """The CSV text of ``{subject: Landmarks}`` (see the module)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(LANDMARK_COLUMNS)
    for name, lm in table.items():
        writer.writerow([name, *(f"{x:.10g}" for x in lm.as_array().ravel())])
    return out.getvalue()


def write_landmarks(path, table: dict) -> Path:
    """Write ``{subject: Landmarks}`` as a landmark table (atomically); return the path."""
    path = Path(path)
    atomic_write_text(path, landmarks_csv(table))
    return path


def read_landmarks(path) -> dict:
    """``{subject: Landmarks}`` of a landmark table (see the module).

    Raises
    ------
    LandmarkError
        An unreadable file, a missing or unused column, a duplicated subject, a value
        that is not a finite number (:func:`ladders.tables.read_table`) or landmarks
        without a frame; the message names the file, the line and the column.
    """
    table = read_table(path, _TABLE_COLUMNS, what="landmark table", key=("subject",),
                       error=LandmarkError)  # fmt: skip
    out = TableDict({}, table)
    for i, row in enumerate(table.rows):
        values = [row[column] for column in LANDMARK_COLUMNS[1:]]
        try:
            out[row["subject"]] = Landmarks.from_array(np.reshape(values, (3, 3)))
        except LandmarkError as exc:
            raise table.error(i, None, f"subject {row['subject']!r}: {exc}") from None
    return out


def refuse_unknown_subjects(table: dict, subjects, source) -> None:
    """Refuse a row of a landmark table that names none of ``subjects`` nor the atlas (a
    row that would be ignored: a typo, or another cohort's table), naming its line.

    Raises
    ------
    LandmarkError
    """
    known = set(subjects) | {"atlas"}
    unknown = [name for name in table if name not in known]
    if unknown:
        where = locate(table, "subject", unknown[0], f"landmarks {source}")
        shown = ", ".join(sorted(known - {"atlas"})[:6])
        raise LandmarkError(
            f"{where}: unknown subject {unknown[0]!r}: no such subject among the meshes "
            f"({shown}{' ...' if len(known) > 7 else ''})"
        )


def check_landmarks(landmarks: Landmarks, vertices, faces, tolerance: float, name: str) -> None:
    """Refuse landmarks that do not belong to the mesh ``(vertices, faces)``.

    The apex and the septal point must lie within ``tolerance`` of the surface;
    the base-plane centre within the mesh's bounding box grown by ``tolerance``.

    Raises
    ------
    LandmarkError
        Naming the subject ``name``, the landmark and its distance.
    """
    from ..surface_queries import closest_points

    dist = closest_points(np.stack([landmarks.apex, landmarks.septum]), vertices, faces)[1]
    for label, d in zip(("apex", "septum"), dist):
        if d > tolerance:
            raise LandmarkError(
                f"landmarks: subject {name!r}: the {label} point is {d:.3g} from its mesh's "
                f"surface (more than {tolerance:g}); are the landmarks in the mesh's coordinates?"
            )
    low = np.min(vertices, axis=0) - tolerance
    high = np.max(vertices, axis=0) + tolerance
    if ((landmarks.base < low) | (landmarks.base > high)).any():
        raise LandmarkError(
            f"landmarks: subject {name!r}: the base-plane centre {landmarks.base.round(3).tolist()} "
            "lies outside its mesh's bounding box"
        )
