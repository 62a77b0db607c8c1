"""The ideal transport of a synthetic subject's motion: its own motion on the atlas's anatomy.

A transport carries a subject's end-diastole to end-systole motion onto the atlas. In
the synthetic cohort the answer is known: the motion parameters of the subject (radial
contraction and its heterogeneity and gradient, longitudinal shortening, apex and base
rotations, and the planted abnormality of its group), applied to the atlas's anatomy
(the model's mid-range anatomy without wall harmonics, which is how
:func:`~ladders.study.cohort.synthetic_lv.make_synthetic_cohort` builds the atlas).
:func:`ideal_transport` gives that displacement per subject and atlas vertex, and
:func:`transport_error` the distance of a transported motion to it: the measure of
how much of a subject's anatomy a transport leaves in its motion.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..cohort.cardiac_cycle import frame_abnormality, motion_forward
from ..cohort.planted_effect import planted_modulation
from ..cohort.synthetic_lv import (
    SubjectParameters,
    SyntheticLVModel,
    grid_shape,
    lv_grid,
    lv_shapes,
)
from ..errors import CohortError
from .covariate_cohort import CovariateCohort
from .two_groups import PATIENTS, TwoGroupCohort

__all__ = ["MOTION_PARAMETERS", "ideal_cycle_transport", "ideal_transport", "transport_error"]

#: The parameters of :class:`~ladders.study.cohort.synthetic_lv.SubjectParameters` that
#: describe the motion (the others describe the end-diastolic anatomy).
MOTION_PARAMETERS = (
    "longitudinal_shortening",
    "radial_contraction",
    "contraction_heterogeneity",
    "heterogeneity_phase",
    "contraction_gradient",
    "apex_rotation",
    "base_rotation",
)


def _abnormalities(data) -> dict:
    """``{subject: MotionAbnormality or None}`` of a generated cohort."""
    if isinstance(data, CovariateCohort):
        effects = {spec.name: spec.abnormality for spec in data.specs}
        return {name: effects[group] for name, group in data.groups.items()}
    if isinstance(data, TwoGroupCohort):
        planted = None if data.region is None else data.region.abnormality
        return {n: planted if g == PATIENTS else None for n, g in data.groups.items()}
    raise CohortError(
        f"data: expected a CovariateCohort or a TwoGroupCohort, got {type(data).__name__}"
    )


def _on_atlas(cohort, model: SyntheticLVModel | None):
    """The cohort's grid, the model's mean parameters and the atlas, checked to be the cohort's."""
    model = model or SyntheticLVModel()
    theta, phi, _ = lv_grid(*grid_shape(cohort.atlas.shape[0]), model)
    mean = SubjectParameters.mean(model)
    atlas, _ = lv_shapes(mean, theta, phi)
    if atlas.shape != cohort.atlas.shape or not np.allclose(atlas, cohort.atlas, atol=1e-9):
        raise CohortError(
            "data: its atlas is not the mid-range anatomy of this model on its grid "
            "(pass the SyntheticLVModel the cohort was drawn with)"
        )
    return theta, phi, mean, atlas


def _motion_on(mean: SubjectParameters, subject) -> SubjectParameters:
    """The atlas's anatomy with ``subject``'s motion parameters."""
    if subject.parameters is None:
        raise CohortError(f"data: subject {subject.name} has no generator parameters")
    return replace(mean, **{name: getattr(subject.parameters, name) for name in MOTION_PARAMETERS})


def ideal_transport(data, model: SyntheticLVModel | None = None) -> np.ndarray:
    """Each subject's motion parameters applied to the atlas's anatomy, as a displacement.

    Parameters
    ----------
    data : CovariateCohort or TwoGroupCohort
        A cohort of :func:`~ladders.study.population.make_covariate_cohort` or
        :func:`~ladders.study.population.make_two_group_cohort` (its subjects keep the
        parameters they were drawn with, after the covariates and the anatomy shifts
        acted on them; segmentation noise is not part of the motion).
    model : SyntheticLVModel, optional
        The model the cohort was drawn with (default ``SyntheticLVModel()``).

    Returns
    -------
    ndarray, shape (n, k, 3)
        ``ES_i - T`` on the atlas ``T``, subject ``i`` in cohort order (mm).

    Raises
    ------
    CohortError
        The cohort's atlas is not the model's mid-range anatomy on the cohort's grid
        (another model, or a cohort not drawn by the generator), or a subject has no
        parameters.
    """
    planted = _abnormalities(data)
    cohort = data.cohort
    theta, phi, mean, atlas = _on_atlas(cohort, model)
    modulations = {None: None}
    for abnormality in planted.values():
        if abnormality not in modulations:
            modulations[abnormality] = planted_modulation(abnormality, theta, phi)
    out = np.empty((len(cohort.subjects),) + atlas.shape)
    for i, s in enumerate(cohort.subjects):
        _, es = lv_shapes(_motion_on(mean, s), theta, phi, modulations[planted[s.name]])
        out[i] = es - atlas
    return out


def ideal_cycle_transport(cycles, model: SyntheticLVModel | None = None) -> np.ndarray:
    """The ideal transport of every frame: each subject's motion through the cycle on the atlas.

    Parameters
    ----------
    cycles : CohortCycles
        From :func:`~ladders.study.population.make_two_group_cycles` (or
        :func:`~ladders.study.population.two_group_cycles`).
    model : SyntheticLVModel, optional
        The model the cohort was drawn with (default ``SyntheticLVModel()``).

    Returns
    -------
    ndarray, shape (n_subjects, n_frames, k, 3)
        ``T_i(t) - T`` on the atlas ``T`` (mm); frame 0 is zero, and at the ES frame it
        equals :func:`ideal_transport`.
    """
    data = getattr(cycles, "data", None)
    if data is None or not hasattr(cycles, "fractions"):
        raise CohortError(f"cycles: expected a CohortCycles, got {type(cycles).__name__}")
    theta, phi, mean, atlas = _on_atlas(data.cohort, model)
    out = np.empty((len(cycles.names), len(cycles.fractions)) + atlas.shape)
    for i, s in enumerate(data.cohort.subjects):
        params = _motion_on(mean, s)
        abnormality = cycles.abnormality if cycles.patients[i] else None
        es_phase = getattr(cycles, "es_phase", 0.35)
        for t, f in enumerate(cycles.fractions):
            acting = frame_abnormality(abnormality, float(cycles.times[t]), es_phase)
            out[i, t] = motion_forward(params, atlas, float(f), acting) - atlas
    return out


def transport_error(displacement, ideal) -> np.ndarray:
    """Mean distance over the atlas's vertices of each transported displacement to its ideal.

    Parameters
    ----------
    displacement, ideal : array, shape (n, k, 3)

    Returns
    -------
    ndarray, shape (n,)
        ``mean_j |d_ij - ideal_ij|`` per subject (mm).
    """
    d = np.asarray(displacement, dtype=float)
    ideal = np.asarray(ideal, dtype=float)
    if d.shape != ideal.shape or d.ndim != 3:
        raise CohortError(
            f"displacement: expected the shape of ideal {ideal.shape} (n, k, 3), got {d.shape}"
        )
    if not (np.isfinite(d).all() and np.isfinite(ideal).all()):
        raise CohortError("displacement: contains NaN or infinite values")
    return np.linalg.norm(d - ideal, axis=2).mean(axis=1)
