"""The SVF landmark space: contract with registration-level tolerances, residuals, cache,
inverse consistency, validation."""

import numpy as np
import pytest

from ladders import pole_ladder, schild_ladder, symmetry_errors
from manifolds import ResidualAugmented
from manifolds.errors import ManifoldError
from manifolds.lddmm import SVFLandmarks
from manifolds.testing import ConnectionContract


def small_space(**kw):
    """Six well-separated landmarks: registration is well posed and fast."""
    params = dict(sigma=0.6, alpha=1e-3, control_points="dense")
    params.update(kw)
    return SVFLandmarks(6, 2, **params)


class TestSVFContract(ConnectionContract):
    """The generic contract; log is a registration, exact up to ~1e-6 here."""

    space = small_space()
    rtol = 1e-4
    atol = 1e-4
    tangent_scale = 0.3
    max_examples = 4


class TestSVFGridContract(ConnectionContract):
    """Grid control points and RK2: the same contract."""

    space = small_space(control_points="grid", integrator="rk2", sigma=0.8)
    rtol = 1e-4
    atol = 1e-4
    tangent_scale = 0.3
    max_examples = 3


def test_exp_of_zero_log_at_self_and_symmetry_at_centre_are_exact():
    space = small_space(control_points="grid")
    a = space.random_point(np.random.default_rng(0))
    zero = np.zeros_like(space.control_points(a))
    np.testing.assert_array_equal(space.exp(a, zero), a)
    np.testing.assert_array_equal(space.log(a, a), zero)
    np.testing.assert_array_equal(space.symmetry(a, a), a)


def test_exp_of_negated_tangent_inverts_the_deformation():
    space = small_space(n_steps=20)
    rng = np.random.default_rng(1)
    a = space.random_point(rng)
    v = space.random_tangent(a, rng, 0.5)
    phi = space.deformation(a, v)
    b = space.exp(a, v)
    np.testing.assert_array_equal(phi(a), b)
    np.testing.assert_allclose(phi.inverse()(b), a, atol=1e-7)
    # the same through the space: the flow of -v from a's control points applied to b
    np.testing.assert_allclose(space.flow(a, -v, b), a, atol=1e-7)


def test_residual_augmented_wraps_the_space_unchanged():
    base = small_space(alpha=0.3)
    rng = np.random.default_rng(2)
    t, s = base.random_point(rng), base.random_point(rng)
    space = ResidualAugmented(base)
    log = space.log(t, s)
    assert base.n_registrations == 1
    np.testing.assert_allclose(space.exp(t, log), s, atol=1e-10)
    assert np.linalg.norm(log.residual) > 1e-3  # alpha = 0.3: the residual is not zero
    mom, resid = base.log_with_residual(t, s)
    res = base.register(t, s)
    assert base.n_registrations == 1
    np.testing.assert_array_equal(mom, log.tangent)
    np.testing.assert_array_equal(resid, res.residual)
    assert np.array_equal(space.symmetry(t, t), t)
    s2 = base.exp(s, base.random_tangent(s, rng, 0.2))
    for residuals in (True, False):
        wrapped = ResidualAugmented(base, residuals)
        u = wrapped.log(s, s2)
        for ladder in (pole_ladder, schild_ladder):
            w = ladder(wrapped, s, t, u)
            assert np.isfinite(w.tangent).all() and np.isfinite(w.residual).all()
        errs = symmetry_errors(wrapped, t, s, s2).as_dict()
        assert all(np.isfinite(v) and v >= 0 for v in errs.values())


def test_inverse_consistency_vanishes_for_exact_registrations():
    """With dense control points and a tiny alpha both registrations are exact on the
    vertices: phi_ST(phi_TS(T)) = T up to the registration accuracy; a large alpha
    leaves both deformations short of their targets and the error grows."""
    rng = np.random.default_rng(3)
    exact = small_space(alpha=1e-4)
    t = exact.random_point(rng)
    s = exact.exp(t, exact.random_tangent(t, rng, 0.3))
    size = np.sqrt(((s - t) ** 2).sum(axis=1).mean())  # per-vertex RMS, the default distance
    assert exact.inverse_consistency(t, s) < 1e-4 * size
    loose = small_space(alpha=1.0)
    assert loose.inverse_consistency(t, s) > 0.05 * size
    frobenius = loose.inverse_consistency(t, s, distance="frobenius")
    np.testing.assert_allclose(frobenius, np.sqrt(len(t)) * loose.inverse_consistency(t, s))


def test_cache_inner_and_random_tangent_scale():
    space = SVFLandmarks(40, 3, sigma=0.5, alpha=0.1, control_points="grid", cache_size=1)
    rng = np.random.default_rng(4)
    a = space.random_point(rng)
    cp = space.control_points(a)
    assert cp.shape[1] == 3 and cp.shape[0] >= 4 and cp is not a
    u = space.random_tangent(a, rng, scale=0.2)
    vel = space.kernel.convolve(cp, cp, u)
    np.testing.assert_allclose(np.sqrt((vel**2).sum(1).mean()), 0.2, rtol=1e-12)
    v = space.random_tangent(a, rng)
    k = space.kernel.matrix(cp)
    np.testing.assert_allclose(space.inner(a, u, v), np.sum(u * (k @ v)), rtol=1e-12)
    np.testing.assert_allclose(space.norm(a, u) ** 2, space.inner(a, u, u), rtol=1e-12)
    small = small_space(cache_size=1)
    p, q, r = small.random_point(rng, n_samples=3)
    small.log(p, q)
    small.log(p, q)
    assert small.n_registrations == 1
    small.log(p, r)
    small.log(p, q)  # evicted by the cache of size one
    assert small.n_registrations == 3
    assert "SVFLandmarks(k=6, d=2" in repr(small)


def test_validation_errors_name_the_argument():
    space = small_space()
    a = space.random_point(np.random.default_rng(5))
    with pytest.raises(ManifoldError, match="other"):
        space.log(a, np.zeros((7, 2)))
    with pytest.raises(ManifoldError, match="point"):
        space.exp(np.full((6, 2), np.nan), np.zeros((6, 2)))
    with pytest.raises(ManifoldError, match="tangent"):
        space.exp(a, np.zeros((5, 2)))
    with pytest.raises(ManifoldError, match="initial_momenta"):
        space.register(a, a, initial_momenta=np.zeros((6, 3)))
    with pytest.raises(ManifoldError, match="points"):
        space.flow(a, np.zeros((6, 2)), np.zeros((3, 3)))
    for kw, name in (
        (dict(dim=4), "dim"),
        (dict(alpha=-1.0), "alpha"),
        (dict(alpha=np.nan), "alpha"),
        (dict(n_steps=0), "n_steps"),
        (dict(n_landmarks=0), "n_landmarks"),
        (dict(control_points="random"), "control_points"),
        (dict(control_points=np.zeros(3)), "control_points"),
        (dict(sigma=0.0), "sigma"),
    ):
        params = dict(n_landmarks=6, dim=2, sigma=1.0, alpha=0.1)
        params.update(kw)
        with pytest.raises(ManifoldError, match=name):
            SVFLandmarks(**params)
    with pytest.raises(ValueError, match="integrator"):
        SVFLandmarks(6, 2, sigma=1.0, alpha=0.1, integrator="rk3")


def test_svf_space_refuses_to_optimise_its_control_points():
    with pytest.raises(ManifoldError, match="optimize_control_points"):
        SVFLandmarks(10, 3, sigma=0.5, alpha=0.1, optimize_control_points=True)
