"""Residual-augmented LDDMM space: exactness with residuals and the PDM limit alpha -> infinity."""

import numpy as np
import pytest

from ladders import pole_ladder, schild_ladder, symmetry_errors
from manifolds import Euclidean, LDDMMLandmarks, ResidualAugmented


def _shapes(seed=0, k=18):
    rng = np.random.default_rng(seed)
    space = LDDMMLandmarks(k, 2, sigma=0.6, alpha=0.1, control_points="dense")
    t = space.random_point(rng)
    s = space.exp(t, 0.3 * space.random_tangent(t, rng)) + 0.02 * rng.standard_normal((k, 2))
    s2 = space.exp(s, 0.2 * space.random_tangent(s, rng))
    return t, s, s2


@pytest.mark.parametrize("alpha", [0.05, 1.0])
def test_residuals_make_exp_log_exact_and_fix_the_centre(alpha):
    t, s, _ = _shapes()
    space = ResidualAugmented(LDDMMLandmarks(len(t), 2, sigma=0.6, alpha=alpha))
    log = space.log(t, s)
    np.testing.assert_allclose(space.exp(t, log), s, rtol=0, atol=1e-10)
    assert np.array_equal(space.symmetry(t, t), t)
    assert np.array_equal(space.midpoint(t, t), t)


def test_pdm_is_the_large_alpha_limit():
    t, s, s2 = _shapes(seed=1)
    pdm = Euclidean(t.shape)
    gaps, norms = [], []
    for alpha in (1.0, 10.0, 100.0, 1000.0):
        base = LDDMMLandmarks(len(t), 2, sigma=0.6, alpha=alpha)
        space = ResidualAugmented(base)
        gaps.append(np.linalg.norm(space.symmetry(t, s) - pdm.symmetry(t, s)))
        norms.append(base.norm(t, base.log(t, s)))
    assert np.all(np.diff(gaps) < 0) and np.all(np.diff(norms) < 0)
    assert gaps[-1] < 1e-5 * np.linalg.norm(s - t)
    # In the limit every symmetry error of the residual variant vanishes (flat space) ...
    big = ResidualAugmented(LDDMMLandmarks(len(t), 2, sigma=0.6, alpha=1e4))
    assert max(symmetry_errors(big, t, s, s2).as_dict().values()) < 1e-6
    # ... while without residuals the symmetry collapses onto its centre: s_T(S) -> T.
    plain = ResidualAugmented(LDDMMLandmarks(len(t), 2, sigma=0.6, alpha=1e4), False)
    assert np.linalg.norm(plain.symmetry(t, s) - t) < 1e-5 * np.linalg.norm(s - t)


def test_generic_ladders_run_on_both_variants():
    t, s, s2 = _shapes(seed=2)
    base = LDDMMLandmarks(len(t), 2, sigma=0.6, alpha=0.3)
    for residuals in (True, False):
        space = ResidualAugmented(base, residuals)
        u = space.log(s, s2)
        for ladder in (pole_ladder, schild_ladder):
            w, traj = ladder(space, s, t, u, n_rungs=2, return_trajectory=True)
            assert np.isfinite(traj.end_point).all()
            assert np.isfinite(w.tangent).all() and np.isfinite(w.residual).all()
        errs = symmetry_errors(space, t, s, s2)
        assert all(np.isfinite(v) for v in errs.as_dict().values())
