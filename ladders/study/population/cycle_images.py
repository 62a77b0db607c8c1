"""The whole-cycle cohort on disk: 4-D label or cine images, the frames as meshes, the truth.

:func:`write_cycle_cohort` writes what a cardiac pipeline starts from, for a cohort of
:func:`~ladders.study.population.make_two_group_cycles` (or, in several groups with
covariates, of :func:`~ladders.study.population.covariate_cycles`)::

    <folder>/atlas.vtk, <subject>_ed.vtk, <subject>_es.vtk, groups.csv,
    planted_region.json           as write_two_group_cohort (the ES frame's surfaces)
    <folder>/design.csv           several groups and covariates: as write_covariate_cohort
                                  (subject, group, age, sex, body_size; time, event)
    <folder>/images/<subject>.nii.gz
                                  the subject's 4-D series (frames on the fourth axis,
                                  frame 0 at ED): labels (0 background, 1 blood pool,
                                  2 myocardium, 3 right ventricle) or cine intensities
                                  (noise, partial volume, optionally tagging)
    <folder>/subjects.csv, study.toml
                                  with labels: the subjects table and the settings of
                                  ``symladders run`` (the cohort as a user holds it)
    <folder>/frames/<subject>/frame_<kk>.vtk
                                  the true surfaces of every frame, in the atlas's
                                  correspondence (what ``symladders track`` estimates)
    <folder>/cycle.json           frames, ES frame, the grid and what was rendered
    <folder>/valve_planes.csv     the valve plane of every subject's every frame (the plane
                                  of the true surface's rim, its normal away from the
                                  apex), the table ``symladders track --cut-planes`` reads
    <folder>/landmarks.csv        with ``landmarks=True``: the apex, base-plane centre and
                                  septal point of the atlas (row ``atlas``) and of every
                                  subject's ED frame, the table ``symladders correspond
                                  --landmarks`` reads

The images are short-axis stacks (slices along the long axis) over each subject's
own field of view: its ED surface with a margin of 15 mm (8 mm above the base). The
cohort is not posed: the meshes, the frames and the images' world coordinates (their
affines) are all the generator's frame, in mm, so one landmark table serves the ED
meshes and the meshes made from the ED images.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import CohortError
from ..imaging.cine import TagGrid, write_series
from ..imaging.plane_table import PLANES_FILE, write_plane_table
from ..meshes.mesh_io import write_mesh
from ..preparation.landmarks import LANDMARKS_FILE, write_landmarks
from ..preparation.synthetic_landmarks import synthetic_landmarks
from ..tracking.base_planes import rim_plane
from ..volume import boundary_vertices
from .covariate_cohort import CovariateCohort, write_covariate_cohort
from .cycle_grid import cycle_grid
from .image_cohort import subjects_table, with_rv_label, write_run_files
from .two_groups import write_two_group_cohort

__all__ = [
    "IMAGE_KINDS",
    "VALVE_PLANES_FILE",
    "cycle_grid",
    "cycle_valve_planes",
    "valve_planes",
    "write_cycle_cohort",
]

#: The per-frame valve planes :func:`write_cycle_cohort` writes (``--cut-planes`` format).
VALVE_PLANES_FILE = PLANES_FILE

#: What :func:`write_cycle_cohort` renders into ``images/``.
IMAGE_KINDS = ("labels", "cine", "none")


def valve_planes(frames, faces) -> np.ndarray:
    """The plane of the rim (the valve plane) of every frame of an open surface.

    Parameters
    ----------
    frames : array, shape (n_frames, k, 3)
        The surface at every frame (one triangulation, e.g. a subject's true frames).
    faces : array of int, shape (f, 3)
        Its triangles, with one boundary loop (the rim at the base).

    Returns
    -------
    ndarray, shape (n_frames, 6)
        ``(x, y, z, nx, ny, nz)`` per frame (:func:`~ladders.study.tracking.base_planes.rim_plane`):
        the rim's centroid and the unit normal of its least-squares plane, pointing away
        from the surface's centroid (the side ``MeshingSettings.cut_plane`` removes).
    """
    frames = np.asarray(frames, dtype=float)
    rim = boundary_vertices(faces)
    if frames.ndim != 3 or frames.shape[-1] != 3 or len(rim) < 3:
        raise CohortError(
            f"frames: expected (n_frames, k, 3) of an open surface, got {frames.shape} with "
            f"{len(rim)} rim vertices"
        )
    return np.array([rim_plane(v, faces) for v in frames])


def cycle_valve_planes(cycles) -> dict:
    """Every subject's valve plane at every frame of a cohort through the cycle.

    Returns ``{subject: {"0": plane, "1": plane, ...}}`` with ``plane`` the list
    ``[x, y, z, nx, ny, nz]`` of :func:`valve_planes` of its true frames: the
    ``cut_planes`` of :func:`~ladders.study.tracking.track_cohort` (what ``symladders
    track --cut-planes valve_planes.csv`` reads).
    """
    return {name: {str(t): [float(x) for x in plane]
                   for t, plane in enumerate(valve_planes(cycles.frames[i], cycles.faces))}
            for i, name in enumerate(cycles.names)}  # fmt: skip


def write_cycle_cohort(
    cycles,
    folder,
    images: str = "labels",
    in_plane: float = 1.5,
    thickness: float = 8.0,
    tagging: TagGrid | None = None,
    noise: float = 0.05,
    rng: np.random.Generator | None = None,
    frames: bool = True,
    landmarks: bool = False,
    progress: bool = False,
) -> Path:
    """Write a whole-cycle cohort's images, frames and truth into ``folder`` (see the module).

    Parameters
    ----------
    cycles : CohortCycles
        From :func:`~ladders.study.population.make_two_group_cycles`.
    folder : path
    images : {"labels", "cine", "none"}
    in_plane, thickness : float
        Voxel size of the short-axis stacks, mm.
    tagging : TagGrid, optional
        Cine only: tagging lines that move with the material.
    noise : float, default 0.05
        Cine only: the noise's standard deviation (the myocardium's intensity is 1).
    rng : numpy.random.Generator, optional
        Cine only: the noise (default: seeded by the cohort's seed).
    frames : bool, default True
        Also write every frame's true surface.
    landmarks : bool, default False
        Also write ``landmarks.csv``: the apex, base-plane centre and septal point
        (:func:`~ladders.study.preparation.synthetic_landmarks.synthetic_landmarks`) of the
        atlas (row ``atlas``) and of every subject's ED frame (``frames[i, 0]``, the
        surface its ED image is rendered from; ``<subject>_ed`` itself for a cohort without
        segmentation noise), in the coordinates of the meshes and of the images' world
        frame, which ``symladders correspond --landmarks`` reads.
    progress : bool, default False
        A progress bar over the subjects written (tqdm).

    Returns
    -------
    Path
    """
    from tqdm.auto import tqdm

    if images not in IMAGE_KINDS:
        raise CohortError(f"images: expected one of {IMAGE_KINDS}, got {images!r}")
    if images != "cine" and tagging is not None:
        raise CohortError("tagging: only with images='cine'")
    data = getattr(cycles, "data", None)
    if data is None or not hasattr(cycles, "render_labels"):
        raise CohortError(f"cycles: expected a CohortCycles, got {type(cycles).__name__}")
    if isinstance(data, CovariateCohort):  # several groups and covariates: also design.csv
        folder = write_covariate_cohort(data, folder)
    else:
        folder = write_two_group_cohort(data, folder)
    if landmarks:
        table = {"atlas": synthetic_landmarks(data.cohort.atlas)}
        table.update((name, synthetic_landmarks(cycles.frames[i, 0]))
                     for i, name in enumerate(cycles.names))  # fmt: skip
        write_landmarks(folder / LANDMARKS_FILE, table)
    write_plane_table(folder / VALVE_PLANES_FILE, cycle_valve_planes(cycles))
    if images != "none":
        cycles.check_invertible()  # a folded motion cannot be rendered: say which subject
    if rng is None:
        rng = np.random.default_rng([int(getattr(data, "seed", 0)), 3])
    grids = {}
    for i, name in enumerate(tqdm(cycles.names, desc="subjects", disable=not progress)):
        affine, shape = cycle_grid(cycles.frames[i, 0], in_plane, thickness)
        grids[name] = {"affine": affine.tolist(), "shape": list(shape)}
        if images == "labels":  # with the right ventricle's label against the ED septum
            series = [with_rv_label(cycles.render_labels(i, affine, shape, t), affine,
                                    cycles.frames[i, 0]) for t in range(len(cycles.times))]  # fmt: skip
        elif images == "cine":
            series = [cycles.render_cine(i, affine, shape, t, rng, noise=noise, tagging=tagging)
                      for t in range(len(cycles.times))]  # fmt: skip
        if images != "none":
            write_series(folder / "images" / f"{name}.nii.gz", series, affine)
        if frames:
            (folder / "frames" / name).mkdir(parents=True, exist_ok=True)
            for t, surface in enumerate(cycles.frames[i]):
                write_mesh(folder / "frames" / name / f"frame_{t:02d}.vtk", surface, cycles.faces)
    es = int(np.argmax(cycles.fractions))
    record = {
        "n_frames": len(cycles.times),
        "es_frame": es,
        "fractions": [float(f) for f in cycles.fractions],
        "images": images,
        "voxel_mm": [in_plane, in_plane, thickness],
        "tagging": None if tagging is None else vars(tagging),
        "noise": noise if images == "cine" else None,
        "labels": {"background": 0, "blood_pool": 1, "myocardium": 2, "right_ventricle": 3},
        "grids": grids,
        "landmarks": LANDMARKS_FILE if landmarks else None,
        "valve_planes": VALVE_PLANES_FILE,
    }
    (folder / "cycle.json").write_text(json.dumps(record, indent=1), encoding="utf-8")
    if images == "labels":  # the cohort as a user holds it, for symladders run
        names = {n: [f"images/{n}.nii.gz"] for n in cycles.names}
        write_run_files(folder, subjects_table(data), names, myocardium=True)
    return folder
