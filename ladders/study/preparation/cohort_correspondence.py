"""Correspond a folder of segmentations to an atlas, writing a folder the study reads.

:func:`correspond_cohort` reads ``<name>_ed.<ext>`` / ``<name>_es.<ext>`` (or
``<name>/ed.<ext>``, ``<name>/es.<ext>``) meshes of any vertex count, checks
their units against the atlas (:func:`~ladders.study.preparation.units.check_units_and_pose`),
corresponds every subject (:func:`~ladders.study.preparation.correspondence.correspond_subject`)
and writes, in ``output``::

    atlas.<ext>                     the atlas (so that ``symladders study --meshes output`` runs)
    <name>_ed.<ext>, <name>_es.<ext> the corresponded meshes: the atlas's vertices and faces
    quality.csv, quality.md         one row per mesh, flagged rows first (:mod:`.quality_table`)
    correspondence/<name>.json      per subject: status, transform, units, quality, hashes

Anatomical landmarks (:mod:`ladders.study.preparation.landmarks`: apex, base-plane centre, septal point)
fix each subject's turn about the long axis, which the surfaces leave open: a
landmark table (``landmarks=``, or ``landmarks.csv`` in the folder of meshes, as
``symladders mesh --rv-label`` and ``symladders cohort --landmarks`` write it) needs
a row per subject and the atlas's own (row ``atlas``, ``atlas_landmarks``, or
``<atlas>_landmarks.csv`` beside the atlas file, as ``symladders atlas`` writes it); a
missing row or a landmark far from its mesh is refused before any computation.

A subject that fails is recorded with its reason (``"status": "failed"``), its
meshes from an earlier run are removed (the study must not read them), and the
others finish. Every file is written atomically and a subject's record last, so
an interrupted run loses nothing: the next run with the same atlas, settings
and input files skips the subjects already done (failed ones are retried).
A reused record written with an older definition of the quality's surface distances
(before ``beyond_rim_fraction``) gets them again from its stored meshes, so that the
quality table of a rerun is that of the current definition.
The arguments are those a command line needs (atlas, meshes, output, jobs,
progress, resume), so a command is a thin wrapper.
"""

from __future__ import annotations

import json
import os
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..batch import run_batch
from ..cohort.mesh_folder import natural_key, scan_mesh_folder
from ..files import array_digest, atomic_write_text, file_sha256
from ..meshes.mesh_io import WRITE_EXTENSIONS, read_mesh, write_mesh
from ..running.store import validate_subject_name
from .alignment import SimilarityTransform
from .correspondence import QUALITY_DISTANCES, CorrespondenceSettings, correspond_subject
from .landmarks import (
    LANDMARKS_FILE,
    LandmarkError,
    Landmarks,
    atlas_landmarks_path,
    check_landmarks,
    read_landmarks,
    refuse_unknown_subjects,
)
from .quality_table import write_quality_table
from .surface_distance import surface_distances
from .units import check_units_and_pose

__all__ = ["CohortCorrespondence", "correspond_cohort", "scan_segmentations"]

RECORDS = "correspondence"


@dataclass
class CohortCorrespondence:
    """Outcome of :func:`correspond_cohort`.

    Attributes
    ----------
    output : Path
    records : list of dict
        One per subject (the content of ``correspondence/<name>.json``).
    computed, reused, failed : list of str
        Subject names.
    units : dict
        Per subject, the unit assumed for its input files.
    quality : list of dict
        The rows of ``quality.csv`` (:func:`~.quality_table.quality_rows`), flagged first.
    """

    output: Path
    records: list = field(default_factory=list)
    computed: list = field(default_factory=list)
    reused: list = field(default_factory=list)
    failed: list = field(default_factory=list)
    units: dict = field(default_factory=dict)
    quality: list = field(default_factory=list)

    @property
    def flagged(self) -> list[str]:
        """The meshes flagged for inspection, as ``"subject phase"``, in the table's order."""
        return [f"{r['subject']} {r['phase']}" for r in self.quality if r["flagged"]]


def scan_segmentations(folder, phases=("ed", "es")) -> dict:
    """``{subject: {"ed": path, "es": path}}`` of a folder in the study's layout, naturally sorted.

    An ``atlas.<ext>`` in the folder is ignored here (the atlas is given separately).
    Every subject must have a mesh of each of ``phases`` (``("ed",)`` for an atlas).
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise FileNotFoundError(f"meshes: {folder} is not a folder")
    _, entries, _ = scan_mesh_folder(folder)
    if not entries:
        names = " / ".join(f"'<name>_{p}.<ext>'" for p in phases)
        raise ValueError(f"meshes: {folder} holds no {names} files")
    for name, slot in entries.items():
        validate_subject_name(name)
        missing = set(phases) - set(slot)
        if missing:
            raise ValueError(f"meshes: subject {name!r} has no {missing.pop().upper()} mesh")
    return {n: {p: entries[n][p] for p in phases} for n in sorted(entries, key=natural_key)}


def _fingerprint(settings, atlas_hash, slot, factor, landmarks) -> dict:
    out = {
        "settings": settings.key(),
        "atlas": atlas_hash,
        "inputs": {p: file_sha256(slot[p]) for p in ("ed", "es")},
        "unit_factor": factor,
    }
    if landmarks is not None:
        out["landmarks"] = [lm.as_array().round(9).tolist() for lm in landmarks]
    return out


def _reusable(
    record_path: Path, fingerprint: dict, output: Path, name: str, ext: str
) -> dict | None:
    try:
        record = json.loads(record_path.read_text())
    except (OSError, ValueError):
        return None
    done = record.get("status") == "ok" and record.get("fingerprint") == fingerprint
    meshes = all((output / f"{name}_{p}{ext}").is_file() for p in ("ed", "es"))
    return record if done and meshes else None


def _reuse_check(resume: bool, outcome):
    """``reuse`` of :func:`~ladders.study.batch.run_batch`: a subject's record when it is done."""

    def stored(name, slot, atlas, settings, factor, output, ext, fingerprint, landmarks):
        record = None
        if resume:
            record = _reusable(output / RECORDS / f"{name}.json", fingerprint, output, name, ext)
        if record is not None:
            record = _refresh_quality(record, slot, atlas[1], factor, output, name, ext)
            outcome.reused.append(name)
        return record

    return stored


def _refresh_quality(record: dict, slot, faces, factor, output: Path, name: str, ext: str):
    """The record with the current quality distances: recomputed from the stored meshes
    and the recorded transform (rewritten) when a phase lacks one of them."""
    if all(k in record.get(p, {}) for p in ("ed", "es") for k in QUALITY_DISTANCES):
        return record
    try:
        transform = SimilarityTransform.from_dict(record["transform"])
        for phase in ("ed", "es"):
            v, f = read_mesh(slot[phase])
            corresponded = read_mesh(output / f"{name}_{phase}{ext}")[0]
            found = surface_distances(corresponded, faces, transform.apply(v * factor), f,
                                      skip_beyond_rim=True)  # fmt: skip
            record[phase].update({k: found[k] for k in QUALITY_DISTANCES})
    except (KeyError, ValueError, OSError):  # not refreshable: kept as it was
        return record
    atomic_write_text(output / RECORDS / f"{name}.json", json.dumps(record, indent=1))
    return record


def _correspond_one(
    name, slot, atlas, settings, factor, output, ext, fingerprint, landmarks
) -> dict:
    """Correspond one subject; the record (status ok or failed) is written last.

    ``landmarks`` is None or ``(subject's, atlas's)`` in the atlas's unit."""
    record = {"subject": name, "fingerprint": fingerprint, "unit_factor": factor}
    try:
        meshes = {}
        for phase in ("ed", "es"):
            v, f = read_mesh(slot[phase])
            meshes[phase] = (v * factor, f)
        subject_lm, atlas_lm = landmarks if landmarks is not None else (None, None)
        out = correspond_subject(*atlas, meshes["ed"], meshes["es"], settings,
                                 landmarks=subject_lm, atlas_landmarks=atlas_lm)  # fmt: skip
        for phase, c in (("ed", out.ed), ("es", out.es)):
            write_mesh(output / f"{name}_{phase}{ext}", c.vertices, atlas[1], atomic=True)
            record[phase] = {"input": str(slot[phase]), "n_input_vertices": len(meshes[phase][0]),
                             **c.quality}  # fmt: skip
        record.update(status="ok", transform=out.transform.as_dict())
        if out.ed.alignment is not None:
            record["alignment"] = out.ed.alignment.as_dict()
        if landmarks is not None:
            record["landmarks"] = {"subject": subject_lm.as_array().tolist(),
                                   "atlas": atlas_lm.as_array().tolist()}  # fmt: skip
    except Exception as exc:  # a failing subject must not stop the others
        record.update(status="failed", reason=f"{type(exc).__name__}: {exc}",
                      traceback=traceback.format_exc())  # fmt: skip
        for phase in ("ed", "es"):  # no earlier result is left for the study to read
            (output / f"{name}_{phase}{ext}").unlink(missing_ok=True)
    atomic_write_text(output / RECORDS / f"{name}.json", json.dumps(record, indent=1))
    return record


def _readable(entries: dict) -> dict:
    """The subjects' meshes that can be read (the others fail later, recorded with the reason)."""
    out = {}
    for name, slot in entries.items():
        try:
            out[name] = {p: read_mesh(slot[p]) for p in ("ed", "es")}
        except (ValueError, OSError):
            continue
    return out


def _subject_landmarks(landmarks, meshes, entries) -> dict | None:
    """The landmark table to use: given, found in the folder of meshes, or none."""
    if landmarks is False:
        return None
    if landmarks is None:
        if isinstance(meshes, dict) or not (Path(meshes) / LANDMARKS_FILE).is_file():
            return None
        landmarks = Path(meshes) / LANDMARKS_FILE
    table = landmarks if isinstance(landmarks, dict) else read_landmarks(landmarks)
    refuse_unknown_subjects(table, entries, "the table given")
    table = dict(table)
    missing = [n for n in entries if n not in table]
    if missing:
        raise LandmarkError(
            f"landmarks: no row for subject(s) {missing} (of {len(entries)}) in "
            f"{'the table given' if isinstance(landmarks, dict) else landmarks}"
        )
    return table


def _atlas_landmarks(atlas_landmarks, table, atlas) -> Landmarks:
    if isinstance(atlas_landmarks, Landmarks):
        return atlas_landmarks
    if atlas_landmarks is None and "atlas" not in table and isinstance(atlas, str | os.PathLike):
        sidecar = atlas_landmarks_path(atlas)
        atlas_landmarks = sidecar if sidecar.is_file() else None
    if atlas_landmarks is not None:
        rows = read_landmarks(atlas_landmarks)
        if "atlas" not in rows and len(rows) != 1:
            raise LandmarkError(
                f"atlas_landmarks: {atlas_landmarks} has no row 'atlas' and {len(rows)} rows"
            )
        return rows.get("atlas") or next(iter(rows.values()))
    if "atlas" not in table:
        raise LandmarkError(
            "landmarks: the table has no row 'atlas' (the atlas's own apex, base-plane centre "
            "and septal point) and the atlas file has no <name>_landmarks.csv beside it: add "
            "the row, or give the atlas's landmarks (--atlas-landmarks)"
        )
    return table["atlas"]


def _checked_landmarks(table, atlas_lm, atlas_mesh, readable, factors, tolerance) -> dict:
    """Per subject ``(subject's, atlas's)`` landmarks in the atlas's unit, checked on the meshes."""
    check_landmarks(atlas_lm, *atlas_mesh, tolerance, "atlas")
    out = {}
    for name, factor in factors.items():
        lm = table[name].scaled(factor)
        if name in readable:
            v, f = readable[name]["ed"]
            check_landmarks(lm, v * factor, f, tolerance, name)
        out[name] = (lm, atlas_lm)
    return out


def _read_atlas(atlas):
    """The atlas's mesh and the extension to write (its file's when written, else ``.vtk``)."""
    if isinstance(atlas, str | os.PathLike):
        v, f = read_mesh(atlas)
        ext = Path(atlas).suffix.lower()
        return (v, f), ext if ext in WRITE_EXTENSIONS else ".vtk"
    v, f = atlas
    return (np.asarray(v, dtype=float), np.asarray(f, dtype=np.int64)), ".vtk"


def correspond_cohort(
    atlas,
    meshes,
    output,
    settings: CorrespondenceSettings | None = None,
    *,
    jobs: int = 1,
    progress: Callable | None = None,
    resume: bool = True,
    units=None,
    allow_scale: bool = False,
    allow_pose: bool | None = None,
    atlas_unit: str = "mm",
    ext: str | None = None,
    landmarks=None,
    atlas_landmarks=None,
) -> CohortCorrespondence:
    """Correspond every subject of a folder of segmentations to ``atlas`` (see the module).

    Parameters
    ----------
    atlas : str, Path or tuple ``(vertices, faces)``
    meshes : str, Path or dict
        A folder in the study's layout, or ``{subject: {"ed": path, "es": path}}``.
    output : str or Path
        Created if needed; readable afterwards by ``read_cohort(output)``.
    settings : CorrespondenceSettings, optional
    jobs : int, default 1
        Subjects corresponded in parallel (joblib processes).
    progress : callable, optional
        ``progress(done, total, subject, record)`` after each subject (reused ones included).
    resume : bool, default True
        Skip subjects already corresponded with the same atlas, settings, inputs and unit.
    units, allow_scale, atlas_unit
        As in :func:`~ladders.study.preparation.units.check_units_and_pose`.
    allow_pose : bool, optional
        Accept meshes far from the atlas's pose; by default they are accepted
        when ``settings.alignment == "icp"`` (the pose is then estimated), and
        refused without alignment.
    ext : str, optional
        Extension of the written meshes (default the atlas file's when
        :func:`~ladders.study.meshes.mesh_io.write_mesh` writes it, else ``.vtk``).
    landmarks : str, Path, dict or False, optional
        A landmark table (:func:`~.landmarks.read_landmarks`) or ``{subject: Landmarks}``,
        in the mesh files' coordinates; by default ``landmarks.csv`` of the folder of
        meshes when there is one; False: none.
    atlas_landmarks : Landmarks, str or Path, optional
        The atlas's landmarks (in its coordinates), or a table with a row ``atlas`` (or
        a single row); by default the table's row ``atlas``.

    Returns
    -------
    CohortCorrespondence

    Raises
    ------
    UnitsError
        Meshes whose size disagrees with the atlas's, unless ``units`` or ``allow_scale``,
        or whose pose does, unless ``allow_pose``.
    LandmarkError
        A landmark table without a row for a subject or the atlas, or with a landmark
        far from its mesh.
    """
    settings = settings or CorrespondenceSettings()
    atlas_mesh, atlas_ext = _read_atlas(atlas)
    ext = "." + (ext or atlas_ext).lower().lstrip(".")
    entries = scan_segmentations(meshes) if not isinstance(meshes, dict) else dict(meshes)
    table = _subject_landmarks(landmarks, meshes, entries)
    atlas_lm = None if table is None else _atlas_landmarks(atlas_landmarks, table, atlas)
    readable = _readable(entries)
    report = check_units_and_pose(
        *atlas_mesh, readable, atlas_unit=atlas_unit, units=units,
        allow_scale=allow_scale,
        allow_pose=settings.alignment == "icp" if allow_pose is None else allow_pose,
    )  # fmt: skip
    output = Path(output)
    (output / RECORDS).mkdir(parents=True, exist_ok=True)
    write_mesh(output / f"atlas{ext}", *atlas_mesh, atomic=True)
    outcome = CohortCorrespondence(output, units=report.assumed_units)
    atlas_hash = array_digest(atlas_mesh[0]) + array_digest(atlas_mesh[1])

    factors = {n: report.factors.get(n, 1.0) for n in entries}
    pairs = dict.fromkeys(entries)
    if table is not None:
        pairs = _checked_landmarks(table, atlas_lm, atlas_mesh, readable, factors,
                                   settings.landmark_tolerance)  # fmt: skip
    tasks = [(name, slot, atlas_mesh, settings, factors[name], output, ext,
              _fingerprint(settings, atlas_hash, slot, factors[name], pairs[name]), pairs[name])
             for name, slot in entries.items()]  # fmt: skip
    records = {}
    for record in run_batch(_correspond_one, tasks, jobs=jobs, reuse=_reuse_check(resume, outcome)):
        name = record["subject"]
        records[name] = record
        if name not in outcome.reused:
            outcome.computed.append(name)
        if progress is not None:
            progress(len(records), len(entries), name, record)
    outcome.records = [records[n] for n in entries]
    outcome.failed = [r["subject"] for r in outcome.records if r["status"] != "ok"]
    outcome.quality = write_quality_table(outcome.records, output, settings, report.assumed_units)
    return outcome
