"""Track every subject of a folder of corresponded meshes through its label series: batch, resumable.

:func:`track_cohort` pairs each corresponded end-diastolic mesh
``<subject>_ed.<ext>`` of a folder ``symladders correspond`` wrote with the
subject's label series in a folder of images (:func:`~.label_series.find_series`:
``<subject>.nii.gz``, 4-D, or a folder ``<subject>/`` of frames), meshes every frame
of the series as ``symladders mesh`` does
(:func:`~ladders.study.imaging.surface_extraction.extract_surface`, with the
subject's valve cut plane where one is given, per frame or for all frames), tracks
the mesh through the frames (:func:`~.surface_tracking.track_surfaces`, the valve
planes anchoring the base's height where every frame has its own) and writes::

    <output>/<subject>/frame_<kk>.vtk   the tracked mesh of every frame (the atlas's faces)
    <output>/<subject>.json             provenance: inputs' SHA-256, frames, settings,
                                         per-frame quality and meshing, versions
    <output>/tracking.csv               one row per subject: status, frames, reason
    <output>/valve_planes.csv           the valve planes estimated from the images (the
                                         ``--cut-planes`` table, world mm), when any was

A subject given no valve plane has every frame's plane estimated from its images and
its ED mesh's rim (:func:`~.base_planes.estimate_base_planes`) when
``settings.estimate_planes`` says so (by default on thick slices,
:func:`~.base_planes.thick_sliced`); the planes are then used as given ones, kept in the
subject's record (``estimated_planes``) and gathered in ``valve_planes.csv``, which
``cut_planes`` (``symladders track --cut-planes``) takes back, e.g. after an edit.

With ``myocardium_label`` (label series), every frame's epicardium is meshed too and
frame 0's is followed through them; with ``epicardia`` (cine series), a folder of ED
epicardial meshes ``<subject>_ed.<ext>`` in the images' world frame (``symladders mesh
--myocardium-label``'s ``epicardium/``), each subject's is moved with its endocardium
(:mod:`.epicardium_tracking`). Either way the epicardium of every frame is written as
``<output>/<subject>/epicardium/frame_<kk>.vtk`` (its own triangulation), in the frame of
the endocardium's, for the wall thickness (``symladders wall``).

The corresponded meshes are in the atlas's frame: where the folder holds the
subject's record ``correspondence/<subject>.json`` (as ``symladders correspond``
writes it), its transform brings the ED mesh back into the images' world frame
before tracking, and the tracked frames are written in the atlas's frame again (so
that ``frame_00`` is the corresponded ED). Without a record the meshes are taken
to be in the images' world frame.

Every file is written atomically and a subject's record last; a rerun skips the
subjects whose record matches their inputs (the ED mesh's and the series' bytes, the
transform, the label, the settings and the cut planes). A subject that fails (no
series, a bad series, an ED mesh outside the images, the label absent in a frame, a
surface the mesh cannot follow) is recorded with its reason and the others go on.
"""

from __future__ import annotations

import csv
import io
import json
import traceback
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..batch import run_batch
from ..files import atomic_write_text, file_sha256
from ..imaging.surface_extraction import MeshingSettings, extract_surface
from ..meshes.mesh_io import read_mesh, write_mesh
from ..preparation.alignment import SimilarityTransform
from ..volume import boundary_vertices
from .base_planes import estimate_base_planes, gather_plane_table, planes_wanted
from .cine_tracking import CineTrackingSettings, track_cine
from .epicardium_tracking import EPICARDIUM_FOLDER, track_cine_with_epicardium, track_epicardium
from .label_series import SeriesError, check_field_of_view, open_series
from .settings import TrackingSettings
from .surface_tracking import TrackedSurfaces, track_surfaces
from .tracking_plan import TrackingTask, plan_tracking

__all__ = ["TrackingTask", "TrackingOutcome", "plan_tracking", "track_cohort", "REPORT_FILE"]

#: The batch's table of subjects, written into the output folder.
REPORT_FILE = "tracking.csv"


@dataclass
class TrackingOutcome:
    """What :func:`track_cohort` did: one row per subject, in natural order.

    Attributes
    ----------
    output : Path
    records : list of dict
        ``subject``, ``status`` (ok, skipped, failed), ``frames``, ``mean_distance``
        (largest over the frames, mm), ``error``.
    planes_file : Path or None
        ``valve_planes.csv``, the planes estimated from the images, when any was.
    """

    output: Path
    records: list = field(default_factory=list)
    planes_file: Path | None = None

    @property
    def failed(self) -> list:
        """The rows of the subjects that could not be tracked."""
        return [r for r in self.records if r["status"] == "failed"]


def _planes_of(task: TrackingTask, cut_planes: dict | None) -> dict | None:
    """``{frame or "all": plane}`` of a subject (keyed by subject or series file name)."""
    if not cut_planes:
        return None
    keys = [task.subject] + ([task.series.name, str(task.series)] if task.series else [])
    entry = next((cut_planes[k] for k in keys if k in cut_planes), None)
    if entry is None:
        return None
    if isinstance(entry, dict):
        return {str(k): [float(x) for x in v] for k, v in entry.items()}
    return {"all": [float(x) for x in entry]}


def _frame_settings(meshing: MeshingSettings, planes: dict | None, frame: int) -> MeshingSettings:
    if not planes:
        return meshing
    plane = planes.get(str(frame), planes.get("all"))
    if plane is None:
        return meshing
    return MeshingSettings(**{**meshing.as_dict(), "cut_plane": tuple(plane)})


def _series_hashes(source: Path) -> list[str]:
    files = sorted(p for p in source.iterdir() if p.is_file()) if source.is_dir() else [source]
    return [file_sha256(p) for p in files]


def _anchored(settings, planes) -> bool:
    """Whether per-frame planes may anchor the affine fits (label series, projection)."""
    return (
        isinstance(settings, TrackingSettings)
        and settings.method == "projection"
        and any(k != "all" for k in planes or {})
    )


def _base_planes(planes, n_frames: int) -> np.ndarray | None:
    """Every frame's own plane ``(n_frames, 6)``, or None when a frame has none."""
    if not planes or not all(str(t) in planes for t in range(n_frames)):
        return None
    return np.array([planes[str(t)] for t in range(n_frames)], dtype=float)


def _fingerprint(task: TrackingTask, label: int, settings: TrackingSettings, planes,
                 myocardium: int | None = None) -> dict:  # fmt: skip
    out = {
        "ed_sha256": file_sha256(task.ed),
        "series_sha256": _series_hashes(task.series),
        "transform": task.transform,
        "label": int(label),
        "settings": settings.key(),
        "cut_planes": planes,
    }
    if _anchored(settings, planes):  # results of before the anchors are not reused
        out["base_anchors"] = True
    if myocardium is not None:  # keys only when set: the records without them stay valid
        out["myocardium_label"] = int(myocardium)
    if task.epicardium is not None:
        out["epicardium_sha256"] = file_sha256(task.epicardium)
    return out


def _epicardium_wanted(task: TrackingTask, settings, myocardium: int | None) -> bool:
    cine = isinstance(settings, CineTrackingSettings)
    return task.epicardium is not None if cine else myocardium is not None


def _frame_name(t: int, n: int, ext: str) -> str:
    return f"frame_{t:0{max(2, len(str(n - 1)))}d}{ext}"


def _row(task: TrackingTask, status: str, **extra) -> dict:
    return {"subject": task.subject, "status": status, "frames": extra.get("frames", ""),
            "mean_distance": extra.get("mean_distance", ""), "error": extra.get("error", "")}  # fmt: skip


def _done(task: TrackingTask, output: Path, label: int, settings, planes, ext: str,
          myocardium: int | None = None) -> dict | None:  # fmt: skip
    """``reuse`` of :func:`~ladders.study.batch.run_batch`: the row of a subject tracked before."""
    if task.error:
        return None
    try:
        record = json.loads((output / f"{task.subject}.json").read_text(encoding="utf-8"))
        fingerprint = _fingerprint(task, label, settings, planes, myocardium)
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or record.get("status") != "ok":
        return None
    if record.get("fingerprint") != fingerprint:
        return None
    n = int(record.get("n_frames", 0))
    folders = [output / task.subject]
    if _epicardium_wanted(task, settings, myocardium):
        folders.append(output / task.subject / EPICARDIUM_FOLDER)
    if n < 1 or not all((f / _frame_name(t, n, ext)).is_file() for f in folders for t in range(n)):
        return None
    return _row(task, "skipped", frames=n, mean_distance=record.get("max_mean_distance", ""))


def _clear(output: Path, subject: str, ext: str) -> None:
    for folder in (output / subject, output / subject / EPICARDIUM_FOLDER):
        if folder.is_dir():
            for path in folder.glob(f"frame_*{ext}"):
                path.unlink(missing_ok=True)


def _track_one(task: TrackingTask, output: Path, label: int, settings: TrackingSettings,
               planes, ext: str, myocardium: int | None = None) -> dict:  # fmt: skip
    record: dict = {"subject": task.subject, "status": "failed"}
    try:
        if task.error:
            raise SeriesError(task.error)
        record["fingerprint"] = _fingerprint(task, label, settings, planes, myocardium)
        cine = isinstance(settings, CineTrackingSettings)
        series = open_series(task.series, labels=not cine)
        vertices, faces = read_mesh(task.ed)
        transform = (
            None if task.transform is None else SimilarityTransform.from_dict(task.transform)
        )
        scanner = vertices if transform is None else transform.inverse().apply(vertices)
        check_field_of_view(scanner, series, f"{task.ed}")
        reports, epicardium = [], None
        if cine:  # B-spline registrations of the intensities, forward and backward
            if task.epicardium is None:
                moved = track_cine(series.intensities(), series.affine, scanner, settings)
            else:
                epi_ed, epi_faces = read_mesh(task.epicardium)
                check_field_of_view(epi_ed, series, f"{task.epicardium}")
                moved, epi = track_cine_with_epicardium(series.intensities(), series.affine,
                                                        scanner, epi_ed, settings)  # fmt: skip
                epicardium = TrackedSurfaces(epi, epi_faces)
            tracked = TrackedSurfaces(moved, faces)
        else:
            frames = series.frames()
            if planes_wanted(settings, series.affine, faces, planes):
                estimate = estimate_base_planes(scanner, faces, frames, label)
                record["estimated_planes"] = estimate.as_dict()
                planes = {str(t): [float(x) for x in p] for t, p in enumerate(estimate.planes)}
            elif (not planes and getattr(settings, "estimate_planes", "never") != "never"
                  and len(boundary_vertices(faces)) == 0):  # fmt: skip
                record["estimated_planes"] = {"skipped": "the ED mesh is closed (its label was "
                                              "meshed without a valve plane): the estimate "
                                              "starts from an open mesh's rim"}  # fmt: skip
            surfaces = []
            meshing = [_frame_settings(settings.meshing, planes, t) for t in range(len(frames))]
            for image, frame_meshing in zip(frames, meshing):
                v, f, report = extract_surface(image, label, frame_meshing)
                surfaces.append((v, f))
                reports.append(report.as_dict())
            base = _base_planes(planes, series.n_frames) if _anchored(settings, planes) else None
            record["base_anchors"] = base is not None
            tracked = track_surfaces(scanner, faces, surfaces, settings, base_planes=base)
            if myocardium is not None:
                epicardium, epi_reports = track_epicardium(frames, label, myocardium, settings,
                                                           meshing, base)  # fmt: skip
        _clear(output, task.subject, ext)
        for t in range(series.n_frames):
            frame = (
                tracked.vertices[t] if transform is None else transform.apply(tracked.vertices[t])
            )
            write_mesh(output / task.subject / _frame_name(t, series.n_frames, ext), frame, faces,
                       atomic=True)  # fmt: skip
        if epicardium is not None:
            for t in range(series.n_frames):
                v = epicardium.vertices[t]
                write_mesh(output / task.subject / EPICARDIUM_FOLDER
                           / _frame_name(t, series.n_frames, ext),
                           v if transform is None else transform.apply(v), epicardium.faces,
                           atomic=True)  # fmt: skip
            record["epicardium"] = {
                "myocardium_label": None if cine else int(myocardium),
                "ed_mesh": None if task.epicardium is None else str(task.epicardium.resolve()),
                "n_vertices": int(epicardium.vertices.shape[1]),
                "quality": epicardium.quality, "surfaces": [] if cine else epi_reports,
            }  # fmt: skip
        worst = max((q["mean_distance"] for q in tracked.quality), default=float("nan"))
        record.update(
            status="ok", ed_mesh=str(task.ed.resolve()), series=[str(p.resolve()) for p in series.files],
            n_frames=series.n_frames, label=int(label), frame="atlas" if transform else "images",
            affine=series.affine.tolist(), spacing_mm=np.linalg.norm(series.affine[:3, :3], axis=0).tolist(),
            scale=1.0 if transform is None else float(transform.scale),
            settings=settings.as_dict(), cut_planes=record["fingerprint"]["cut_planes"],
            quality=tracked.quality,
            surfaces=reports, max_mean_distance=worst, versions=_versions(),
        )  # fmt: skip
        row = _row(task, "ok", frames=series.n_frames, mean_distance=worst)
    except Exception as exc:  # noqa: BLE001 - a failing subject must not stop the others
        reason = (
            str(exc)
            if isinstance(exc, SeriesError | ValueError | OSError)
            else (f"{type(exc).__name__}: {exc}")
        )
        record.update(reason=reason, traceback=traceback.format_exc())
        _clear(output, task.subject, ext)
        row = _row(task, "failed", error=reason)
    atomic_write_text(output / f"{task.subject}.json", json.dumps(record, indent=1, default=float))
    return row


def _versions() -> dict:
    from ..running.provenance import package_versions

    return package_versions()


def _report_csv(rows: list) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=["subject", "status", "frames", "mean_distance", "error"],
                            lineterminator="\n", extrasaction="ignore")  # fmt: skip
    writer.writeheader()
    writer.writerows(rows)
    return buf.getvalue()


def track_cohort(
    meshes_folder,
    images,
    output,
    label: int,
    settings: TrackingSettings | CineTrackingSettings | None = None,
    cut_planes: dict | None = None,
    jobs: int = 2,
    progress: bool = True,
    ext: str = ".vtk",
    myocardium_label: int | None = None,
    epicardia=None,
) -> TrackingOutcome:
    """Track every subject's corresponded ED mesh through its label series (see the module).

    Parameters
    ----------
    meshes_folder : path
        A folder of ``<subject>_ed.<ext>`` meshes in the atlas's correspondence (the
        output of ``symladders correspond``, with its ``correspondence/`` records).
    images : path or iterable of paths
        A folder of label series (4-D ``<subject>.nii.gz`` or folders of frames).
    output : path
        The folder written (created).
    label : int
        The label meshed (e.g. the left-ventricle cavity).
    settings : TrackingSettings or CineTrackingSettings, optional
        With the meshing settings of the frames (``settings.meshing``). A
        :class:`~.cine_settings.CineTrackingSettings` tracks cine intensity series
        instead (:func:`~.cine_tracking.track_cine`: the frames are not meshed, the ED
        mesh is moved by B-spline registrations of the images; ``label`` and
        ``cut_planes`` are not used).
    cut_planes : dict, optional
        ``{subject or series file name: plane}`` with ``plane`` ``(x, y, z, nx, ny, nz)``
        in world mm for every frame, or ``{frame: plane}`` per frame (0-based; a key
        ``"all"`` for the others). Where every frame of a subject has its own plane
        (the valve plane moving with the base) and the method is the projection, the
        planes also anchor the affine fits (:func:`~.surface_tracking.track_surfaces`'s
        ``base_planes``; the record's ``base_anchors``). A subject given none has its
        planes estimated from its images when ``settings.estimate_planes`` says so (see
        the module).
    jobs : int, default 2
        Subjects tracked in parallel (joblib processes).
    progress : bool
        A progress bar over the subjects (tqdm).
    ext : str, default ".vtk"
        Format of the tracked meshes.
    myocardium_label : int, optional
        Label series: the myocardium's label; every frame's epicardium is meshed and
        followed too (see the module).
    epicardia : path, optional
        Cine series: a folder of ED epicardia ``<subject>_ed.<ext>`` in the images' world
        frame, each moved with its subject's endocardium (see the module).

    Returns
    -------
    TrackingOutcome
    """
    settings = settings or TrackingSettings()
    if isinstance(label, bool) or not isinstance(label, int | np.integer):
        raise ValueError(f"label: expected an int, got {label!r}")
    ext = "." + ext.lower().lstrip(".")
    cine = isinstance(settings, CineTrackingSettings)
    if myocardium_label is not None:
        if cine:
            raise ValueError("myocardium_label: for label series; cine series take epicardia")
        if isinstance(myocardium_label, bool) or not isinstance(myocardium_label, int | np.integer):
            raise ValueError(f"myocardium_label: expected an int, got {myocardium_label!r}")
        if int(myocardium_label) == int(label):
            raise ValueError(f"myocardium_label: must differ from the cavity's label ({label})")
        myocardium_label = int(myocardium_label)
    if epicardia is not None and not cine:
        raise ValueError("epicardia: for cine series; label series take myocardium_label")
    output = Path(output)
    tasks = plan_tracking(meshes_folder, images, epicardia)
    output.mkdir(parents=True, exist_ok=True)
    jobs_args = [(t, output, int(label), settings, _planes_of(t, cut_planes), ext,
                  myocardium_label) for t in tasks]  # fmt: skip
    rows = []
    try:
        for row in run_batch(_track_one, jobs_args, jobs=jobs, progress=bool(progress),
                             desc="subjects", unit="subject", reuse=_done):  # fmt: skip
            rows.append(row)
    finally:
        order = {t.subject: i for i, t in enumerate(tasks)}
        rows.sort(key=lambda r: order[r["subject"]])
        atomic_write_text(output / REPORT_FILE, _report_csv(rows))
        planes_file = gather_plane_table(output, [t.subject for t in tasks])
    return TrackingOutcome(output, rows, planes_file)
