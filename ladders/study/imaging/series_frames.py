"""The end-diastolic and end-systolic frames of a 4-D label series: given, tabled or found.

``symladders mesh`` meshes two frames of every 4-D series. They are given for every
series (``--frames ED,ES``), per series in a frames table (:func:`read_frames_table`:
the columns ``subject,ed,es``, the subject named as ``symladders mesh`` names it from
the file, ``<subject>.nii.gz``), or found (:func:`least_volume_frame`): end-diastole
is the first frame, as the series of ``symladders track`` and the usual acquisitions
start, and end-systole the frame where the cavity is smallest (the label's voxel
count times the voxel volume). :data:`FRAME_CHOICES` names how each frame was chosen,
as ``meshing.csv`` and the meshes' records state it.
"""

from __future__ import annotations

from pathlib import Path

import nibabel as nib
import numpy as np

from ladders.tables import Column, Table, read_table

from .label_images import ImageError, image_stem, read_label_series

__all__ = [
    "FRAME_CHOICES",
    "FRAMES_COLUMNS",
    "series_frame_counts",
    "read_frames_table",
    "least_volume_frame",
]

#: How a frame of a series was chosen: by ``--frames ED,ES``, by the frames table, as
#: the series' first frame (ED), or as its frame of least cavity volume (ES).
FRAME_CHOICES = ("given", "table", "first frame", "least volume")

#: The columns of a frames table: one row per series.
FRAMES_COLUMNS = (Column("subject"), Column("ed", "frame"), Column("es", "frame"))


def series_frame_counts(images) -> dict[str, int]:
    """``{subject: frame count}`` of the 4-D series (more than one frame) among ``images``,
    from their headers (an unreadable file is left out: its meshing records why)."""
    counts = {}
    for path in map(Path, images):
        try:
            shape = nib.load(str(path)).shape
        except Exception:  # noqa: BLE001 - read_label_image names the problem later
            continue
        if len(shape) == 4 and shape[3] > 1:
            counts[image_stem(path)] = int(shape[3])
    return counts


def read_frames_table(path, images) -> dict[str, tuple[int, int]]:
    """``{subject: (ed, es)}`` of a frames table (see the module), checked against the
    4-D series among ``images``.

    Raises
    ------
    ladders.tables.TableError
        One line naming the file, the line and the column: a missing or unused column, a
        value that is not a frame index, a subject twice, a subject that is not one of the
        series, a frame beyond its series.
    """
    table: Table = read_table(path, FRAMES_COLUMNS, what="frames table", key=("subject",))
    counts = series_frame_counts(images)
    table.refuse_unknown("subject", counts, what="series")
    for column in ("ed", "es"):
        table.refuse_beyond(column, counts, key="subject")
    return {row["subject"]: (row["ed"], row["es"]) for row in table.rows}


def least_volume_frame(path, label: int) -> tuple[int, list[float]]:
    """The frame of a 4-D label series where the label's volume is least, and every
    frame's volume (mm^3: voxel count times voxel volume); the first such frame on a tie.

    Raises
    ------
    ImageError
        The series cannot be read, or the label is in none of its frames.
    """
    frames = read_label_series(path)
    voxel = float(abs(np.linalg.det(frames[0].affine[:3, :3])))
    volumes = [float(np.count_nonzero(f.labels == label)) * voxel for f in frames]
    if not any(volumes):
        raise ImageError(f"{path}: label {label} is in none of its {len(frames)} frames")
    present = [v if v > 0 else np.inf for v in volumes]  # a frame without the label is no ES
    return int(np.argmin(present)), volumes
