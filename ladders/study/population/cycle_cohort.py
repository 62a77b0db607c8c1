"""The whole cycle of a two-group cohort: every subject's frames, and images of them.

:func:`make_two_group_cycles` draws the two-group cohort of
:func:`~ladders.study.population.two_groups.make_two_group_cohort` with the cycle's own
default abnormality :data:`CYCLE_ABNORMALITY` and gives every subject's surface at every
frame (:func:`~ladders.study.cohort.cardiac_cycle.cycle_frames`); :func:`two_group_cycles`
does it for a cohort already drawn. :class:`CohortCycles` holds the frames and renders
any subject's label or cine image at any frame
(:func:`~ladders.study.imaging.cine.render_labels`,
:func:`~ladders.study.imaging.cine.render_cine`), the patients' images with the
planted abnormality acting through the whole cycle.

Why a default of its own: the surfaces only need the planted motion on the endocardium,
the images need it to be a bijection of the volume (``z'`` growing with ``z``). With
the surface cohort's default (:data:`~ladders.study.population.two_groups.DEFAULT_ABNORMALITY`,
transitions of half-width 0.05 of the long axis) the mid-to-basal transition of the
halved shortening folds the volume of the subjects whose shortening is largest;
:data:`CYCLE_ABNORMALITY` has the same segments, kind and magnitude with transitions of
half-width 0.1, invertible over the model's whole range of shortening with a wide
margin (a narrower transition that is just invertible would compress the tissue at the
transition so much that the incompressible wall would balloon there).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..cohort.cardiac_cycle import (
    check_invertible,
    cycle_fraction,
    cycle_frames,
    frame_abnormality,
    frame_times,
)
from ..cohort.planted_effect import MotionAbnormality
from ..cohort.synthetic_lv import SubjectParameters, SyntheticLVModel, lv_grid, lv_shapes
from ..errors import CohortError
from ..imaging.cine import render_cine, render_labels
from .two_groups import make_two_group_cohort

__all__ = [
    "CYCLE_ABNORMALITY",
    "CohortCycles",
    "covariate_cycles",
    "make_two_group_cycles",
    "two_group_cycles",
]

#: The whole cycle's default abnormality: :class:`MotionAbnormality`'s hypokinesia of
#: segments 7, 8, 13 and 14 at half the motion, with ring transitions of half-width 0.1 of
#: the long axis (twice the surface cohort's) so that every subject's motion is invertible.
CYCLE_ABNORMALITY = MotionAbnormality(transition_height=0.1)


@dataclass(frozen=True)
class CohortCycles:
    """Every subject's surface through the cycle, and its images.

    Attributes
    ----------
    frames : ndarray, shape (n_subjects, n_frames, k, 3)
        In mm, in vertex correspondence with the cohort's atlas (shared ``faces``).
    names : tuple of str
    patients : ndarray of bool, shape (n_subjects,)
    times : ndarray, shape (n_frames,)
        ``k / n_frames``.
    fractions : ndarray, shape (n_frames,)
        :func:`cycle_fraction` at ``times``.
    faces : ndarray of int, shape (f, 3)
    parameters : tuple of SubjectParameters
        Each subject's parameters (what the images are rendered from).
    abnormality : MotionAbnormality or None
        The patients' planted abnormality.
    data : TwoGroupCohort or None
        The cohort the cycles are of (its groups and planted region).
    es_phase : float
        The time of end-systole (fraction of the cycle).
    planted : tuple
        Each subject's planted abnormality (None: none), when the groups have their own
        (a cohort of :func:`covariate_cycles`); empty: ``abnormality`` for the patients.
    """

    frames: np.ndarray
    names: tuple
    patients: np.ndarray
    times: np.ndarray
    fractions: np.ndarray
    faces: np.ndarray
    parameters: tuple = ()
    abnormality: MotionAbnormality | None = None
    data: object = None
    es_phase: float = 0.35
    planted: tuple = ()

    def _index(self, subject) -> int:
        if isinstance(subject, str):
            if subject not in self.names:
                raise CohortError(f"subject: no subject named {subject!r}")
            return self.names.index(subject)
        ok = isinstance(subject, (int, np.integer)) and not isinstance(subject, bool)
        if not ok or not -len(self.names) <= subject < len(self.names):
            n = len(self.names)
            raise CohortError(f"subject: expected a name or an index < {n}, got {subject!r}")
        return int(subject) % len(self.names)

    def motion_of(
        self, subject, frame: int | None = None
    ) -> tuple[SubjectParameters, MotionAbnormality | None]:
        """A subject's (name or index) parameters and planted abnormality (None for a control);
        with ``frame``, the abnormality acting at that frame (:func:`frame_abnormality`)."""
        i = self._index(subject)
        if len(self.parameters) != len(self.names):
            raise CohortError("parameters: these cycles carry no subject parameters")
        abnormality = self.abnormality if self.patients[i] else None
        if self.planted:
            abnormality = self.planted[i]
        if frame is not None:
            self._fraction(frame)  # checks the frame
            abnormality = frame_abnormality(abnormality, float(self.times[frame]), self.es_phase)
        return self.parameters[i], abnormality

    def check_invertible(self) -> np.ndarray:
        """Every subject's smallest margin of :func:`check_invertible` over the frames.

        Returns an array ``(n_subjects,)``; raises :class:`CohortError` naming the first
        subject whose motion folds the volume at some frame (its images cannot be rendered).
        """
        margins = np.empty(len(self.names))
        planted = self.planted or (self.abnormality,)
        timed = any(a is not None and a.kind == "delay" for a in planted)
        frames = (
            range(len(self.times)) if timed else np.unique(self.fractions, return_index=True)[1]
        )
        for i, name in enumerate(self.names):
            try:
                margins[i] = min(
                    check_invertible(*self._at(i, t)) for t in frames
                )  # fmt: skip
            except CohortError as error:
                hint = "make_two_group_cycles draws the cohort with CYCLE_ABNORMALITY"
                raise CohortError(f"subject {name!r}: {error} ({hint})") from None
        return margins

    def _at(self, i: int, frame: int) -> tuple:
        """``(params, f, abnormality)`` of subject ``i`` at a frame."""
        params, abnormality = self.motion_of(i, frame)
        return params, float(self.fractions[frame]), abnormality

    def _fraction(self, frame) -> float:
        ok = isinstance(frame, (int, np.integer)) and not isinstance(frame, bool)
        if not ok or not 0 <= frame < len(self.fractions):
            n = len(self.fractions)
            raise CohortError(f"frame: expected an index in [0, {n}), got {frame!r}")
        return float(self.fractions[frame])

    def render_labels(self, subject, affine, shape, frame: int, **options) -> np.ndarray:
        """A subject's label image at a frame (:func:`render_labels`, ``options`` its keywords)."""
        params, abnormality = self.motion_of(subject, frame)
        return render_labels(params, affine, shape, self._fraction(frame), abnormality, **options)

    def render_cine(self, subject, affine, shape, frame: int, rng=None, **options) -> np.ndarray:
        """A subject's cine image at a frame (:func:`render_cine`, ``options`` its keywords)."""
        params, abnormality = self.motion_of(subject, frame)
        f = self._fraction(frame)
        return render_cine(params, affine, shape, f, rng, abnormality=abnormality, **options)


def _grid_of(cohort, model: SyntheticLVModel) -> tuple[np.ndarray, np.ndarray]:
    """The parametric grid of a synthetic cohort, recovered from its apex fan and checked."""
    n_lon = int(np.count_nonzero(np.any(cohort.faces == 0, axis=1)))
    k = len(cohort.atlas)
    if n_lon < 3 or (k - 1) % n_lon:
        raise CohortError("data: the cohort's meshes are not the synthetic ventricle's grid")
    theta, phi, faces = lv_grid(n_lon, (k - 1) // n_lon, model)
    atlas, _ = lv_shapes(SubjectParameters.mean(model), theta, phi)
    same = faces.shape == cohort.faces.shape and np.array_equal(faces, cohort.faces)
    if not same or not np.allclose(atlas, cohort.atlas, atol=1e-6):
        raise CohortError(
            "data: the cohort's atlas is not the synthetic model's (another model? pass model=)"
        )
    return theta, phi


def two_group_cycles(
    data,
    n_frames: int = 25,
    es_phase: float = 0.35,
    model: SyntheticLVModel | None = None,
) -> CohortCycles:
    """Every subject's frames of a cohort of :func:`make_two_group_cohort`.

    Each subject's surfaces are rebuilt from its parameters by :func:`cycle_frames`; the
    patients' motion carries the cohort's planted abnormality (``data.region.abnormality``)
    through the whole cycle, scaled with the motion, as ``make_two_group_cohort``
    plants it at ES. The frames have no segmentation noise (with ``noise = 0`` the
    ED frame is ``subject.ed``, and the ES frame, when there is one, ``subject.es``).
    The surfaces are valid for any abnormality; a patient's images need its motion to
    be invertible (:meth:`CohortCycles.check_invertible`), which the surface cohort's
    default abnormality is not for every subject: :func:`make_two_group_cycles` draws
    the cohort with :data:`CYCLE_ABNORMALITY`.

    Parameters
    ----------
    data : TwoGroupCohort
        From :func:`ladders.study.population.make_two_group_cohort`.
    n_frames : int, default 25
    es_phase : float, default 0.35
    model : SyntheticLVModel, optional
        The model the cohort was drawn with (default ``SyntheticLVModel()``).

    Returns
    -------
    CohortCycles
    """
    cohort = getattr(data, "cohort", None)
    if cohort is None or not hasattr(data, "labels") or not hasattr(data, "region"):
        raise CohortError(f"data: expected a TwoGroupCohort, got {type(data).__name__}")
    abnormality = None if data.region is None else data.region.abnormality
    patients = np.asarray(data.labels, dtype=bool)
    planted = [abnormality if p else None for p in patients]
    cycles = _cycles(data, planted, n_frames, es_phase, model)
    return replace(cycles, patients=patients, abnormality=abnormality, planted=())


def covariate_cycles(
    data,
    n_frames: int = 25,
    es_phase: float = 0.35,
    model: SyntheticLVModel | None = None,
) -> CohortCycles:
    """Every subject's frames of a cohort in several groups with covariates.

    As :func:`two_group_cycles`, for a :class:`~.covariate_cohort.CovariateCohort`: each
    subject's parameters already carry its covariates' effects (age and sex scale its
    contraction and shortening, the body size its lengths) and its group's anatomy
    shift, and its motion carries its group's planted abnormality through the whole
    cycle, so that the covariates act on the motion at every frame.

    Parameters
    ----------
    data : CovariateCohort
        From :func:`~ladders.study.population.make_covariate_cohort`.
    n_frames, es_phase, model : as :func:`two_group_cycles`

    Returns
    -------
    CohortCycles
        ``patients``: the subjects with a planted abnormality; ``abnormality``: the first
        group's that has one; ``planted``: each subject's.
    """
    specs = {g.name: g for g in getattr(data, "specs", ())}
    groups = getattr(data, "groups", None)
    if getattr(data, "cohort", None) is None or not specs or groups is None:
        raise CohortError(f"data: expected a CovariateCohort, got {type(data).__name__}")
    planted = [specs[groups[s.name]].abnormality for s in data.cohort.subjects]
    first = next((a for a in planted if a is not None), None)
    cycles = _cycles(data, planted, n_frames, es_phase, model)
    patients = np.array([a is not None for a in planted], dtype=bool)
    return replace(cycles, patients=patients, abnormality=first, planted=tuple(planted))


def _cycles(data, planted, n_frames, es_phase, model) -> CohortCycles:
    """The frames of every subject of ``data.cohort`` with its planted abnormality."""
    cohort = data.cohort
    times = frame_times(n_frames)
    n = len(times)
    fractions = cycle_fraction(times, es_phase)
    theta, phi = _grid_of(cohort, model or SyntheticLVModel())
    frames = []
    for subject, abnormality in zip(cohort.subjects, planted):
        if not isinstance(subject.parameters, SubjectParameters):
            raise CohortError(f"data: subject {subject.name!r} has no synthetic parameters")
        frames.append(cycle_frames(subject.parameters, theta, phi, n, es_phase, abnormality))
    stacked = np.stack(frames) if frames else np.zeros((0, n, len(cohort.atlas), 3))
    names = tuple(s.name for s in cohort.subjects)
    parameters = tuple(s.parameters for s in cohort.subjects)
    patients = np.array([a is not None for a in planted], dtype=bool)
    return CohortCycles(stacked, names, patients, times, fractions, cohort.faces, parameters,
                        None, data, float(es_phase), tuple(planted))  # fmt: skip


def make_two_group_cycles(
    n_subjects: int = 40,
    abnormality: MotionAbnormality | None = CYCLE_ABNORMALITY,
    n_frames: int = 25,
    es_phase: float = 0.35,
    n_vertices: int = 1009,
    seed: int = 0,
    patient_fraction: float = 0.5,
    model: SyntheticLVModel | None = None,
    check: bool = True,
) -> CohortCycles:
    """The two-group cohort through the whole cycle, every subject's images renderable.

    The cohort is ``make_two_group_cohort(n_subjects, patient_fraction, abnormality,
    n_vertices, seed, model=model)`` (no segmentation noise), the same subjects and groups
    as the surface cohort of that seed; its frames are :func:`two_group_cycles`'.

    Parameters
    ----------
    n_subjects : int, default 40
    abnormality : MotionAbnormality or None, default CYCLE_ABNORMALITY
        Planted in the patients; None for the null (no abnormality).
    n_frames : int, default 25
    es_phase : float, default 0.35
    n_vertices : int, default 1009
    seed : int, default 0
    patient_fraction : float, default 0.5
    model : SyntheticLVModel, optional
    check : bool, default True
        Check that every subject's motion is invertible at every frame
        (:meth:`CohortCycles.check_invertible`), so that every image renders.

    Returns
    -------
    CohortCycles
        With ``data``, the :class:`TwoGroupCohort`.
    """
    model = model or SyntheticLVModel()
    data = make_two_group_cohort(
        n_subjects, patient_fraction, abnormality, n_vertices, seed, model=model
    )
    cycles = two_group_cycles(data, n_frames, es_phase, model)
    if check:
        cycles.check_invertible()
    return cycles
