"""A synthetic cohort written as a user holds it: label images, a subjects table, a settings file.

:func:`write_image_cohort` writes, into a folder, what ``symladders run`` reads:

* ``images/``: every subject's label images in the labels of UK Biobank's segmentations
  (:data:`LABELS`: 1 the left ventricle's blood pool, 2 its myocardium where the
  generator has one, 3 the right ventricle's blood pool, placed against the septum);
  two 3-D images ``<subject>_ed.nii.gz`` and ``<subject>_es.nii.gz``, or, for the
  subjects given a series, one 4-D series ``<subject>.nii.gz`` over the whole cycle;
* ``subjects.csv``: one row per subject, its images, its group and covariates
  (``age``, ``sex``, ``body_size`` for a cohort with covariates);
* ``study.toml``: the settings, with the labels and the planted truth;
* ``planted_region.json``: the truth (as ``symladders cohort`` writes it).

The cohorts: a two-group or covariate cohort (ED and ES only,
:func:`~.two_groups.make_two_group_cohort`, :func:`~.covariate_cohort.make_covariate_cohort`),
whose surfaces are voxelised on an isotropic grid; or a whole-cycle cohort
(:class:`~.cycle_cohort.CohortCycles`), rendered on its short-axis stacks, the first
``n_series`` subjects as 4-D series and the others as their ED and ES frames.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from ..errors import CohortError
from ..imaging import add_rv_label, voxelize, write_label_image
from ..preparation.synthetic_landmarks import synthetic_landmarks
from .cycle_grid import cycle_grid

__all__ = ["LABELS", "write_image_cohort", "write_run_files", "subjects_table", "with_rv_label",
           "SUBJECTS_FILE", "SETTINGS_FILE"]  # fmt: skip

#: The label values of the images written (UK Biobank's convention).
LABELS = {"blood_pool": 1, "myocardium": 2, "right_ventricle": 3}
SUBJECTS_FILE = "subjects.csv"
SETTINGS_FILE = "study.toml"
_MARGIN = 22.0  # mm around the ventricle: room for the right ventricle beside the septum


def with_rv_label(labels, affine, surface) -> np.ndarray:
    """The labels with the RV crescent against the septum of the ED surface ``surface``."""
    lm = synthetic_landmarks(surface)
    septum = np.asarray(lm.septum) - np.asarray(lm.apex)
    return add_rv_label(labels, affine, lm.apex, lm.base, septum,
                        lv_label=LABELS["blood_pool"], rv_label=LABELS["right_ventricle"])  # fmt: skip


def _grid(ed, es, spacing: float, thickness: float):
    """A grid over both shapes: ``spacing`` in plane, ``thickness`` along the long axis (z)."""
    both = np.vstack([ed, es])
    low = both.min(axis=0) - _MARGIN
    step = np.array([spacing, spacing, thickness])
    shape = tuple(int(n) for n in np.ceil((both.max(axis=0) + _MARGIN - low) / step))
    affine = np.diag([spacing, spacing, thickness, 1.0])
    affine[:3, 3] = low
    return affine, shape


def _pair(folder: Path, name: str, ed, es, faces, spacing: float, thickness: float) -> list[str]:
    affine, shape = _grid(ed, es, spacing, thickness)
    files = []
    for phase, surface in (("ed", ed), ("es", es)):
        labels = voxelize(surface, faces, affine, shape, label=LABELS["blood_pool"])
        labels = with_rv_label(labels, affine, ed)
        path = folder / "images" / f"{name}_{phase}.nii.gz"
        write_label_image(path, labels, affine)
        files.append(path.relative_to(folder).as_posix())
    return files


def _cycle_images(folder: Path, cycles, i: int, series: bool, in_plane, thickness) -> list[str]:
    from ..imaging.cine import write_series

    name = cycles.names[i]
    ed = cycles.frames[i, 0]
    affine, shape = cycle_grid(ed, in_plane, thickness)
    es = int(np.argmax(cycles.fractions))
    frames = range(len(cycles.times)) if series else (0, es)
    rendered = [
        with_rv_label(cycles.render_labels(i, affine, shape, t), affine, ed) for t in frames
    ]
    if series:
        path = folder / "images" / f"{name}.nii.gz"
        write_series(path, rendered, affine)
        return [path.relative_to(folder).as_posix()]
    files = []
    for phase, labels in zip(("ed", "es"), rendered):
        path = folder / "images" / f"{name}_{phase}.nii.gz"
        write_label_image(path, labels, affine)
        files.append(path.relative_to(folder).as_posix())
    return files


def _settings(truth: bool, myocardium: bool) -> str:
    lines = [
        "# symladders run study.toml: the route from these images to the adjusted maps.",
        f'subjects = "{SUBJECTS_FILE}"',
        "",
        "[images]",
        f"label = {LABELS['blood_pool']}  # the left ventricle's blood pool",
        f"rv_label = {LABELS['right_ventricle']}  # the right ventricle: landmarks, AHA segments",
    ]
    if myocardium:
        lines.append(f"myocardium_label = {LABELS['myocardium']}  # the wall: thickness, strain")
    if truth:
        lines += [
            "",
            "[model]",
            'truth = "planted_region.json"  # a synthetic cohort: score the maps',
        ]
    return "\n".join(lines) + "\n"


def subjects_table(cohort_data) -> dict:
    """The cohort's subjects with their group and covariates (``design_table()`` of a cohort
    with covariates), ``{column: list}`` in the cohort's order."""
    cohort = cohort_data.cohort
    if hasattr(cohort_data, "design_table"):
        return cohort_data.design_table()
    return {"subject": cohort.names, "group": [cohort_data.groups[s] for s in cohort.names]}


def write_run_files(folder, table: dict, images: dict, *, myocardium: bool = False) -> None:
    """``subjects.csv`` and ``study.toml`` of a synthetic cohort written as label images.

    ``table``: :func:`subjects_table`; ``images``: per subject, its image files relative to
    ``folder``, one (a series) or two (ED and ES). The settings name the planted truth
    when ``folder/planted_region.json`` has a region.
    """
    folder = Path(folder)
    covariates = [c for c in table if c != "subject"]
    rows = []
    for j, name in enumerate(table["subject"]):
        files = images[name]
        image, ed, es = (files[0], "", "") if len(files) == 1 else ("", *files)
        rows.append([name, image, ed, es, *(table[c][j] for c in covariates)])
    with open(folder / SUBJECTS_FILE, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(["subject", "image", "ed_image", "es_image", *covariates])
        writer.writerows(rows)
    truth = json.loads((folder / "planted_region.json").read_text(encoding="utf-8"))
    text = _settings(truth.get("region") is not None, myocardium)
    (folder / SETTINGS_FILE).write_text(text, encoding="utf-8")


def write_image_cohort(data, folder, *, spacing: float = 1.5, thickness: float | None = None,
                       n_series: int | None = None) -> Path:  # fmt: skip
    """Write a synthetic cohort as label images with its subjects table (see the module).

    Parameters
    ----------
    data : TwoGroupCohort, CovariateCohort or CohortCycles
    folder : path
    spacing : float, default 1.5
        The voxel size in the short-axis plane (mm).
    thickness : float, optional
        The voxel size along the long axis (mm); default ``spacing`` (isotropic), and 8
        mm for a whole-cycle cohort (its short-axis stacks).
    n_series : int, optional
        Whole-cycle cohort: the first ``n_series`` subjects get a 4-D series, the others
        their ED and ES frames (default: every subject a series).

    Returns
    -------
    Path
        The folder.
    """
    from .two_groups import write_two_group_cohort

    folder = Path(folder)
    cycles = data if hasattr(data, "render_labels") else None
    cohort_data = cycles.data if cycles is not None else data
    if not hasattr(cohort_data, "cohort") or not hasattr(cohort_data, "groups"):
        raise CohortError(f"data: expected a synthetic cohort, got {type(data).__name__}")
    thickness = (8.0 if cycles is not None else spacing) if thickness is None else thickness
    for name, value in (("spacing", spacing), ("thickness", thickness)):
        if not (np.isfinite(value) and value > 0):
            raise CohortError(f"{name}: expected a voxel size > 0 mm, got {value!r}")
    truth_folder = folder / "truth"
    write_two_group_cohort(cohort_data, truth_folder)  # meshes and planted_region.json
    (folder / "planted_region.json").write_text(
        (truth_folder / "planted_region.json").read_text(encoding="utf-8"), encoding="utf-8"
    )
    cohort = cohort_data.cohort
    n = len(cohort.subjects)
    n_series = n if n_series is None else int(n_series)
    if cycles is None and n_series and n_series != n:
        raise CohortError("n_series: only a whole-cycle cohort has series")
    images = {}
    for i, subject in enumerate(cohort.subjects):
        if cycles is not None:
            files = _cycle_images(folder, cycles, i, i < n_series, spacing, thickness)
        else:
            files = _pair(folder, subject.name, subject.ed, subject.es, cohort.faces, spacing,
                          thickness)  # fmt: skip
        images[subject.name] = files
    write_run_files(folder, subjects_table(cohort_data), images, myocardium=cycles is not None)
    return folder
