"""The study of whole cycles: every subject's frames transported to the atlas, resumable.

Layout of the output folder::

    <output>/cycle_study.json     settings, atlas digest, subjects and their status
    <output>/cycle_study.csv      one row per subject: status, frames, seconds, error
    <output>/atlas.vtk            the atlas
    <output>/<subject>.npz        the transported frames (:class:`FrameTransport`'s fields)
                                  and the fingerprint of what they depend on

Every subject is stored as soon as it finishes (atomically); a rerun skips the subjects
stored with the same frames, atlas and settings, and a subject that fails is recorded
with its reason while the others go on. The frames come from ``symladders track``'s
output (``<subject>/frame_<kk>.<ext>``, :func:`read_tracked_frames`) or from arrays.
"""

from __future__ import annotations

import csv
import io
import json
import re
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..batch import run_batch
from ..errors import CohortError
from ..files import array_digest, atomic_path, atomic_write_text, config_hash
from ..meshes.mesh_io import MESH_EXTENSIONS, read_mesh, write_mesh
from ..recommendations import RECOMMENDED_ALPHA2
from ..running.pipeline import StudyConfig, make_space
from .frame_transport import check_frames, transport_frames

__all__ = ["CycleStudyOutcome", "read_tracked_frames", "run_cycle_study", "REPORT_FILE"]

REPORT_FILE = "cycle_study.csv"
_FRAME = re.compile(r"^frame_(\d+)$")


@dataclass
class CycleStudyOutcome:
    """What :func:`run_cycle_study` did.

    Attributes
    ----------
    output : Path
    computed, reused : list of str
        Subjects transported now, and those found stored with the same inputs.
    failures : dict
        ``{subject: reason}``.
    seconds : float
    """

    output: Path
    computed: list = field(default_factory=list)
    reused: list = field(default_factory=list)
    failures: dict = field(default_factory=dict)
    seconds: float = 0.0


def read_tracked_frames(folder) -> dict[str, list[Path]]:
    """``{subject: [frame files in order]}`` from a folder of ``<subject>/frame_<kk>.<ext>``.

    Raises
    ------
    CohortError
        No such folder, no subject with frames, a frame number missing or given twice.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise CohortError(f"frames: {folder} is not a folder")
    out = {}
    for sub in sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith(".")):
        numbered: dict[int, Path] = {}
        for path in sub.iterdir():
            match = _FRAME.match(path.stem)
            if not match or path.suffix.lower() not in MESH_EXTENSIONS:
                continue
            t = int(match.group(1))
            if t in numbered:
                raise CohortError(f"frames: {sub.name}: frame {t} given twice ({numbered[t].name}, "
                                  f"{path.name})")  # fmt: skip
            numbered[t] = path
        if not numbered:
            continue
        missing = sorted(set(range(max(numbered) + 1)) - set(numbered))
        if missing:
            raise CohortError(f"frames: {sub.name}: frame(s) {missing} missing")
        out[sub.name] = [numbered[t] for t in range(len(numbered))]
    if not out:
        raise CohortError(f"frames: {folder} holds no '<subject>/frame_<kk>.<ext>' meshes")
    return out


def _load(frames, faces: np.ndarray, k: int, name: str) -> np.ndarray:
    """A subject's frames as an array, read (and checked against the atlas) when given as paths."""
    if isinstance(frames, (list, tuple)) and frames and isinstance(frames[0], (str, Path)):
        stack = []
        for path in frames:
            v, f = read_mesh(path)
            if len(v) != k or not np.array_equal(f, faces):
                raise CohortError(f"{name}: {Path(path).name} is not in the atlas's correspondence "
                                  f"({len(v)} vertices, the atlas has {k}; the faces must be "
                                  "the atlas's)")  # fmt: skip
            stack.append(v)
        frames = stack
    return check_frames(frames, k, name=name)


def _fingerprint(settings: dict, frames: np.ndarray) -> str:
    return config_hash({**settings, "frames": array_digest(frames)})


def _stored(path: Path, fingerprint: str):
    try:
        with np.load(path) as data:
            if str(data["fingerprint"]) != fingerprint:
                return None
            return {k: data[k] for k in data.files}
    except (OSError, ValueError, KeyError):
        return None


def _transport_one(name, frames, atlas, faces, config, use_residuals, settings, output):
    """One subject: its frames transported and stored, or its failure returned."""
    start = time.perf_counter()
    try:
        x = _load(frames, faces, len(atlas), name)
        fingerprint = _fingerprint(settings, x)
        space = make_space(config, atlas, config.alpha2[0])
        result = transport_frames(space, atlas, x, use_residuals=use_residuals,
                                  model=config.model)  # fmt: skip
        with atomic_path(output / f"{name}.npz") as tmp, open(tmp, "wb") as fh:
            np.savez(fh, transported=result.transported, registration_rms=result.registration_rms,
                     converged=result.converged, seconds=result.seconds,
                     fingerprint=fingerprint)  # fmt: skip
        return {"subject": name, "status": "computed", "frames": len(x),
                "seconds": round(time.perf_counter() - start, 2), "error": ""}  # fmt: skip
    except Exception as exc:  # noqa: BLE001 - recorded, the batch goes on
        return {"subject": name, "status": "failed", "frames": "",
                "seconds": round(time.perf_counter() - start, 2),
                "error": f"{type(exc).__name__}: {exc}"}  # fmt: skip


def run_cycle_study(
    atlas,
    faces,
    sequences: dict,
    output,
    alpha2: float = RECOMMENDED_ALPHA2,
    deformation: str = "lddmm",
    use_residuals: bool = True,
    jobs: int = 1,
    progress: bool = False,
    **registration,
) -> CycleStudyOutcome:
    """Transport every subject's frames to the atlas (:func:`transport_frames`), resumably.

    Parameters
    ----------
    atlas : array, shape (k, 3)
    faces : int array, shape (f, 3)
    sequences : dict
        ``{subject: frames}``, each an array ``(n_frames, k, 3)`` or a list of mesh files
        in order (:func:`read_tracked_frames`); ED first, in the atlas's correspondence.
    output : path
        The folder written (see the module).
    alpha2 : float, default 100
        The regularisation ``alpha^2`` of eq. 3; the default is the value for group
        statistics (:data:`~ladders.study.recommendations.RECOMMENDED_ALPHA2`).
    deformation : str or DeformationModel
        A registered deformation model's name (``"lddmm"``, ``"svf"``, any a user
        registers) or a model.
    use_residuals : bool, default True
    jobs : int, default 1
        Subjects in parallel (joblib processes).
    progress : bool
    **registration
        Overrides of the study's registration settings (``sigma=``, ``max_iter=``, ...).

    Returns
    -------
    CycleStudyOutcome
    """
    start = time.perf_counter()
    atlas = np.asarray(atlas, dtype=np.float64)
    if atlas.ndim != 2 or atlas.shape[1] != 3 or not np.isfinite(atlas).all():
        raise ValueError(f"atlas: expected finite coordinates of shape (k, 3), got {atlas.shape}")
    faces = np.asarray(faces, dtype=np.int64)
    if not sequences:
        raise CohortError("sequences: no subject given")
    bad = [n for n in sequences if not n or "/" in n or "\\" in n or n in (".", "..")]
    if bad:
        raise CohortError(f"sequences: subject names must be plain file names, got {bad}")
    config = StudyConfig.build(alpha2=(float(alpha2),), deformation=deformation, **registration)
    settings = {**config.as_dict(), "use_residuals": bool(use_residuals),
                "atlas": array_digest(atlas), "faces": array_digest(faces)}  # fmt: skip
    output = Path(output)
    output.mkdir(parents=True, exist_ok=True)
    write_mesh(output / "atlas.vtk", atlas, faces, atomic=True)
    outcome = CycleStudyOutcome(output)
    rows: dict[str, dict] = {}

    def reuse(name, frames, *_):
        try:
            x = _load(frames, faces, len(atlas), name)
        except (CohortError, ValueError, OSError):
            return None  # the worker records the reason
        stored = _stored(output / f"{name}.npz", _fingerprint(settings, x))
        if stored is None:
            return None
        return {"subject": name, "status": "reused", "frames": len(x),
                "seconds": float(stored["seconds"]), "error": ""}  # fmt: skip

    tasks = [(n, f, atlas, faces, config, use_residuals, settings, output)
             for n, f in sequences.items()]  # fmt: skip
    for row in run_batch(_transport_one, tasks, jobs=jobs, progress=progress, desc="subjects",
                         unit="subject", ordered=False, reuse=reuse):  # fmt: skip
        rows[row["subject"]] = row
        if row["status"] == "failed":
            outcome.failures[row["subject"]] = row["error"]
        else:
            (outcome.computed if row["status"] == "computed" else outcome.reused).append(
                row["subject"]
            )
        _write_reports(output, settings, rows, sequences)
    outcome.seconds = time.perf_counter() - start
    return outcome


def _write_reports(output: Path, settings: dict, rows: dict, sequences: dict) -> None:
    ordered = [rows[n] for n in sequences if n in rows]
    buf = io.StringIO()
    writer = csv.DictWriter(buf, ["subject", "status", "frames", "seconds", "error"],
                            lineterminator="\n")  # fmt: skip
    writer.writeheader()
    writer.writerows(ordered)
    atomic_write_text(output / REPORT_FILE, buf.getvalue())
    record = {"settings": settings, "subjects": {r["subject"]: r["status"] for r in ordered}}
    atomic_write_text(output / "cycle_study.json", json.dumps(record, indent=2))
