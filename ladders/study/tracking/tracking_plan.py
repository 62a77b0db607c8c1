"""The subjects a tracking batch has to follow: their ED meshes, transforms, series, epicardia.

:func:`plan_tracking` pairs each corresponded end-diastolic mesh ``<subject>_ed.<ext>``
of a folder (with its correspondence record's transform, when the folder has one) with
the subject's series among the images (and, for cine series, its ED epicardium), and
names beforehand what is missing for a subject (:class:`TrackingTask`'s ``error``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from ..cohort.mesh_folder import natural_key
from ..meshes.mesh_io import MESH_EXTENSIONS
from .label_series import SeriesError, find_series

__all__ = ["TrackingTask", "plan_tracking", "ed_meshes"]

_RECORDS = "correspondence"


@dataclass(frozen=True)
class TrackingTask:
    """One subject to track: its ED mesh, its correspondence transform, its series."""

    subject: str
    ed: Path | None
    transform: dict | None
    series: Path | None
    error: str = ""
    epicardium: Path | None = None


def ed_meshes(folder: Path) -> dict[str, Path]:
    """``{subject: path}`` of the ``<subject>_ed.<ext>`` meshes of a folder (one each)."""
    if not folder.is_dir():
        raise SeriesError(f"meshes: {folder} is not a folder")
    out: dict[str, Path] = {}
    for path in sorted(folder.iterdir()):
        if (
            path.name.startswith(".")
            or not path.is_file()
            or path.suffix.lower() not in MESH_EXTENSIONS
        ):
            continue
        if path.stem.lower().endswith("_ed"):
            subject = path.stem[:-3]
            if subject in out:
                raise SeriesError(
                    f"meshes: subject {subject!r} has two ED meshes, {out[subject]} and {path}"
                )
            out[subject] = path
    if not out:
        raise SeriesError(f"meshes: {folder} holds no '<subject>_ed.<ext>' mesh")
    return out


def _transform(folder: Path, subject: str) -> dict | None:
    path = folder / _RECORDS / f"{subject}.json"
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    transform = record.get("transform") if isinstance(record, dict) else None
    return transform if isinstance(transform, dict) and "matrix" in transform else None


def plan_tracking(meshes_folder, images, epicardia=None) -> list[TrackingTask]:
    """The subjects to track (every ED mesh and every series), with the errors known beforehand.

    ``epicardia`` (optional): a folder of ED epicardial meshes ``<subject>_ed.<ext>``; a
    subject without one is an error of its own."""
    folder = Path(meshes_folder)
    meshes = ed_meshes(folder)
    series = find_series(images)
    epi = None if epicardia is None else ed_meshes(Path(epicardia))
    tasks = []
    for subject in sorted(set(meshes) | set(series), key=natural_key):
        ed, source = meshes.get(subject), series.get(subject)
        error = ""
        if ed is None:
            error = f"subject {subject!r}: no ED mesh '{subject}_ed.<ext>' in {folder}"
        elif source is None:
            error = (f"subject {subject!r}: no label series ({subject}.nii.gz, or a folder "
                     f"{subject}/ of frames) among the images")  # fmt: skip
        elif isinstance(source, str):
            error, source = source, None
        elif epi is not None and subject not in epi:
            error = f"subject {subject!r}: no ED epicardium '{subject}_ed.<ext>' in {epicardia}"
        tasks.append(TrackingTask(subject, ed, _transform(folder, subject) if ed else None,
                                  source, error, None if epi is None else epi.get(subject)))  # fmt: skip
    return tasks
