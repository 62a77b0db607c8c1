"""Flows of stationary fields: linear fields against matrix exponentials, inverse by
negation and its convergence order, and the exact adjoint against autograd."""

import autograd.numpy as anp
import numpy as np
import pytest
import scipy.linalg
from autograd import grad

from manifolds.lddmm.kernels import GaussianKernel
from manifolds.lddmm.stationary_flow import (
    StationaryFlow,
    integrate_stationary,
    kernel_flow,
    kernel_flow_vjp,
)
from manifolds.numerics.integrators import RK2, RK4, Euler

SIGMA = 0.6
A = np.array([[0.3, -1.2], [0.9, -0.4]])


def slope(n_steps, errors):
    """Least-squares slope of ``log(error)`` against ``log(1 / n_steps)``."""
    return np.polyfit(np.log(1.0 / np.asarray(n_steps)), np.log(errors), 1)[0]


def kernel_problem(seed=0, n_cp=8, k=20, scale=0.8):
    rng = np.random.default_rng(seed)
    cp = rng.uniform(-1, 1, (n_cp, 2))
    return cp, scale * rng.standard_normal((n_cp, 2)), rng.uniform(-1, 1, (k, 2))


def test_linear_field_flow_is_matrix_exponential_with_order_four():
    x = np.random.default_rng(1).uniform(-1, 1, (15, 2))
    exact = x @ scipy.linalg.expm(A).T
    steps = [4, 8, 16, 32]
    errs = [
        np.abs(integrate_stationary(lambda p: p @ A.T, x, "rk4", n).points - exact).max()
        for n in steps
    ]
    assert errs[-1] < 1e-7
    assert 3.8 < slope(steps, errs) < 4.2
    # Time t of the flow: expm(t A), backwards included.
    for t in (0.5, -1.0):
        got = StationaryFlow(lambda p: p @ A.T, n_steps=64, time=t)(x)
        np.testing.assert_allclose(got, x @ scipy.linalg.expm(t * A).T, atol=1e-9)


def test_exp_of_zero_is_identity():
    cp, m, x = kernel_problem()
    kernel = GaussianKernel(SIGMA)
    for name in ("euler", "rk2", "rk4"):
        np.testing.assert_array_equal(kernel_flow(kernel, cp, 0 * m, x, name, 5).points, x)
    np.testing.assert_array_equal(StationaryFlow.from_momenta(kernel, cp, m).scaled(0.0)(x), x)


@pytest.mark.parametrize("integrator, low, high", [("rk4", 3.5, 5.5), ("rk2", 1.8, 3.3)])
def test_inverse_is_negated_field_with_measured_order(integrator, low, high):
    """``exp(-v) o exp(v) - id`` vanishes with the step; measured orders are 5 (RK4) and
    3 (RK2): for even-order schemes the leading error terms of the forward and the
    backward flow cancel, so the composition gains one order over each flow."""
    kernel = GaussianKernel(SIGMA)
    cp, m, x = kernel_problem()
    steps = [4, 8, 16, 32]
    errs = []
    for n in steps:
        y = kernel_flow(kernel, cp, m, x, integrator, n).points
        errs.append(np.abs(kernel_flow(kernel, cp, -m, y, integrator, n).points - x).max())
    assert np.all(np.diff(errs) < 0)
    assert low < slope(steps, errs) < high
    if integrator == "rk4":
        assert 4.5 < slope(steps, errs) and errs[-1] < 1e-7


def ag_flow(x, cp, m, scheme, n_steps):
    """The same Runge-Kutta flow of ``v(x) = sum_j K(x, c_j) m_j`` in autograd.numpy."""

    def vel(p):
        sq = anp.sum((p[:, None, :] - cp[None, :, :]) ** 2, axis=-1)
        return anp.dot(anp.exp(-sq / SIGMA**2), m)

    h = 1.0 / n_steps
    for _ in range(n_steps):
        ks = []
        for s in range(len(scheme.b)):
            stage = x
            for r, a in enumerate(scheme.a[s]):
                if a != 0.0:
                    stage = stage + h * a * ks[r]
            ks.append(vel(stage))
        for s, b in enumerate(scheme.b):
            if b != 0.0:
                x = x + h * b * ks[s]
    return x


@pytest.mark.parametrize("scheme", [Euler, RK2, RK4], ids=lambda s: s.name)
def test_flow_vjp_matches_autograd_and_central_differences(scheme):
    kernel = GaussianKernel(SIGMA, backend="numpy")
    cp, m, x = kernel_problem(seed=2)
    cot = np.random.default_rng(3).standard_normal(x.shape)
    n = 5
    res = kernel_flow(kernel, cp, m, x, scheme, n, keep_stages=True)
    np.testing.assert_allclose(res.points, ag_flow(x, cp, m, scheme, n), rtol=1e-13)
    g_x, g_m, g_c = kernel_flow_vjp(kernel, cp, m, res, cot)
    refs = [
        grad(lambda xx: anp.sum(cot * ag_flow(xx, cp, m, scheme, n)))(x),
        grad(lambda mm: anp.sum(cot * ag_flow(x, cp, mm, scheme, n)))(m),
        grad(lambda cc: anp.sum(cot * ag_flow(x, cc, m, scheme, n)))(cp),
    ]
    for got, ref in zip((g_x, g_m, g_c), refs):
        assert np.linalg.norm(got - ref) <= 1e-10 * np.linalg.norm(ref)
    # Central differences along a random direction of the momenta.
    d = np.random.default_rng(4).standard_normal(m.shape)
    eps = 1e-5

    def f(mm):
        return float((cot * kernel_flow(kernel, cp, mm, x, scheme, n).points).sum())

    fd = (f(m + eps * d) - f(m - eps * d)) / (2 * eps)
    assert abs(fd - (g_m * d).sum()) <= 1e-7 * abs(fd)


def test_vjp_needs_stages():
    kernel = GaussianKernel(SIGMA)
    cp, m, x = kernel_problem()
    res = kernel_flow(kernel, cp, m, x)
    with pytest.raises(ValueError, match="keep_stages"):
        kernel_flow_vjp(kernel, cp, m, res, x)
