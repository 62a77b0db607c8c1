"""The ideal transport of the synthetic cohort: each subject's own motion on the atlas's anatomy."""

import numpy as np
import pytest

from ladders.study.cohort.planted_effect import MotionAbnormality
from ladders.study.cohort.synthetic_lv import SyntheticLVModel
from ladders.study.errors import CohortError
from ladders.study.population import (
    AnatomyShift,
    Covariates,
    ideal_transport,
    make_covariate_cohort,
    transport_error,
)

K = 241
#: A model whose anatomy does not vary: every subject has the atlas's anatomy.
FIXED_ANATOMY = SyntheticLVModel(radius=(25.0, 25.0), long_axis=(85.0, 85.0),
                                 bulge=(0.025, 0.025), harmonic_amplitude=0.0)  # fmt: skip
NO_COVARIATES = Covariates(age_effect=0.0, body_size_sd=0.0)


def test_subjects_with_the_atlas_anatomy_are_their_own_ideal():
    data = make_covariate_cohort(
        4, (("controls", None), ("patients", MotionAbnormality())), NO_COVARIATES,
        seed=2, n_vertices=K, model=FIXED_ANATOMY,
    )  # fmt: skip
    np.testing.assert_allclose(data.cohort.ed, np.broadcast_to(data.cohort.atlas, data.cohort.ed.shape),
                               atol=1e-12)  # fmt: skip
    ideal = ideal_transport(data, FIXED_ANATOMY)
    motion = data.cohort.es - data.cohort.ed
    np.testing.assert_allclose(ideal, motion, atol=1e-12)
    assert transport_error(motion, ideal).max() < 1e-12
    # the planted abnormality is in the patients' ideal: their motion is smaller in the region
    region = data.regions["patients"].affected
    size = np.linalg.norm(ideal[:, region], axis=2).mean(axis=1)
    assert size[4:].max() < size[:4].min()


def test_an_anatomy_shift_leaves_the_ideal_unchanged():
    """The same subjects with and without a dilated anatomy: the same ideal, other motions."""
    groups = (("controls", None), ("other", None))
    shifted = (("controls", None), ("other", AnatomyShift(scale=1.2, sphericity=1.1, bulge=0.05)))
    plain = make_covariate_cohort(4, groups, seed=5, n_vertices=K)
    dilated = make_covariate_cohort(4, shifted, seed=5, n_vertices=K)
    a, b = ideal_transport(plain), ideal_transport(dilated)
    np.testing.assert_allclose(a, b, atol=1e-12)
    own = dilated.cohort.es - dilated.cohort.ed
    before = plain.cohort.es - plain.cohort.ed
    # the dilated subjects' own motion moved away from the ideal by the shift
    assert transport_error(own[4:], b[4:]).mean() > 1.5 * transport_error(before[4:], a[4:]).mean()
    np.testing.assert_allclose(transport_error(own[:4], b[:4]), transport_error(before[:4], a[:4]))


def test_the_ideal_is_on_the_atlas_and_keeps_the_subjects_motion_parameters():
    data = make_covariate_cohort(3, (("controls", None), ("b", None)), seed=1, n_vertices=K)
    ideal = ideal_transport(data)
    assert ideal.shape == data.cohort.ed.shape
    # the apex is a fixed point of every motion of the model (rotation about its axis)
    apex = int(np.argmin(data.cohort.atlas[:, 2]))
    np.testing.assert_allclose(ideal[:, apex], 0.0, atol=1e-9)
    # the base shortens by the subject's own fraction of the atlas's length
    top = np.isclose(data.cohort.atlas[:, 2], data.cohort.atlas[:, 2].max())
    for s, d in zip(data.cohort.subjects, ideal):
        np.testing.assert_allclose(d[top, 2], -s.parameters.longitudinal_shortening
                                   * data.cohort.atlas[top, 2])  # fmt: skip


def test_bad_input_is_refused():
    data = make_covariate_cohort(3, (("controls", None), ("b", None)), seed=1, n_vertices=K)
    with pytest.raises(CohortError, match="data: its atlas"):
        ideal_transport(data, SyntheticLVModel(radius=(20.0, 20.0)))
    with pytest.raises(CohortError, match="data: expected a CovariateCohort or a TwoGroupCohort"):
        ideal_transport(data.cohort)
    ideal = ideal_transport(data)
    with pytest.raises(CohortError, match="displacement: expected the shape"):
        transport_error(ideal[:, :10], ideal)
    bad = ideal.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(CohortError, match="NaN"):
        transport_error(bad, ideal)


def test_the_two_group_cohort_has_its_ideal_too():
    """make_two_group_cohort with the atlas's anatomy: every subject is its own ideal, the
    patients' with the planted abnormality, the controls' without."""
    from ladders.study.population import make_two_group_cohort

    data = make_two_group_cohort(8, abnormality=MotionAbnormality(), n_vertices=K,
                                 seed=4, model=FIXED_ANATOMY)  # fmt: skip
    np.testing.assert_allclose(ideal_transport(data, FIXED_ANATOMY),
                               data.cohort.es - data.cohort.ed, atol=1e-12)  # fmt: skip
