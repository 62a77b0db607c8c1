"""Warm starts of iterative logarithms: log_near and symmetry_near in the generic layer."""

import numpy as np
import pytest

from ladders import symmetry_errors
from manifolds import Hypersphere, LDDMMLandmarks, ResidualAugmented


def test_closed_form_spaces_ignore_the_start():
    sphere = Hypersphere(2)
    rng = np.random.default_rng(0)
    a, b = sphere.random_point(rng), sphere.random_point(rng)
    start = sphere.random_tangent(a, rng)
    np.testing.assert_array_equal(sphere.log_near(a, b, start), sphere.log(a, b))
    np.testing.assert_array_equal(sphere.symmetry_near(a, b, start), sphere.symmetry(a, b))
    t, s, s2 = (sphere.random_point(rng) for _ in range(3))
    cold = symmetry_errors(sphere, t, s, s2).as_dict()
    assert symmetry_errors(sphere, t, s, s2, warm_start=True).as_dict() == cold


def shapes(seed=0, k=30):
    space = LDDMMLandmarks(
        k, 2, sigma=0.6, alpha=0.1, control_points="grid", stopping="shape", shape_tol=1e-9,
        max_iter=3000,
    )  # fmt: skip
    rng = np.random.default_rng(seed)
    t = space.random_point(rng)
    s = space.exp(t, space.random_tangent(t, rng, 0.3)) + 0.01 * rng.standard_normal((k, 2))
    s2 = space.exp(s, space.random_tangent(s, rng, 0.2))
    return space, t, s, s2


def test_landmark_log_near_reaches_the_same_minimiser_in_fewer_iterations():
    space, t, s, s2 = shapes()
    cold = space.register(t, s)
    near = space.register(t, s, initial_momenta=cold.momenta * 1.05)
    assert near.n_iter < cold.n_iter
    np.testing.assert_allclose(near.deformed, cold.deformed, atol=1e-7)
    v = space.log_near(t, s, cold.momenta)
    np.testing.assert_allclose(space.exp(t, v), cold.deformed, atol=1e-7)


@pytest.mark.parametrize("use_residuals", [True, False])
def test_warm_and_cold_symmetry_errors_agree_when_registrations_converge(use_residuals):
    space, t, s, s2 = shapes(1)
    sp = ResidualAugmented(space, use_residuals)
    cold = symmetry_errors(sp, t, s, s2)
    regs = space.n_registrations
    warm = symmetry_errors(sp, t, s, s2, warm_start=True)
    # the warm involutivity is one new registration; every other one is a cache hit
    assert space.n_registrations == regs + 1
    for name in ("midpoint_distance", "centrality", "transvectivity"):
        assert getattr(warm, name) == getattr(cold, name)
    assert warm.involutivity == pytest.approx(cold.involutivity, rel=1e-4, abs=1e-8)


def test_residual_log_near_keeps_exp_log_exact():
    space, t, s, _ = shapes(2)
    sp = ResidualAugmented(space, True)
    v = sp.log(t, s)
    near = sp.log_near(t, s, 1.01 * v)
    np.testing.assert_allclose(sp.exp(t, near), s, atol=1e-12)
    off = ResidualAugmented(space, False).log_near(t, s, v)
    assert not off.residual.any()
