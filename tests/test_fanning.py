"""Fanning scheme: first-order convergence, exactness in a flat case, conserved quantities,
the space's own integrator and the capability it needs."""

import numpy as np
import pytest

from ladders.convergence import loglog_slope
from ladders.fanning import NoMomentumFlowError, fanning_scheme, fanning_transport
from manifolds import Hypersphere
from manifolds.errors import ConvergenceError
from manifolds.lddmm import LDDMMLandmarks, SVFLandmarks
from manifolds.lddmm.hamiltonian_shooting import shoot


def _space(n=6, sigma=1.0, integrator="rk2", n_steps=10):
    return LDDMMLandmarks(
        n, 2, sigma=sigma, alpha=0.0, integrator=integrator, n_steps=n_steps,
        kernel_backend="numpy",
    )  # fmt: skip


def _setup(seed=0, n=6, sigma=1.0, integrator="rk2"):
    rng = np.random.default_rng(seed)
    c = rng.uniform(-1, 1, size=(n, 2))
    mu = 0.6 * rng.standard_normal((n, 2))
    w = 0.5 * rng.standard_normal((n, 2))
    return _space(n, sigma, integrator), c, mu, w


def _rkhs(kernel, c, a, b):
    return float((a * kernel.convolve(c, c, b)).sum())


@pytest.mark.parametrize("integrator", ["rk2", "euler"])
def test_first_order_convergence(integrator):
    space, c, mu, w = _setup(integrator=integrator)
    ref = fanning_scheme(space, c, mu, w, n_steps=1024).momenta
    ns = [8, 16, 32, 64]
    errors = [
        np.linalg.norm(fanning_scheme(space, c, mu, w, n_steps=n).momenta - ref)
        / np.linalg.norm(ref)
        for n in ns
    ]
    assert max(errors) > 1e-6  # the geometry is curved: the scheme is not exact here
    assert loglog_slope(ns, errors) <= -0.8


def test_exact_for_a_single_control_point():
    # One control point: the metric is flat (K = 1), geodesics are straight lines
    # and parallel transport is the identity.
    c, mu, w = np.array([[0.2, -0.1]]), np.array([[0.8, 0.3]]), np.array([[-0.4, 0.9]])
    for n, integrator in ((1, "euler"), (3, "rk2"), (10, "rk4")):
        res = fanning_scheme(_space(1, 0.7, integrator), c, mu, w, n_steps=n)
        np.testing.assert_allclose(res.momenta, w, atol=1e-12)
        np.testing.assert_allclose(res.control_points, c + mu, atol=1e-12)


def test_conserves_norm_and_component_along_geodesic():
    space, c, mu, w = _setup(seed=1)
    kernel = space.kernel
    res = fanning_scheme(space, c, mu, w, n_steps=20)
    # Geodesic momenta at the end, shot with the space's integrator in the same 20 steps.
    end = shoot(kernel, c, mu, space.integrator, n_steps=20)
    c_end, mu_end = end.control_points, end.momenta
    np.testing.assert_allclose(res.control_points, c_end, atol=1e-14)
    w1 = res.momenta
    np.testing.assert_allclose(_rkhs(kernel, c_end, w1, w1), _rkhs(kernel, c, w, w), rtol=1e-10)
    np.testing.assert_allclose(
        _rkhs(kernel, c_end, w1, mu_end), _rkhs(kernel, c, w, mu), rtol=1e-10
    )


def test_zero_geodesic_is_identity_to_second_order():
    space, c, _, w = _setup(seed=2)
    res = fanning_scheme(space, c, np.zeros_like(c), w, n_steps=10)
    np.testing.assert_allclose(res.control_points, c, atol=0)
    assert np.linalg.norm(res.momenta - w) / np.linalg.norm(w) < 1e-2


def test_norm_drift_guard_and_bad_input():
    space, c, mu, w = _setup(seed=3)
    with pytest.raises(ConvergenceError, match="n_steps"):
        fanning_scheme(space, c, 3 * mu, w, n_steps=2, max_norm_drift=1e-6)
    with pytest.raises(ValueError, match="tangent"):
        fanning_scheme(space, c, mu, w[:-1], n_steps=2)
    with pytest.raises(ValueError, match="geodesic_momenta"):
        fanning_scheme(space, c, np.full_like(mu, np.nan), w, n_steps=2)
    with pytest.raises(ValueError, match="n_steps"):
        fanning_scheme(space, c, mu, w, n_steps=0)


def test_fanning_transport_on_lddmm_space_agrees_with_pole_ladder():
    """Both transports approximate the same parallel transport on a smooth case."""
    from ladders import pole_ladder

    rng = np.random.default_rng(4)
    space = LDDMMLandmarks(12, 2, sigma=0.8, alpha=0.0, control_points="dense", n_steps=10)
    s = space.random_point(rng)
    geo = 0.15 * space.random_tangent(s, rng)
    u = 0.1 * space.random_tangent(s, rng)
    t = space.exp(s, geo)
    fan = fanning_transport(space, s, t, u, n_steps=20)
    v_fan = space.kernel.convolve(fan.control_points, fan.control_points, fan.momenta)
    w_pole = pole_ladder(space, s, t, u)
    c_t = space.control_points(t)
    v_pole = space.kernel.convolve(c_t, c_t, w_pole)
    rel = np.linalg.norm(v_fan - v_pole) / np.linalg.norm(v_pole)
    assert rel < 0.1, rel


@pytest.mark.parametrize("integrator", ["euler", "rk2", "rk4"])
def test_the_fanning_geodesic_is_the_one_the_space_shoots(integrator):
    """With the space's n_steps, the fanning ends where the space's own shooting ends."""
    rng = np.random.default_rng(5)
    space = LDDMMLandmarks(12, 2, sigma=0.8, alpha=0.0, integrator=integrator, n_steps=7)
    s = space.random_point(rng)
    geo, u = 0.3 * space.random_tangent(s, rng), 0.1 * space.random_tangent(s, rng)
    c = space.control_points(s)
    fan = fanning_scheme(space, c, geo, u, n_steps=space.n_steps)
    _, trajectory = space.shoot(s, geo, return_trajectory=True)
    np.testing.assert_array_equal(fan.control_points, trajectory[-1][0])
    other = fanning_scheme(space, c, geo, u, n_steps=space.n_steps + 1)
    assert not np.array_equal(other.control_points, trajectory[-1][0])


def test_spaces_without_a_flow_of_momenta_are_refused_by_name():
    rng = np.random.default_rng(6)
    svf = SVFLandmarks(8, 2, sigma=0.8, alpha=0.1, control_points="dense")
    s = svf.random_point(rng)
    t = svf.exp(s, 0.1 * svf.random_tangent(s, rng))
    u = 0.1 * svf.random_tangent(s, rng)
    with pytest.raises(NoMomentumFlowError, match="fanning_transport: space: .*SVFLandmarks"):
        fanning_transport(svf, s, t, u)
    sphere = Hypersphere(2)
    x = sphere.random_point(rng)
    with pytest.raises(NoMomentumFlowError, match="fanning_scheme: space: .*Hypersphere"):
        fanning_scheme(sphere, x[None, :2], x[None, :2], x[None, :2])
    assert issubclass(NoMomentumFlowError, TypeError)
