"""The inputs folder of ``symladders run``: the subjects table turned into what each command reads.

The commands name a subject after its files (``<subject>_ed.nii.gz``,
``<subject>.nii.gz``); a user's files rarely are (UK Biobank gives every subject a
folder of files of the same names). :func:`write_route_inputs` writes, in
``OUTPUT/inputs/``:

* ``images/``: a link per image named after its subject (``<subject>.nii.gz`` for a
  series, ``<subject>_ed.nii.gz`` and ``<subject>_es.nii.gz`` for two 3-D images),
  read by ``symladders mesh``;
* ``series/``: the series of the subjects tracked through the cycle, read by
  ``symladders track`` (a link; a copy turned so that it starts at end-diastole when
  the table's ED frame is not frame 0);
* ``tracked_meshes/``: links to those subjects' corresponded ED meshes and
  correspondence records (written by the step ``correspond``), so that ``symladders
  track`` follows them alone;
* ``frames.csv``: the ED and ES frames the table gives (``subject,ed,es``);
* ``landmarks.csv``: the landmarks the table gives;
* ``planes.csv``: the valve planes of the settings, per image and frame, in the table
  format ``symladders mesh --cut-planes`` reads.

Each file is written only when its content changes, so that a rerun leaves the
fingerprints of unchanged inputs as they were.
"""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path

import numpy as np

from ladders.tables import Column, TableError, read_table

from ..files import atomic_write_text
from ..preparation.landmarks import LANDMARK_COLUMNS
from .subjects_table import SubjectsTable, SubjectsTableError

__all__ = ["RouteInputs", "write_route_inputs", "image_suffix", "series_frames"]


def image_suffix(path: Path) -> str:
    """``.nii.gz`` or ``.nii``."""
    return ".nii.gz" if path.name.lower().endswith(".nii.gz") else ".nii"


class RouteInputs:
    """The paths of the inputs folder (see the module)."""

    def __init__(self, output: Path):
        self.folder = Path(output) / "inputs"
        self.images = self.folder / "images"
        self.series = self.folder / "series"
        self.tracked_meshes = self.folder / "tracked_meshes"
        self.frames = self.folder / "frames.csv"
        self.landmarks = self.folder / "landmarks.csv"
        self.planes = self.folder / "planes.csv"

    def image_files(self) -> list[Path]:
        """The links in ``images/`` (those of an earlier run too)."""
        return sorted(self.images.iterdir()) if self.images.is_dir() else []

    def image_paths(self, table: SubjectsTable) -> list[Path]:
        """The links ``images/`` holds for ``table``, sorted."""
        names = []
        for e in table.entries:
            if e.series is not None:
                names.append(f"{e.subject}{image_suffix(e.series)}")
            else:
                names += [f"{e.subject}_{p}{image_suffix(t)}"
                          for p, t in (("ed", e.ed_image), ("es", e.es_image))]  # fmt: skip
        return [self.images / n for n in sorted(names)]


def _write_if_changed(path: Path, text: str) -> None:
    if path.is_file() and path.read_text(encoding="utf-8") == text:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, text)


def _link(link: Path, target: Path) -> None:
    if link.is_symlink() and Path(os.readlink(link)) == target:
        return
    if link.exists() or link.is_symlink():
        link.unlink()
    link.parent.mkdir(parents=True, exist_ok=True)
    link.symlink_to(target)


def _rolled(path: Path, target: Path, ed_frame: int) -> None:
    """A copy of the series ``target`` turned so that frame ``ed_frame`` comes first."""
    import nibabel as nib

    from ..files import atomic_path

    stamp = path.with_name(path.name + ".source")
    key = f"{target}\n{os.stat(target).st_mtime_ns}\n{ed_frame}\n"
    if path.is_file() and stamp.is_file() and stamp.read_text(encoding="utf-8") == key:
        return
    if path.is_symlink():
        path.unlink()
    img = nib.load(str(target))
    data = np.roll(np.asanyarray(img.dataobj), -ed_frame, axis=3)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        nib.save(nib.Nifti1Image(data, img.affine, img.header), str(tmp))
    atomic_write_text(stamp, key)


def _csv(header, rows) -> str:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return out.getvalue()


_PLANE_COLUMNS = (
    Column("subject"),
    Column("frame", required=False, empty=""),
    *(Column(c, "number") for c in ("x", "y", "z", "nx", "ny", "nz")),
)


def _planes(table: SubjectsTable, path: Path) -> str:
    """The settings' valve-plane table (subject, frame, x..nz) per image and frame, in the
    columns ``symladders mesh --cut-planes`` reads (image, x..nz, frame)."""
    try:
        planes = read_table(path, _PLANE_COLUMNS, what="valve planes", key=("subject", "frame"))
        planes.refuse_unknown("subject", set(table.subjects))
    except TableError as exc:
        raise SubjectsTableError(str(exc)) from None
    rows = []
    for i, row in enumerate(planes.rows):
        entry = table.entry(row["subject"])
        frame = row["frame"].lower()
        plane = [f"{row[c]:.6g}" for c in ("x", "y", "z", "nx", "ny", "nz")]
        if entry.series is None:
            if frame not in ("ed", "es", ""):
                raise SubjectsTableError(str(planes.error(
                    i, "frame", f"{entry.subject!r} has two 3-D images: expected 'ed', 'es' or "
                                f"empty, got {frame!r}")))  # fmt: skip
            for phase in ("ed", "es") if not frame else (frame,):
                rows.append([f"{entry.subject}_{phase}{image_suffix(entry.ed_image)}", *plane, ""])
            continue
        if frame in ("ed", "es"):
            frame = str(series_frames(entry, None)[0 if frame == "ed" else 1])
        elif frame:
            try:
                number = int(frame)
            except ValueError:
                raise SubjectsTableError(str(planes.error(
                    i, "frame", f"expected a frame number, 'ed', 'es' or empty, got {frame!r}"
                ))) from None  # fmt: skip
            if not 0 <= number < entry.n_frames:
                raise SubjectsTableError(str(planes.error(
                    i, "frame", f"frame {number} outside the series' {entry.n_frames} frames"
                )))  # fmt: skip
        rows.append([f"{entry.subject}{image_suffix(entry.series)}", *plane, frame])
    return _csv(["image", "x", "y", "z", "nx", "ny", "nz", "frame"], rows)


def series_frames(entry, label: int | None) -> tuple[int, int]:
    """The ED and ES frames of a subject's series: the table's, else frame 0 and the frame of
    least cavity volume (:func:`~ladders.study.imaging.series_frames.least_volume_frame`, the
    rule ``symladders mesh`` applies; it needs ``label``)."""
    ed, es = entry.ed_frame, entry.es_frame
    if es is None:
        from ..imaging.series_frames import least_volume_frame

        if label is None:
            raise SubjectsTableError(f"subject {entry.subject!r}: its ES frame is found when the "
                                     "series is meshed; name it (es_frame) to use 'es' here")  # fmt: skip
        es = least_volume_frame(entry.series, label)[0]
    return (0 if ed is None else ed), es


def _tracked_meshes(inputs: RouteInputs, corresponded: Path, entries) -> None:
    """Links to the tracked subjects' corresponded ED meshes and records (they may not exist
    yet: the step ``correspond`` writes them before ``track`` reads the links)."""
    wanted = {}
    for e in entries:
        wanted[f"{e.subject}_ed.vtk"] = corresponded / f"{e.subject}_ed.vtk"
        wanted[f"correspondence/{e.subject}.json"] = (
            corresponded / "correspondence" / f"{e.subject}.json"
        )
    for name, target in wanted.items():
        _link(inputs.tracked_meshes / name, target)
    if inputs.tracked_meshes.is_dir():
        for path in sorted(inputs.tracked_meshes.rglob("*")):
            if (
                path.is_symlink()
                and path.relative_to(inputs.tracked_meshes).as_posix() not in wanted
            ):
                path.unlink()


def write_route_inputs(table: SubjectsTable, output: Path, settings, track: bool) -> RouteInputs:
    """Write the inputs folder of ``table`` (see the module); the paths written.

    ``track``: the series of three frames or more go to ``series/``.
    """
    inputs = RouteInputs(output)
    for e in table.entries:
        if e.series is not None:
            _link(inputs.images / f"{e.subject}{image_suffix(e.series)}", e.series)
        else:
            for phase, target in (("ed", e.ed_image), ("es", e.es_image)):
                _link(inputs.images / f"{e.subject}_{phase}{image_suffix(target)}", target)
    wanted = {p.name for p in inputs.image_paths(table)}
    for path in inputs.image_files():  # a subject removed from the table
        if path.name not in wanted:
            path.unlink()
    tracked = {}
    if track:
        for e in table.tracked:
            path = inputs.series / f"{e.subject}{image_suffix(e.series)}"
            if e.ed_frame:
                _rolled(path, e.series, e.ed_frame)
            else:
                _link(path, e.series)
            tracked[path.name] = True
    if inputs.series.is_dir():
        for path in sorted(inputs.series.iterdir()):
            if path.name not in tracked and not path.name.endswith(".source"):
                path.unlink()
    _tracked_meshes(inputs, Path(output) / "corresponded", table.tracked if track else [])
    label = settings["images"]["label"]
    frames = [(e.subject, *series_frames(e, label)) for e in table.entries
              if e.series is not None and (e.ed_frame is not None or e.es_frame is not None)]  # fmt: skip
    if frames:
        _write_if_changed(inputs.frames, _csv(["subject", "ed", "es"], frames))
    elif inputs.frames.is_file():
        inputs.frames.unlink()
    if table.has_landmarks:
        rows = [[e.subject, *(f"{x:.6g}" for x in e.landmarks.ravel())]
                for e in table.entries if e.landmarks is not None]  # fmt: skip
        _write_if_changed(inputs.landmarks, _csv(LANDMARK_COLUMNS, rows))
    elif inputs.landmarks.is_file():
        inputs.landmarks.unlink()
    planes = settings["images"]["valve_planes"]
    if planes is not None:
        _write_if_changed(inputs.planes, _planes(table, planes))
    elif inputs.planes.is_file():
        inputs.planes.unlink()
    return inputs
