"""The landmark table of a meshing: each subject's ED landmarks, from the meshes' records.

:func:`folder_landmarks` makes ``landmarks.csv`` of a folder of meshes
(:func:`~.mesh_images.mesh_label_images` with ``rv_label``): the end-diastolic meshes
of the run (its records) and those an earlier run left in the folder with landmarks in
their provenance records.
"""

from __future__ import annotations

import json
from pathlib import Path

from ..preparation.landmarks import Landmarks

__all__ = ["PHASES", "subject_phase", "ed_landmarks", "folder_landmarks", "landmarks_of"]

#: The two frames meshed per subject, as the mesh files end.
PHASES = ("ed", "es")


def subject_phase(stem: str) -> tuple[str, str | None]:
    """``(subject, "ed" | "es")`` of a mesh or image file's stem, ``(stem, None)`` without
    a phase (``case01_ED`` -> ``("case01", "ed")``)."""
    low = stem.lower()
    for phase in PHASES:
        if low.endswith(f"_{phase}"):
            return stem[: -len(phase) - 1], phase
    return stem, None


def ed_landmarks(records: list) -> dict:
    """``{subject: Landmarks}`` of the records of end-diastolic meshes that have landmarks."""
    table = {}
    for r in records:
        subject, phase = subject_phase(Path(r["mesh"]).stem)
        if r["status"] != "failed" and phase == "ed" and r.get("landmarks") is not None:
            table[subject] = Landmarks.from_array(r["landmarks"])
    return table


def folder_landmarks(folder: Path, ext: str, records: list) -> dict:
    """``{subject: Landmarks}`` of every end-diastolic mesh of ``folder`` with landmarks.

    This run's records first: its meshes made or reused, none for its failed images;
    then the meshes of the folder this run did not touch (an earlier run on other
    images), from their provenance records.
    """
    table = ed_landmarks(records)
    touched = {r["mesh"] for r in records}
    for mesh in sorted(folder.glob(f"*{ext}")):
        subject, phase = subject_phase(mesh.stem)
        if phase != "ed" or mesh.name in touched or subject in table:
            continue
        try:
            record = json.loads(mesh.with_suffix(".json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        landmarks = landmarks_of(record) if isinstance(record, dict) else None
        if landmarks is not None:
            table[subject] = Landmarks.from_array(landmarks)
    return dict(sorted(table.items()))


def landmarks_of(record: dict) -> list | None:
    """The landmarks (3 x 3 nested list) of a provenance record, None if it has none usable."""
    entry = record.get("landmarks")
    try:
        return Landmarks(*(entry[k] for k in ("apex", "base", "septum"))).as_array().tolist()
    except (TypeError, KeyError, ValueError):
        return None
