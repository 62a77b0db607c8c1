"""A folder of label images to a folder of meshes the study reads: batch, resumable, recorded.

:func:`mesh_label_images` turns every image into the surface of one label
(:func:`~.surface_extraction.extract_surface`) and writes it in the layout
``symladders correspond`` / ``atlas`` / ``study`` read:

* a 3-D image per frame, ``<subject>_ed.nii.gz`` and ``<subject>_es.nii.gz``, gives
  ``<subject>_ed<ext>`` and ``<subject>_es<ext>``;
* a 4-D series ``<subject>.nii.gz`` with ``frames=(ed, es)`` gives the same two meshes.

Each mesh is written atomically with a provenance record beside it
(``<mesh>.json``: the source's SHA-256, label, frame, voxel spacing, affine, the
settings and the extraction report); a rerun skips the meshes whose record matches
(same source bytes, label, frame and settings). With ``myocardium_label``, every image's epicardium (the outer surface of the cavity and
the myocardium, :func:`~.epicardium.extract_epicardium`, with the same settings and cut
plane) is written too, as ``epicardium/<mesh>`` (its meshing report in the mesh's
record): ``symladders track --cine --epicardia`` moves the ED one through the cycle. A
file that fails (label or myocardium absent,
not a label image, 4-D without a frame, frame out of range, no or a singular affine,
the two frames of a subject on different grids) is recorded with its reason in
``meshing.csv`` and the others go on.

With ``rv_label`` (a right-ventricle label in the same images), each mesh also gets
its anatomical landmarks, apex, base-plane centre and septal point
(:func:`~.septum.landmarks_from_labels`), in its provenance record; the output folder
gets :data:`~ladders.study.preparation.landmarks.LANDMARKS_FILE` (``landmarks.csv``),
one row per subject from its end-diastolic mesh (``<subject>_ed<ext>``, the subject
named as ``symladders correspond`` names it): the meshes of this run, and those an
earlier run left in the folder with landmarks in their records (so that images meshed
in several runs, e.g. one subject at a time, make one table). An image whose
landmarks cannot be found (the RV label absent, its centroid on the LV's long axis)
fails like any other: no new mesh, its reason in ``meshing.csv``, no row in the
table. A rerun reuses a mesh only when its record has the landmarks of the same RV
label, taken the same way (``rv_septum``).
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass, field
from pathlib import Path

import nibabel as nib
import numpy as np

from ..batch import run_batch
from ..files import atomic_path, atomic_write_text, file_sha256
from ..meshes.mesh_io import WRITE_EXTENSIONS, write_mesh
from ..preparation.landmarks import LANDMARKS_FILE, Landmarks, write_landmarks
from .epicardium import EPICARDIUM_FOLDER, extract_epicardium
from .label_images import IMAGE_SUFFIXES, ImageError, image_stem, read_label_image
from .septum import SEPTUM_METHODS, landmarks_from_labels
from .surface_extraction import MeshingSettings, extract_surface

__all__ = ["MeshingTask", "MeshingOutcome", "plan_meshing", "mesh_label_images", "REPORT_FILE"]

#: The batch's table of files, written into the output folder.
REPORT_FILE = "meshing.csv"
_PHASES = ("ed", "es")


@dataclass(frozen=True)
class MeshingTask:
    """One mesh to write: its source image, frame and output name."""

    source: Path
    frame: int | None
    output: str
    error: str = ""


@dataclass
class MeshingOutcome:
    """What :func:`mesh_label_images` did: one record per mesh, in order.

    Attributes
    ----------
    folder : Path
    records : list of dict
        ``source``, ``frame``, ``mesh``, ``status`` (ok, skipped, failed), ``error``,
        ``report`` and ``landmarks`` (rows apex, base, septum as nested lists, or None).
    landmarks_file : Path or None
        The landmark table written (with ``rv_label``), else None.
    """

    folder: Path
    records: list = field(default_factory=list)
    landmarks_file: Path | None = None

    @property
    def failed(self) -> list:
        """The records of the meshes that could not be made."""
        return [r for r in self.records if r["status"] == "failed"]

    @property
    def landmarks(self) -> dict:
        """``{subject: Landmarks}`` of the end-diastolic meshes made or reused by this run."""
        return _ed_landmarks(self.records)


def _subject_phase(stem: str) -> tuple[str, str | None]:
    low = stem.lower()
    for phase in _PHASES:
        if low.endswith(f"_{phase}"):
            return stem[: -len(phase) - 1], phase
    return stem, None


def _shape(path: Path):
    try:
        img = nib.load(str(path))
        return img.shape, np.round(np.asarray(img.affine, float), 6)
    except Exception:  # noqa: BLE001 - read_label_image names the problem later
        return None, None


def plan_meshing(
    images, frames: tuple[int, int] | None = None, ext: str = ".vtk"
) -> list[MeshingTask]:
    """The meshes to write for ``images`` (see the module), with the errors known beforehand."""
    tasks: list[MeshingTask] = []
    by_subject: dict[str, dict[str, MeshingTask]] = {}
    for path in sorted(Path(p) for p in images):
        stem = image_stem(path)
        shape, _ = _shape(path)
        if shape is not None and len(shape) == 4 and (shape[3] > 1 or frames is not None):
            if frames is None:
                tasks.append(MeshingTask(path, None, f"{stem}{ext}",
                                         f"{path}: a 4-D series of {shape[3]} frames: name the "
                                         "frames (--frames ED,ES)"))  # fmt: skip
                continue
            for phase, frame in zip(_PHASES, frames):
                tasks.append(MeshingTask(path, int(frame), f"{stem}_{phase}{ext}"))
            continue
        subject, phase = _subject_phase(stem)
        task = MeshingTask(path, None, f"{stem}{ext}")
        tasks.append(task)
        if phase is not None:
            by_subject.setdefault(subject, {})[phase] = task
    # the two frames of a subject must share one grid (shape and affine)
    for subject, pair in by_subject.items():
        if len(pair) != 2:
            continue
        (s1, a1), (s2, a2) = _shape(pair["ed"].source), _shape(pair["es"].source)
        if s1 is not None and s2 is not None and (s1 != s2 or not np.allclose(a1, a2, atol=1e-4)):
            message = (
                f"subject {subject!r}: {pair['ed'].source.name} and {pair['es'].source.name} are on "
                f"different grids (shapes {s1} and {s2}, or different affines): segment both "
                "frames on one grid"
            )
            tasks = [MeshingTask(t.source, t.frame, t.output, message) if t in pair.values() else t
                     for t in tasks]  # fmt: skip
    return tasks


def _ed_landmarks(records: list) -> dict:
    """``{subject: Landmarks}`` of the records of end-diastolic meshes that have landmarks."""
    table = {}
    for r in records:
        subject, phase = _subject_phase(Path(r["mesh"]).stem)
        if r["status"] != "failed" and phase == "ed" and r.get("landmarks") is not None:
            table[subject] = Landmarks.from_array(r["landmarks"])
    return table


def _folder_landmarks(folder: Path, ext: str, records: list) -> dict:
    """``{subject: Landmarks}`` of every end-diastolic mesh of ``folder`` with landmarks.

    This run's records first: its meshes made or reused, none for its failed images;
    then the meshes of the folder this run did not touch (an earlier run on other
    images), from their provenance records.
    """
    table = _ed_landmarks(records)
    touched = {r["mesh"] for r in records}
    for mesh in sorted(folder.glob(f"*{ext}")):
        subject, phase = _subject_phase(mesh.stem)
        if phase != "ed" or mesh.name in touched or subject in table:
            continue
        try:
            record = json.loads(mesh.with_suffix(".json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        landmarks = _landmarks_of(record) if isinstance(record, dict) else None
        if landmarks is not None:
            table[subject] = Landmarks.from_array(landmarks)
    return dict(sorted(table.items()))


def _matching_record(
    record_path: Path,
    sha: str,
    task: MeshingTask,
    label: int,
    settings,
    rv_label: int | None,
    rv_septum: str = "insertion",
    myocardium_label: int | None = None,
) -> dict | None:
    """The provenance record of a mesh made from the same inputs (None: none such)."""
    try:
        record = json.loads(record_path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict):
        return None
    same = (
        record.get("sha256") == sha
        and record.get("label") == label
        and record.get("frame") == task.frame
        and record.get("settings") == settings.as_dict()
    )
    if rv_label is not None:  # the landmarks of this RV label are part of the result
        same = (same and record.get("rv_label") == rv_label and _landmarks_of(record) is not None
                and record.get("rv_septum", "centroid") == rv_septum)  # fmt: skip
    if myocardium_label is not None:  # and the epicardium of this myocardium label
        same = same and (record.get("epicardium") or {}).get("myocardium_label") == myocardium_label
    return record if same else None


def _landmarks_of(record: dict) -> list | None:
    """The landmarks (3 x 3 nested list) of a provenance record, None if it has none usable."""
    entry = record.get("landmarks")
    try:
        return Landmarks(*(entry[k] for k in ("apex", "base", "septum"))).as_array().tolist()
    except (TypeError, KeyError, ValueError):
        return None


def _settings_for(task: MeshingTask, settings: MeshingSettings, cut_planes: dict | None):
    """The settings of one image: its own cut plane where one is given for its file."""
    if not cut_planes:
        return settings
    plane = cut_planes.get(task.source.name, cut_planes.get(str(task.source)))
    if plane is None:
        return settings
    return MeshingSettings(**{**settings.as_dict(), "cut_plane": tuple(plane)})


def _row(task: MeshingTask) -> dict:
    return {"source": str(task.source), "frame": task.frame, "mesh": task.output, "status": "ok",
            "error": "", "report": "", "landmarks": None}  # fmt: skip


def _meshed(
    task: MeshingTask,
    label: int,
    folder: Path,
    settings: MeshingSettings,
    rv_label: int | None = None,
    rv_septum: str = "insertion",
    myocardium_label: int | None = None,
) -> dict | None:
    """``reuse`` of :func:`~ladders.study.batch.run_batch`: the row of an image meshed before
    from the same file, frame, label, settings (and RV and myocardium labels) (None: it is
    meshed)."""
    out = folder / task.output
    if task.error or not out.is_file():
        return None
    if myocardium_label is not None and not (folder / EPICARDIUM_FOLDER / task.output).is_file():
        return None
    try:
        sha = file_sha256(task.source)
    except OSError:
        return None  # the worker records why
    record = _matching_record(out.with_suffix(".json"), sha, task, label, settings, rv_label,
                              rv_septum, myocardium_label)  # fmt: skip
    if record is None:
        return None
    landmarks = None if rv_label is None else _landmarks_of(record)
    return {**_row(task), "status": "skipped", "landmarks": landmarks}


def _mesh_one(
    task: MeshingTask,
    label: int,
    folder: Path,
    settings: MeshingSettings,
    rv_label: int | None = None,
    rv_septum: str = "insertion",
    myocardium_label: int | None = None,
) -> dict:
    out = folder / task.output
    record_path = out.with_suffix(".json")
    row = _row(task)
    if task.error:
        return {**row, "status": "failed", "error": task.error}
    try:
        sha = file_sha256(task.source)
        image = read_label_image(task.source, task.frame)
        vertices, faces, report = extract_surface(image, label, settings)
        landmarks = None
        if rv_label is not None:  # before writing: an image without landmarks gives no mesh
            # the base-plane centre on the valve plane itself, not on the plane moved by the
            # cut's margin: the landmark is anatomical, the margin only removes the lid
            landmarks = landmarks_from_labels(vertices, faces, image, rv_label,
                                              cut_plane=settings.cut_plane,
                                              septum=rv_septum)  # fmt: skip
        epicardium = None
        if myocardium_label is not None:  # before writing: an image without one gives no mesh
            ev, ef, epicardium = extract_epicardium(image, label, myocardium_label, settings)
            write_mesh(folder / EPICARDIUM_FOLDER / task.output, ev, ef, atomic=True)
        write_mesh(out, vertices, faces, atomic=True)
        record = {
            "source": str(task.source.resolve()), "sha256": sha, "label": label,
            "frame": task.frame, "spacing_mm": list(image.spacing),
            "affine": np.asarray(image.affine).tolist(), "settings": settings.as_dict(),
            "report": report.as_dict(),
        }  # fmt: skip
        if landmarks is not None:
            record["rv_label"] = rv_label
            record["rv_septum"] = rv_septum
            record["landmarks"] = {"apex": landmarks.apex.tolist(), "base": landmarks.base.tolist(),
                                   "septum": landmarks.septum.tolist()}  # fmt: skip
        if epicardium is not None:
            record["epicardium"] = {"myocardium_label": myocardium_label,
                                    "mesh": f"{EPICARDIUM_FOLDER}/{task.output}",
                                    "report": epicardium.as_dict()}  # fmt: skip
        atomic_write_text(record_path, json.dumps(record, indent=1))
        return {**row, "report": report.describe(),
                "landmarks": None if landmarks is None else landmarks.as_array().tolist()}  # fmt: skip
    except (ImageError, ValueError, OSError) as exc:
        return {**row, "status": "failed", "error": str(exc)}


def _report_csv(records: list) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=["source", "frame", "mesh", "status", "error", "report"],
                            lineterminator="\n", extrasaction="ignore")  # fmt: skip
    writer.writeheader()
    writer.writerows(records)
    return buf.getvalue()


def mesh_label_images(
    images,
    label: int,
    output,
    frames: tuple[int, int] | None = None,
    settings: MeshingSettings | None = None,
    jobs: int = 2,
    progress: bool = True,
    ext: str = ".vtk",
    cut_planes: dict | None = None,
    rv_label: int | None = None,
    rv_septum: str = "insertion",
    myocardium_label: int | None = None,
) -> MeshingOutcome:
    """Mesh the label ``label`` of every image into ``output`` (see the module).

    Parameters
    ----------
    images : iterable of paths
        NIfTI label images (``.nii``, ``.nii.gz``).
    label : int
        The structure's label (e.g. the left-ventricle cavity).
    output : path
        The mesh folder (created).
    frames : (int, int), optional
        End-diastole and end-systole frames of 4-D series (0-based).
    settings : MeshingSettings, optional
    jobs : int, default 2
        Images meshed in parallel (joblib processes).
    progress : bool
        A progress bar over the files (tqdm).
    ext : str, default ".vtk"
        Mesh format.
    cut_planes : dict, optional
        ``{image file name: (x, y, z, nx, ny, nz)}``: a cut plane per image (e.g. each
        frame's valve plane, in world mm), in place of ``settings.cut_plane``.
    rv_label : int, optional
        The right ventricle's label in the same images: each mesh gets its landmarks
        and the folder a landmark table (see the module). None: no landmarks.
    rv_septum : {"insertion", "centroid"}
        How the septal direction is taken from the RV label: the bisector of its
        insertion points or the direction of its centroid
        (:func:`~.septum.landmarks_from_labels`'s ``septum``).
    myocardium_label : int, optional
        The myocardium's label in the same images: each mesh's epicardium is written
        too, as ``epicardium/<mesh>`` (see the module). None: no epicardium.

    Returns
    -------
    MeshingOutcome
    """
    settings = settings or MeshingSettings()
    ext = "." + ext.lower().lstrip(".")
    if ext not in WRITE_EXTENSIONS:
        raise ValueError(f"ext: expected one of {WRITE_EXTENSIONS}, got {ext!r}")
    if rv_label is not None:
        if isinstance(rv_label, bool) or not isinstance(rv_label, (int, np.integer)):
            raise ValueError(f"rv_label: expected an int (or None), got {rv_label!r}")
        rv_label = int(rv_label)
        if rv_label == int(label):
            raise ValueError(f"rv_label: must differ from the LV's label ({label})")
    if myocardium_label is not None:
        if isinstance(myocardium_label, bool) or myocardium_label in (int(label), rv_label) or (
                not isinstance(myocardium_label, int | np.integer)):  # fmt: skip
            raise ValueError(f"myocardium_label: expected an int other than the cavity's and the "
                             f"RV's labels, got {myocardium_label!r}")  # fmt: skip
        myocardium_label = int(myocardium_label)
    if rv_septum not in SEPTUM_METHODS:
        raise ValueError(f"rv_septum: expected one of {SEPTUM_METHODS}, got {rv_septum!r}")
    images = [Path(p) for p in images]
    bad = [p for p in images if not p.name.lower().endswith(IMAGE_SUFFIXES)]
    if bad:
        raise ImageError(f"{bad[0]}: not a NIfTI label image (.nii or .nii.gz)")
    folder = Path(output)
    folder.mkdir(parents=True, exist_ok=True)
    tasks = [(t, int(label), folder, _settings_for(t, settings, cut_planes), rv_label, rv_septum,
              myocardium_label) for t in plan_meshing(images, frames, ext)]  # fmt: skip
    records = []
    landmarks_file = None if rv_label is None else folder / LANDMARKS_FILE
    try:
        for record in run_batch(_mesh_one, tasks, jobs=jobs, progress=bool(progress),
                                desc="images", unit="mesh", reuse=_meshed):  # fmt: skip
            records.append(record)
    finally:
        order = {t[0].output: i for i, t in enumerate(tasks)}  # the images' order
        records.sort(key=lambda r: order[r["mesh"]])
        with atomic_path(folder / REPORT_FILE) as tmp:
            tmp.write_text(_report_csv(records), encoding="utf-8")
        if landmarks_file is not None:
            write_landmarks(landmarks_file, _folder_landmarks(folder, ext, records))
    return MeshingOutcome(folder, records, landmarks_file)
