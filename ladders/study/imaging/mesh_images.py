"""A folder of label images to a folder of meshes the study reads: batch, resumable, recorded.

:func:`mesh_label_images` turns every image into the surface of one label
(:func:`~.surface_extraction.extract_surface`) and writes it in the layout
``symladders correspond`` / ``atlas`` / ``study`` read:

* a 3-D image per frame, ``<subject>_ed.nii.gz`` and ``<subject>_es.nii.gz``, gives
  ``<subject>_ed<ext>`` and ``<subject>_es<ext>``;
* a 4-D series ``<subject>.nii.gz`` gives the same two meshes, of the frames given
  (``frames``) or, without, of its first frame (ED) and its frame of least cavity
  volume (ES, :mod:`.series_frames`).

Each mesh is written atomically with a provenance record beside it
(``<mesh>.json``: the source's SHA-256, label, frame, voxel spacing, affine, the
settings and the extraction report); a rerun skips the meshes whose record matches
(same source bytes, label, frame and settings). With ``myocardium_label``, every image's
epicardium (the outer surface of the cavity and the myocardium,
:func:`~.epicardium.extract_epicardium`, with the same settings and cut plane) is written
too, as ``epicardium/<mesh>`` (its meshing report in the mesh's record): ``symladders
track --cine --epicardia`` moves the ED one through the cycle. A file that fails (label
or myocardium absent, not a label image, a frame out of range, no or a singular affine,
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
from dataclasses import dataclass, field, replace
from pathlib import Path

import nibabel as nib
import numpy as np

from ..batch import run_batch
from ..files import atomic_path, atomic_write_text, file_sha256
from ..meshes.mesh_io import WRITE_EXTENSIONS, write_mesh
from ..preparation.landmarks import LANDMARKS_FILE, write_landmarks
from .epicardium import EPICARDIUM_FOLDER, extract_epicardium
from .label_images import IMAGE_SUFFIXES, ImageError, image_stem, read_label_image
from .meshing_landmarks import PHASES, ed_landmarks, folder_landmarks, landmarks_of, subject_phase
from .plane_table import image_names, plane_for
from .septum import SEPTUM_METHODS, landmarks_from_labels
from .series_frames import least_volume_frame
from .surface_extraction import MeshingSettings, extract_surface

__all__ = ["MeshingTask", "MeshingOutcome", "plan_meshing", "mesh_label_images", "REPORT_FILE"]

#: The batch's table of files, written into the output folder.
REPORT_FILE = "meshing.csv"


@dataclass(frozen=True)
class MeshingTask:
    """One mesh to write: its source image, frame and output name.

    ``how`` says how the frame of a 4-D series was chosen (one of
    :data:`~.series_frames.FRAME_CHOICES`; empty for a 3-D image) and ``volumes`` are the
    series' cavity volumes per frame (mm^3) when they chose it.
    """

    source: Path
    frame: int | None
    output: str
    error: str = ""
    how: str = ""
    volumes: tuple = ()


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
        return ed_landmarks(self.records)


def _shape(path: Path):
    try:
        img = nib.load(str(path))
        return img.shape, np.round(np.asarray(img.affine, float), 6)
    except Exception:  # noqa: BLE001 - read_label_image names the problem later
        return None, None


def _series_tasks(path: Path, stem: str, frames, label: int, ext: str) -> list[MeshingTask]:
    """The ED and ES tasks of a 4-D series: its frames given, tabled, or found (the first
    frame; the frame of least volume of ``label``)."""
    volumes: tuple = ()
    if isinstance(frames, dict) and stem in frames:
        chosen, how = frames[stem], ("table", "table")
    elif frames is not None and not isinstance(frames, dict):
        chosen, how = frames, ("given", "given")
    else:
        try:
            es, found = least_volume_frame(path, label)
        except ImageError as exc:
            return [MeshingTask(path, None, f"{stem}_{phase}{ext}", str(exc)) for phase in PHASES]
        chosen, how, volumes = (0, es), ("first frame", "least volume"), tuple(found)
    return [MeshingTask(path, int(frame), f"{stem}_{phase}{ext}", how=h, volumes=volumes)
            for phase, frame, h in zip(PHASES, chosen, how)]  # fmt: skip


def plan_meshing(
    images, frames: tuple[int, int] | dict | None = None, ext: str = ".vtk", label: int = 1
) -> list[MeshingTask]:
    """The meshes to write for ``images`` (see the module), with the errors known beforehand.

    ``frames`` as :func:`mesh_label_images`'s; a 4-D series whose frames are not given is
    read here, to find the frame of least volume of ``label`` (its end-systole).
    """
    tasks: list[MeshingTask] = []
    by_subject: dict[str, dict[str, MeshingTask]] = {}
    for path in sorted(Path(p) for p in images):
        stem = image_stem(path)
        shape, _ = _shape(path)
        if shape is not None and len(shape) == 4 and (shape[3] > 1 or frames is not None):
            tasks.extend(_series_tasks(path, stem, frames, label, ext))
            continue
        subject, phase = subject_phase(stem)
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
            tasks = [replace(t, error=message) if t in pair.values() else t for t in tasks]
    return tasks


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
        same = (same and record.get("rv_label") == rv_label and landmarks_of(record) is not None
                and record.get("rv_septum", "centroid") == rv_septum)  # fmt: skip
    if myocardium_label is not None:  # and the epicardium of this myocardium label
        same = same and (record.get("epicardium") or {}).get("myocardium_label") == myocardium_label
    return record if same else None


def _settings_for(task: MeshingTask, settings: MeshingSettings, cut_planes: dict | None):
    """The settings of one image: its own cut plane where one is given for its file."""
    plane = plane_for(cut_planes, image_names(task.source), task.frame)
    if plane is None:
        return settings
    return MeshingSettings(**{**settings.as_dict(), "cut_plane": tuple(plane)})


def _row(task: MeshingTask) -> dict:
    return {"source": str(task.source), "frame": task.frame, "frame_choice": task.how,
            "mesh": task.output, "status": "ok", "error": "", "report": "",
            "landmarks": None}  # fmt: skip


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
    landmarks = None if rv_label is None else landmarks_of(record)
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
            "frame": task.frame, "frame_choice": task.how, "spacing_mm": list(image.spacing),
            "affine": np.asarray(image.affine).tolist(), "settings": settings.as_dict(),
            "report": report.as_dict(),
        }  # fmt: skip
        if task.volumes:
            record["cavity_volumes_mm3"] = list(task.volumes)
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
    writer = csv.DictWriter(buf, fieldnames=["source", "frame", "frame_choice", "mesh", "status", "error",
                                                "report"],
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
    frames : (int, int) or dict, optional
        End-diastole and end-systole frames of the 4-D series (0-based): one pair for
        every series, or ``{subject: (ed, es)}`` per series (the subject named from the
        file, :func:`~.label_images.image_stem`). A series without them is meshed at
        its first frame (ED) and its frame of least volume of ``label`` (ES,
        :func:`~.series_frames.least_volume_frame`). ``meshing.csv`` and every mesh's
        record state the frame and how it was chosen (``frame_choice``).
    settings : MeshingSettings, optional
    jobs : int, default 2
        Images meshed in parallel (joblib processes).
    progress : bool
        A progress bar over the files (tqdm).
    ext : str, default ".vtk"
        Mesh format.
    cut_planes : dict, optional
        ``{image file name or path: plane}`` with ``plane`` ``(x, y, z, nx, ny, nz)`` (world
        mm) for every frame, or ``{frame: plane}`` per frame of a series (a key ``"all"``
        for the others; :func:`~.plane_table.planes_by_image`), in place of
        ``settings.cut_plane``.
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
              myocardium_label) for t in plan_meshing(images, frames, ext, int(label))]  # fmt: skip
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
            write_landmarks(landmarks_file, folder_landmarks(folder, ext, records))
    return MeshingOutcome(folder, records, landmarks_file)
