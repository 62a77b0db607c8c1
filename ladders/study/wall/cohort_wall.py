"""Every tracked subject's wall maps, per vertex and AHA segment: a batch, resumable.

:func:`run_wall_maps` reads a folder ``symladders track`` wrote with the epicardium
(``--myocardium-label``, or ``--epicardia`` for cine): per subject, the endocardium of
every frame ``<subject>/frame_<kk>.<ext>`` (in the atlas's correspondence and frame),
the epicardium of every frame ``<subject>/epicardium/frame_<kk>.<ext>`` and the record
``<subject>.json`` (its ``scale``: the correspondence's, by which the atlas's frame is
scaled, so that thicknesses are in the images' mm). It computes the subject's
:class:`~.maps.WallMaps` (:func:`~.maps.wall_maps`, the long axis and the AHA segments
placed on the atlas by its landmarks: the tracked meshes lie in the atlas's frame,
aligned with it) and writes::

    <output>/<subject>.npz          the maps (WallMaps.as_arrays) and their fingerprint
    <output>/maps/<subject>.vtu     the ED endocardium with per-vertex columns: thickness
                                    at ED and at its peak (mm), peak thickening (mm), peak
                                    radial, circumferential and longitudinal strain (%)
    <output>/wall_segments.csv      per subject and AHA segment, the same figures of the
                                    segment's mean curve, and the fraction of its vertices
                                    measured to the epicardium's rim at ED
    <output>/wall.csv               per subject: status, frames, seconds, error
    <output>/wall.json              the atlas, landmarks and subjects' status
    <output>/atlas.vtk              the atlas (the maps' correspondence)

Every subject is stored as it finishes; a rerun skips the subjects whose frames,
epicardia, scale and landmarks are unchanged; a subject that fails (no epicardium,
frames not in the atlas's correspondence, an epicardium touching the endocardium) is
recorded with its reason and the others go on. :func:`load_wall_cycles`
(:mod:`.wall_cycles`) reads the maps back for the group tests.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..batch import run_batch
from ..errors import CohortError
from ..files import array_digest, atomic_path, atomic_write_text, config_hash, csv_text
from ..meshes.mesh_io import read_mesh, write_mesh
from ..meshes.mesh_outputs import write_point_mesh
from ..population.aha_model import AHA_NAMES, aha_segments
from ..sequences.cycle_study import read_tracked_frames
from ..tracking.epicardium_tracking import EPICARDIUM_FOLDER
from .maps import PEAK_SENSE, WallMaps, signed_peaks, wall_maps

__all__ = ["WallOutcome", "run_wall_maps", "WALL_REPORT", "SEGMENT_TABLE", "summary_columns"]

WALL_REPORT = "wall.csv"
SEGMENT_TABLE = "wall_segments.csv"
_PERCENT = ("radial", "circumferential", "longitudinal")


@dataclass
class WallOutcome:
    """What :func:`run_wall_maps` did: the subjects computed, reused and failed."""

    output: Path
    computed: list = field(default_factory=list)
    reused: list = field(default_factory=list)
    failures: dict = field(default_factory=dict)
    seconds: float = 0.0


def summary_columns(curves: dict) -> dict:
    """The per-vertex or per-segment figures of measure curves ``{name: (n_frames, m)}``:
    thickness at ED and at its peak (mm), peak thickening (mm), peak strains (%)."""
    out = {"thickness_ed_mm": curves["thickness"][0],
           "thickness_peak_mm": signed_peaks(curves["thickness"], 1),
           "thickening_peak_mm": signed_peaks(curves["thickening"], 1)}  # fmt: skip
    for name in _PERCENT:
        out[f"{name}_peak_percent"] = 100.0 * signed_peaks(curves[name], PEAK_SENSE[name])
    return out


def _read_frames(paths, faces, name: str, what: str) -> np.ndarray | list:
    """Frames read; with ``faces`` checked against them (the atlas's correspondence)."""
    out = []
    for path in paths:
        v, f = read_mesh(path)
        if faces is not None and (len(f) != len(faces) or not np.array_equal(f, faces)):
            raise CohortError(f"{name}: {Path(path).name} ({what}) is not in the atlas's "
                              "correspondence (its faces differ from the atlas's)")  # fmt: skip
        out.append(v if faces is not None else (v, f))
    return np.stack(out) if faces is not None else out


def _scale(tracked: Path, name: str) -> float:
    try:
        record = json.loads((tracked / f"{name}.json").read_text(encoding="utf-8"))
        scale = float(record.get("scale", 1.0))
    except (OSError, ValueError, TypeError, AttributeError):
        return 1.0
    return scale if np.isfinite(scale) and scale > 0 else 1.0


def _inputs(tracked: Path, name: str, paths, faces):
    endo = _read_frames(paths, faces, name, "endocardium")
    try:
        epi_paths = read_tracked_frames(tracked / name).get(EPICARDIUM_FOLDER)
    except CohortError:
        epi_paths = None
    if not epi_paths:
        raise CohortError(f"{name}: no epicardium ({name}/{EPICARDIUM_FOLDER}/frame_<kk>): track "
                          "with --myocardium-label (label series) or --epicardia (cine)")  # fmt: skip
    if len(epi_paths) != len(endo):
        raise CohortError(f"{name}: {len(epi_paths)} epicardium frames for {len(endo)} "
                          "endocardium frames")  # fmt: skip
    return endo, _read_frames(epi_paths, None, name, "epicardium"), _scale(tracked, name)


def _fingerprint(settings: dict, endo, epicardia, scale: float) -> str:
    digests = [array_digest(v) + array_digest(f) for v, f in epicardia]
    return config_hash({**settings, "endocardium": array_digest(endo), "epicardia": digests,
                        "scale": scale})  # fmt: skip


def _segment_rows(name: str, maps: WallMaps, segments: np.ndarray) -> list[list]:
    """The rows of :data:`SEGMENT_TABLE` of one subject."""
    per_segment = summary_columns({m: maps.segment_curves(m, segments) for m in PEAK_SENSE})
    members = segments[None, :] == np.arange(1, 18)[:, None]
    rim = (members & maps.on_rim[0][None, :]).sum(axis=1) / members.sum(axis=1)
    return [[name, j + 1, AHA_NAMES[j + 1], *(f"{per_segment[c][j]:.4f}" for c in per_segment),
             f"{rim[j]:.3f}"] for j in range(17)]  # fmt: skip


def _write_vertex_maps(path: Path, ed: np.ndarray, faces, maps: WallMaps) -> None:
    columns = summary_columns({m: maps.measure(m) for m in PEAK_SENSE})
    write_point_mesh(path, ed, faces, {**columns, "on_rim_ed": maps.on_rim[0].astype(float)})


def _stored(path: Path, fingerprint: str) -> WallMaps | None:
    try:
        with np.load(path) as data:
            if str(data["fingerprint"]) != fingerprint:
                return None
            return WallMaps.from_arrays({k: data[k] for k in data.files})
    except (OSError, ValueError, KeyError):
        return None


def _one(name, paths, tracked, faces, segments, landmarks, settings, output) -> dict:
    """One subject: its maps computed and stored, or its failure recorded."""
    start = time.perf_counter()
    try:
        endo, epicardia, scale = _inputs(tracked, name, paths, faces)
        fingerprint = _fingerprint(settings, endo, epicardia, scale)
        maps = wall_maps(endo, faces, epicardia, landmarks.apex, landmarks.base, scale)
        _write_vertex_maps(output / "maps" / f"{name}.vtu", endo[0], faces, maps)
        with atomic_path(output / f"{name}.npz") as tmp, open(tmp, "wb") as fh:
            np.savez(fh, **maps.as_arrays(), fingerprint=fingerprint)
        return _row(name, "computed", len(endo), start, _segment_rows(name, maps, segments))
    except Exception as exc:  # noqa: BLE001 - recorded, the batch goes on
        reason = str(exc) if isinstance(exc, CohortError | ValueError) else (
            f"{type(exc).__name__}: {exc}")  # fmt: skip
        return _row(name, "failed", "", start, error=reason)


def _row(name, status, frames, start, segments=(), error="") -> dict:
    return {"subject": name, "status": status, "frames": frames, "error": error,
            "seconds": round(time.perf_counter() - start, 2), "segments": list(segments)}  # fmt: skip


def run_wall_maps(
    tracked,
    atlas,
    faces,
    landmarks,
    output,
    jobs: int = 1,
    progress: bool = False,
) -> WallOutcome:
    """Every tracked subject's wall maps (see the module), resumably.

    Parameters
    ----------
    tracked : path
        The output of ``symladders track`` with the epicardium.
    atlas : array, shape (k, 3)
    faces : int array, shape (f, 3)
        The atlas (the tracked meshes' correspondence and frame).
    landmarks : Landmarks
        The atlas's apex, base-plane centre and septal point: the long axis of the
        strains' directions and the AHA segments.
    output : path
        The folder written (see the module).
    jobs : int, default 1
        Subjects in parallel (joblib processes).
    progress : bool

    Returns
    -------
    WallOutcome

    Raises
    ------
    CohortError
        No tracked subject in ``tracked``; a bad atlas or landmarks.
    """
    start = time.perf_counter()
    tracked, output = Path(tracked), Path(output)
    atlas = np.asarray(atlas, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    if atlas.ndim != 2 or atlas.shape[1] != 3 or not np.isfinite(atlas).all():
        raise CohortError(f"atlas: expected finite coordinates (k, 3), got shape {atlas.shape}")
    sequences = read_tracked_frames(tracked)
    segments = aha_segments(atlas, landmarks.apex, landmarks.base, landmarks.septum, faces)
    settings = {"atlas": array_digest(atlas), "faces": array_digest(faces),
                "landmarks": landmarks.as_array().tolist(), "definitions": 1}  # fmt: skip
    output.mkdir(parents=True, exist_ok=True)
    write_mesh(output / "atlas.vtk", atlas, faces, atomic=True)
    outcome = WallOutcome(output)
    rows: dict[str, dict] = {}

    def reuse(name, paths, *_):
        try:
            endo, epicardia, scale = _inputs(tracked, name, paths, faces)
        except (CohortError, ValueError, OSError):
            return None  # the worker records why
        maps = _stored(output / f"{name}.npz", _fingerprint(settings, endo, epicardia, scale))
        if maps is None:
            return None
        return _row(name, "reused", len(endo), time.perf_counter(),
                    _segment_rows(name, maps, segments))  # fmt: skip

    tasks = [(n, p, tracked, faces, segments, landmarks, settings, output)
             for n, p in sequences.items()]  # fmt: skip
    for row in run_batch(_one, tasks, jobs=jobs, progress=progress, desc="subjects",
                         unit="subject", reuse=reuse):  # fmt: skip
        rows[row["subject"]] = row
        if row["status"] == "failed":
            outcome.failures[row["subject"]] = row["error"]
        else:
            (outcome.computed if row["status"] == "computed" else outcome.reused).append(
                row["subject"]
            )
        _write_reports(output, settings, rows, list(sequences))
    outcome.seconds = time.perf_counter() - start
    return outcome


def _write_reports(output: Path, settings: dict, rows: dict, order: list) -> None:
    done = [rows[n] for n in order if n in rows]
    atomic_write_text(output / WALL_REPORT, csv_text(
        ["subject", "status", "frames", "seconds", "error"],
        [[r["subject"], r["status"], r["frames"], r["seconds"], r["error"]] for r in done]))  # fmt: skip
    header = ["subject", "segment", "name", "thickness_ed_mm", "thickness_peak_mm",
              "thickening_peak_mm", *(f"{m}_peak_percent" for m in _PERCENT), "on_rim_ed"]  # fmt: skip
    segment_rows = [s for r in done for s in r["segments"]]
    atomic_write_text(output / SEGMENT_TABLE, csv_text(header, segment_rows))
    record = {"settings": settings, "subjects": {r["subject"]: r["status"] for r in done}}
    atomic_write_text(output / "wall.json", json.dumps(record, indent=2))
