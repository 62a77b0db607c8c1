"""The atlas's registrations: coarse to fine reaches a subject the narrow data term alone
does not see."""

import numpy as np
import pytest
import trimesh

from ladders.study.preparation import CorrespondenceSettings
from ladders.study.preparation.atlas_registrations import CoarseToFine, register_atlas_onto
from manifolds.lddmm import LDDMMLandmarks, RegistrationSettings

SETTINGS = RegistrationSettings(sigma=1.0, control_points="grid", max_iter=100)


@pytest.fixture(scope="module")
def far_pair():
    """A unit sphere and the same sphere moved by four data-term widths (0.2) along x."""
    sphere = trimesh.creation.icosphere(subdivisions=1)
    v, f = np.array(sphere.vertices), np.array(sphere.faces)
    return v, f, v + [0.8, 0.0, 0.0]


@pytest.mark.filterwarnings("ignore::manifolds.errors.ConvergenceWarning")
def test_coarse_to_fine_reaches_a_subject_the_narrow_term_does_not(far_pair):
    v, f, target = far_pair
    settings = CorrespondenceSettings(sigma_w=0.2, weight=1.0)
    fine = settings.data_term_for(target, f, f)
    coarse = settings.data_term_for(target, f, f, width_factor=3.0)
    assert coarse.sigma_w == pytest.approx(3.0 * fine.sigma_w)
    direct = register_atlas_onto(v, fine, 0.1, SETTINGS)
    staged = register_atlas_onto(v, CoarseToFine(coarse, fine), 0.1, SETTINGS)
    # both report the narrow term's objective; the staged one is far lower
    assert staged.objective < 0.3 * direct.objective
    space = LDDMMLandmarks(len(v), 3, alpha=0.1, settings=SETTINGS)
    shift = [space.exp(v, r.log).mean(0)[0] for r in (direct, staged)]
    assert shift[0] < 0.4  # the narrow term alone stays about the start
    assert abs(shift[1] - 0.8) < 0.05  # coarse to fine reaches the subject


def test_the_factor_is_checked_and_one_means_directly():
    with pytest.raises(ValueError, match="atlas_coarse_factor"):
        CorrespondenceSettings(atlas_coarse_factor=0.5)
    assert CorrespondenceSettings().atlas_coarse_factor == 3.0
    keys = {CorrespondenceSettings(atlas_coarse_factor=c).key() for c in (1.0, 3.0)}
    assert len(keys) == 2  # an atlas made otherwise is not reused
