"""A two-group synthetic cohort with a planted motion abnormality and known ground truth.

:func:`make_two_group_cohort` draws the synthetic left-ventricle cohort of
:func:`~ladders.study.cohort.synthetic_lv.make_synthetic_cohort` (same seed, same
subjects' anatomy and normal motion), chooses a fraction of its subjects as
patients and plants a :class:`~ladders.study.cohort.planted_effect.MotionAbnormality`
in their end-systolic shapes. The atlas's affected vertices are recorded
(:class:`~ladders.study.cohort.planted_effect.PlantedRegion`). Realism knobs, all
off by default: segmentation noise (mm), and, when written to a folder
(:func:`write_two_group_cohort`), another triangulation of every mesh and a
random pose per subject, so that the meshes are no longer in correspondence and
go through ``symladders correspond``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from manifolds.validation import check_float, check_rng

from ..cohort.cohort import Cohort, Subject
from ..cohort.groups_table import groups_csv
from ..cohort.planted_effect import (
    MotionAbnormality,
    PlantedRegion,
    planted_modulation,
    planted_region,
)
from ..cohort.segmentation_noise import smooth_normal_noise
from ..cohort.synthetic_lv import (
    SyntheticLVModel,
    grid_shape,
    lv_grid,
    lv_shapes,
    make_synthetic_cohort,
)
from ..errors import CohortError
from ..meshes.mesh_io import WRITE_EXTENSIONS, write_mesh
from ..preparation.alignment import SimilarityTransform, random_rigid_transform
from ..preparation.landmarks import LANDMARKS_FILE, write_landmarks
from ..preparation.remeshing import remesh
from ..preparation.synthetic_landmarks import synthetic_landmarks

__all__ = [
    "DEFAULT_ABNORMALITY",
    "PATIENTS",
    "CONTROLS",
    "TwoGroupCohort",
    "make_two_group_cohort",
    "write_two_group_cohort",
    "GROUPS_FILE",
    "REGION_FILE",
]

PATIENTS = "patients"
CONTROLS = "controls"
#: File names written next to the meshes.
GROUPS_FILE = "groups.csv"
REGION_FILE = "planted_region.json"

# spawn keys of the draws besides the subjects' own (which use 0 .. n-1)
_GROUPS_KEY = 1_000_000
_NOISE_KEY = 2_000_000
_WRITE_KEY = 3_000_000

#: The abnormality planted by default: :class:`MotionAbnormality`'s defaults (hypokinesia,
#: half the motion, segments 7, 8, 13 and 14).
DEFAULT_ABNORMALITY = MotionAbnormality()


@dataclass
class TwoGroupCohort:
    """A cohort, each subject's group and the ground truth of the planted abnormality.

    Attributes
    ----------
    cohort : Cohort
        In vertex correspondence with the atlas.
    groups : dict
        ``{subject: "patients" or "controls"}`` in cohort order.
    region : PlantedRegion or None
        The abnormality's weight and affected vertices on the atlas (None without one).
    noise : float
        RMS of the segmentation noise added to every ED and ES mesh, in mm.
    seed : int
    """

    cohort: Cohort
    groups: dict
    region: PlantedRegion | None
    noise: float = 0.0
    seed: int = 0

    @property
    def labels(self) -> np.ndarray:
        """Boolean per subject in cohort order: True for a patient."""
        return np.array([self.groups[s.name] == PATIENTS for s in self.cohort.subjects])

    def description(self) -> dict:
        """JSON-ready description (what the folder's ``planted_region.json`` records)."""
        return {
            "seed": self.seed,
            "n_subjects": len(self.cohort),
            "n_patients": int(self.labels.sum()),
            "segmentation_noise_mm": self.noise,
            "region": None if self.region is None else self.region.as_dict(),
        }


def _seed(seed) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise CohortError(f"seed: expected a non-negative int, got {seed!r}")
    return int(seed)


def _child(seed: int, key: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(key,)))


def make_two_group_cohort(
    n_subjects: int = 40,
    patient_fraction: float = 0.5,
    abnormality: MotionAbnormality | None = DEFAULT_ABNORMALITY,
    n_vertices: int = 1009,
    seed: int = 0,
    noise: float = 0.0,
    noise_length: float = 10.0,
    model: SyntheticLVModel | None = None,
) -> TwoGroupCohort:
    """The synthetic cohort in two groups, with ``abnormality`` planted in the patients.

    Parameters
    ----------
    n_subjects : int, default 40
    patient_fraction : float, default 0.5
        Fraction of the subjects that are patients (rounded; at least one subject
        in each group when both are asked for). The patients are drawn at random
        from the seed.
    abnormality : MotionAbnormality or None
        What is planted in the patients' end-systolic motion; None plants nothing
        (both groups from one distribution: the null).
    n_vertices : int, default 1009
    seed : int, default 0
        Seed of every draw: the subjects are those of
        ``make_synthetic_cohort(n_subjects, n_vertices, seed)``.
    noise : float, default 0.0
        RMS of a smooth normal displacement added to every ED and ES mesh, in mm
        (segmentation noise, :func:`smooth_normal_noise`); the atlas is not noisy.
    noise_length : float, default 10.0
        Correlation length of that noise, in mm.
    model : SyntheticLVModel, optional

    Returns
    -------
    TwoGroupCohort
    """
    seed = _seed(seed)
    fraction = check_float(patient_fraction, "patient_fraction", minimum=0.0)
    if fraction > 1.0:
        raise CohortError(f"patient_fraction: expected a fraction in [0, 1], got {fraction}")
    noise = check_float(noise, "noise", minimum=0.0)
    model = model or SyntheticLVModel()
    base = make_synthetic_cohort(n_subjects, n_vertices=n_vertices, seed=seed, model=model)
    n = len(base)
    n_patients = int(round(fraction * n))
    if 0.0 < fraction < 1.0 and n >= 2:
        n_patients = min(max(n_patients, 1), n - 1)
    patients = set(_child(seed, _GROUPS_KEY).choice(n, size=n_patients, replace=False).tolist())
    theta, phi, _ = lv_grid(*grid_shape(n_vertices), model)
    modulation = None if abnormality is None else planted_modulation(abnormality, theta, phi)
    subjects, groups = [], {}
    for i, s in enumerate(base.subjects):
        es = s.es
        if i in patients and modulation is not None:
            _, es = lv_shapes(s.parameters, theta, phi, modulation)
        ed = s.ed
        if noise > 0:
            rng = _child(seed, _NOISE_KEY + i)
            ed = smooth_normal_noise(ed, base.faces, noise, rng, noise_length)
            es = smooth_normal_noise(es, base.faces, noise, rng, noise_length)
        subjects.append(Subject(s.name, ed, es, s.parameters))
        groups[s.name] = PATIENTS if i in patients else CONTROLS
    source = (
        f"make_two_group_cohort(n_subjects={n}, patient_fraction={fraction:g}, "
        f"abnormality={None if abnormality is None else abnormality.describe()!r}, "
        f"noise={noise:g} mm, seed={seed})"
    )
    cohort = Cohort(base.atlas, base.faces, subjects, source)
    region = None if abnormality is None else planted_region(abnormality, theta, phi)
    return TwoGroupCohort(cohort, groups, region, noise, seed)


def write_two_group_cohort(
    data: TwoGroupCohort,
    folder,
    ext: str = ".vtk",
    remesh_factor: float | None = None,
    pose: bool = False,
    max_angle: float = 30.0,
    max_translation: float = 20.0,
    rng: np.random.Generator | None = None,
    landmarks: bool = False,
) -> Path:
    """Write the cohort's meshes, ``groups.csv`` and ``planted_region.json`` into ``folder``.

    The meshes follow the layout of :func:`~ladders.study.cohort.read_cohort`
    (``atlas<ext>``, ``<subject>_ed<ext>``, ``<subject>_es<ext>``).

    Parameters
    ----------
    data : TwoGroupCohort
    folder : str or Path
    ext : str, default ".vtk"
    remesh_factor : float, optional
        Give every subject mesh another triangulation with about ``remesh_factor``
        times the atlas's face count (:func:`~ladders.study.preparation.remeshing.remesh`):
        the meshes are then not in correspondence and go through ``symladders correspond``.
    pose : bool, default False
        Move every subject (both frames) by its own random rigid motion, angle up
        to ``max_angle`` degrees and translation up to ``max_translation`` mm.
    rng : numpy.random.Generator, optional
        Draws of the remeshing and the poses; default from the cohort's seed.
    landmarks : bool, default False
        Also write ``landmarks.csv``: the apex, base-plane centre and septal point of
        the atlas (row ``atlas``) and of every subject's end-diastole, posed with it
        (:func:`~ladders.study.preparation.synthetic_landmarks.synthetic_landmarks`), which
        ``symladders correspond`` and ``symladders atlas`` read.

    The truth file records each subject's pose (``"poses"``: its 4 x 4 matrix, the
    identity without ``pose``), so that the rotation a correspondence leaves can be
    measured.

    Returns
    -------
    Path
        The folder.
    """
    ext = "." + ext.lower().lstrip(".")
    if ext not in WRITE_EXTENSIONS:
        raise CohortError(f"ext: expected one of {WRITE_EXTENSIONS}, got {ext!r}")
    rng = _child(data.seed, _WRITE_KEY) if rng is None else check_rng(rng)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    cohort = data.cohort
    write_mesh(folder / f"atlas{ext}", cohort.atlas, cohort.faces)
    n_faces = (
        None if remesh_factor is None else max(4, int(round(remesh_factor * len(cohort.faces))))
    )
    poses, table = {}, {"atlas": synthetic_landmarks(cohort.atlas)}
    for s in cohort.subjects:
        motion = random_rigid_transform(rng, max_angle, max_translation) if pose else None
        poses[s.name] = (motion or SimilarityTransform.identity()).matrix.tolist()
        table[s.name] = synthetic_landmarks(s.ed)
        if motion is not None:
            table[s.name] = table[s.name].transformed(motion)
        for phase, vertices in (("ed", s.ed), ("es", s.es)):
            v, f = vertices, cohort.faces
            if n_faces is not None:
                v, f = remesh(v, f, n_faces)
            if motion is not None:
                v = motion.apply(v)
            write_mesh(folder / f"{s.name}_{phase}{ext}", v, f)
    (folder / GROUPS_FILE).write_text(groups_csv(data.groups), encoding="utf-8")
    record = data.description()
    record["remesh_factor"] = remesh_factor
    record["pose"] = (
        {"max_angle_deg": max_angle, "max_translation_mm": max_translation} if pose else None
    )
    record["poses"] = poses
    if landmarks:
        write_landmarks(folder / LANDMARKS_FILE, table)
    (folder / REGION_FILE).write_text(json.dumps(record, indent=1), encoding="utf-8")
    return folder
