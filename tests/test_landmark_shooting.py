"""Hamiltonian shooting and point flow: invariants, convergence orders, adjoint."""

import numpy as np
import pytest

from manifolds.lddmm.hamiltonian_shooting import hamiltonian, shoot, shooting_vjp
from manifolds.lddmm.kernels import GaussianKernel
from manifolds.numerics.integrators import RK4, get_integrator

SIGMA = 0.8


def setup(n_cp=12, n_pts=15, dim=2, scale=0.3, seed=0):
    rng = np.random.default_rng(seed)
    c = rng.uniform(-1, 1, (n_cp, dim))
    mu = scale * rng.standard_normal((n_cp, dim))
    x = rng.uniform(-1, 1, (n_pts, dim))
    return GaussianKernel(SIGMA, backend="numpy"), c, mu, x


@pytest.mark.parametrize("integrator", ["euler", "rk2", "rk4"])
def test_zero_momenta_is_identity(integrator):
    kernel, c, mu, x = setup()
    res = shoot(kernel, c, np.zeros_like(mu), integrator, 7, points=x)
    np.testing.assert_array_equal(res.points, x)
    np.testing.assert_array_equal(res.control_points, c)
    np.testing.assert_array_equal(res.momenta, 0.0)


@pytest.mark.parametrize("integrator", ["euler", "rk2", "rk4"])
def test_flow_of_control_points_equals_their_shooting(integrator):
    kernel, c, mu, _ = setup(scale=0.8)
    res = shoot(kernel, c, mu, integrator, 10, points=c.copy())
    np.testing.assert_allclose(res.points, res.control_points, rtol=0, atol=1e-14)


def test_hamiltonian_is_conserved_by_rk4():
    kernel, c, mu, _ = setup(n_cp=10, dim=3, scale=0.4, seed=2)
    res = shoot(kernel, c, mu, RK4, 10, return_trajectory=True)
    h = np.array([hamiltonian(kernel, s[0], s[1]) for s in res.trajectory])
    assert len(res.trajectory) == 11
    assert np.max(np.abs(h - h[0])) <= 1e-6 * h[0]
    # Euler does not conserve it to that accuracy: the check can fail.
    euler = shoot(kernel, c, mu, "euler", 10, return_trajectory=True)
    h_e = np.array([hamiltonian(kernel, s[0], s[1]) for s in euler.trajectory])
    assert np.max(np.abs(h_e - h_e[0])) > 1e-6 * h_e[0]


def test_trajectory_starts_at_initial_state():
    kernel, c, mu, x = setup()
    res = shoot(kernel, c, mu, "rk2", 5, points=x, return_trajectory=True)
    first, last = res.trajectory[0], res.trajectory[-1]
    np.testing.assert_array_equal(first[0], c)
    np.testing.assert_array_equal(first[1], mu)
    np.testing.assert_array_equal(first[2], x)
    np.testing.assert_array_equal(last[2], res.points)


@pytest.mark.parametrize("integrator, order", [("euler", 1), ("rk2", 2), ("rk4", 4)])
def test_convergence_order(integrator, order):
    kernel, c, mu, x = setup(n_cp=8, n_pts=6, scale=0.6, seed=4)
    ref = shoot(kernel, c, mu, RK4, 256, points=x).points
    steps = [4, 8, 16] if order < 4 else [2, 4, 8]
    errs = [np.abs(shoot(kernel, c, mu, integrator, n, points=x).points - ref).max() for n in steps]
    slope = -np.polyfit(np.log(steps), np.log(errs), 1)[0]
    assert abs(slope - order) < 0.3, (errs, slope)


@pytest.mark.parametrize("integrator", ["euler", "rk2", "rk4"])
def test_shooting_vjp_matches_finite_differences(integrator):
    kernel, c, mu, x = setup(n_cp=5, n_pts=4, scale=0.5, seed=6)
    rng = np.random.default_rng(7)
    wc, wm, wx = (rng.standard_normal(a.shape) for a in (c, mu, x))

    def scalar(cc, mm, xx):
        r = shoot(kernel, cc, mm, integrator, 6, points=xx)
        return (wc * r.control_points).sum() + (wm * r.momenta).sum() + (wx * r.points).sum()

    res = shoot(kernel, c, mu, integrator, 6, points=x, keep_stages=True)
    grads = shooting_vjp(kernel, res, wc, wm, wx)
    args = [c, mu, x]
    for which, g in enumerate(grads):
        d = rng.standard_normal(args[which].shape)
        eps = 1e-6
        plus = [a + eps * d if i == which else a for i, a in enumerate(args)]
        minus = [a - eps * d if i == which else a for i, a in enumerate(args)]
        fd = (scalar(*plus) - scalar(*minus)) / (2 * eps)
        np.testing.assert_allclose((g * d).sum(), fd, rtol=1e-7)


def test_shooting_vjp_needs_stages_and_unknown_integrator_raises():
    kernel, c, mu, _ = setup()
    with pytest.raises(ValueError, match="keep_stages"):
        shooting_vjp(kernel, shoot(kernel, c, mu), c)
    with pytest.raises(ValueError, match="integrator"):
        get_integrator("leapfrog")
    with pytest.raises(ValueError, match="n_steps"):
        shoot(kernel, c, mu, "euler", 0)


def test_a_registered_hamiltonian_system_is_the_one_the_shooting_integrates():
    """``register_system`` replaces a backend's system; the shot is unchanged by a subclass."""
    from manifolds.lddmm.hamiltonian_system import (
        _SYSTEMS,
        HamiltonianSystem,
        hamiltonian_system,
        register_system,
    )

    calls = []

    class Counting(HamiltonianSystem):
        def rhs(self, state):
            calls.append(len(state))
            return super().rhs(state)

    kernel = GaussianKernel(0.7, backend="numpy")
    rng = np.random.default_rng(3)
    c, mu, x = rng.normal(size=(5, 2)), 0.1 * rng.normal(size=(5, 2)), rng.normal(size=(7, 2))
    before = shoot(kernel, c, mu, "rk2", 4, points=x)
    previous = _SYSTEMS["numpy"]
    register_system("numpy", Counting)
    try:
        assert isinstance(hamiltonian_system(kernel), Counting)
        after = shoot(kernel, c, mu, "rk2", 4, points=x)
    finally:
        register_system("numpy", previous)
    assert calls == [3] * 8  # 4 steps of 2 stages, on (c, mu, x)
    np.testing.assert_array_equal(after.points, before.points)
    with pytest.raises(TypeError, match="register_system: system"):
        register_system("numpy", object)
