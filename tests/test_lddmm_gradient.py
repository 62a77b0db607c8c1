"""The hand-written adjoint gradient of the registration objective (eq. 3) is exact.

It is compared with reverse-mode automatic differentiation of an independent
implementation of the same discrete forward pass (written here with
``autograd.numpy``) and with central finite differences, for Euler, RK2 and
RK4, dense and grid control points, in 2-D and 3-D.
"""

import autograd.numpy as anp
import numpy as np
import pytest
from autograd import grad

from manifolds.lddmm.control_points import grid_control_points
from manifolds.lddmm.kernels import GaussianKernel
from manifolds.lddmm.registration import registration_objective
from manifolds.numerics.integrators import RK2, RK4, Euler

SIGMA = 0.6
ALPHA = 0.3
N_STEPS = 4
TABLEAUS = {"euler": Euler, "rk2": RK2, "rk4": RK4}


def ag_kernel(x, y):
    sq = anp.sum((x[:, None, :] - y[None, :, :]) ** 2, axis=-1)
    return anp.exp(-sq / SIGMA**2)


def ag_rhs(state):
    c, mu = state[0], state[1]
    k_cc = ag_kernel(c, c)
    dc = anp.dot(k_cc, mu)
    w = k_cc * anp.dot(mu, mu.T)
    dmu = (2 / SIGMA**2) * (c * anp.sum(w, axis=1)[:, None] - anp.dot(w, c))
    if len(state) == 2:
        return [dc, dmu]
    return [dc, dmu, anp.dot(ag_kernel(state[2], c), mu)]


def ag_shoot(state, scheme, n_steps=N_STEPS):
    """The state ``[c, mu(, x)]`` shot through the Runge-Kutta tableau, in autograd.numpy."""
    h = 1.0 / n_steps
    for _ in range(n_steps):
        ks = []
        for s in range(len(scheme.b)):
            stage = list(state)
            for r, a in enumerate(scheme.a[s]):
                if a != 0.0:
                    stage = [y + h * a * k for y, k in zip(stage, ks[r])]
            ks.append(ag_rhs(stage))
        new = list(state)
        for s, b in enumerate(scheme.b):
            if b != 0.0:
                new = [y + h * b * k for y, k in zip(new, ks[s])]
        state = new
    return state


def ag_objective(mu, template, target, cp, scheme, dense):
    """Objective of eq. (3) through the Runge-Kutta tableau, in autograd.numpy."""
    reg = anp.sum(mu * anp.dot(ag_kernel(cp, cp), mu))
    state = ag_shoot([cp, mu] if dense else [cp, mu, template], scheme)
    deformed = state[0] if dense else state[2]
    return anp.sum((target - deformed) ** 2) + ALPHA**2 * reg


def make_problem(dim, n_points, dense, seed):
    rng = np.random.default_rng(seed)
    template = rng.uniform(-1, 1, size=(n_points, dim))
    target = template + 0.2 * rng.standard_normal((n_points, dim))
    cp = template if dense else grid_control_points(template, SIGMA)
    mu = 0.4 * rng.standard_normal(cp.shape)
    return template, target, cp, mu


CASES = [
    (dim, n, dense, name)
    for dim, n in ((2, 30), (3, 24))
    for dense in (True, False)
    for name in TABLEAUS
]


@pytest.mark.parametrize("dim, n_points, dense, integrator", CASES)
def test_adjoint_matches_autograd_and_finite_differences(dim, n_points, dense, integrator):
    template, target, cp, mu = make_problem(dim, n_points, dense, seed=dim * 10 + n_points)
    kernel = GaussianKernel(SIGMA, backend="numpy")

    def f(m):
        return registration_objective(
            kernel, template, target, cp, m, ALPHA, integrator, N_STEPS, with_gradient=False
        )[0]

    value, g, _, _ = registration_objective(
        kernel, template, target, cp, mu, ALPHA, integrator, N_STEPS
    )
    scheme = TABLEAUS[integrator]
    ref_value = ag_objective(mu, template, target, cp, scheme, dense)
    np.testing.assert_allclose(value, ref_value, rtol=1e-12)
    g_ag = grad(ag_objective)(mu, template, target, cp, scheme, dense)
    assert np.linalg.norm(g - g_ag) <= 1e-7 * np.linalg.norm(g_ag)

    # Central differences, coordinate-wise, step chosen for ~1e-10 truncation error.
    eps = 1e-5
    g_fd = np.zeros_like(mu)
    for i in range(mu.size):
        e = np.zeros(mu.size)
        e[i] = eps
        e = e.reshape(mu.shape)
        g_fd.flat[i] = (f(mu + e) - f(mu - e)) / (2 * eps)
    assert np.linalg.norm(g - g_fd) <= 1e-7 * np.linalg.norm(g)


def test_blockwise_gradient_equals_single_block():
    template, target, cp, mu = make_problem(3, 30, False, seed=5)
    full = GaussianKernel(SIGMA, backend="numpy")
    tiny = GaussianKernel(SIGMA, backend="numpy", block_size=7)
    out_full = registration_objective(full, template, target, cp, mu, ALPHA, "rk2", N_STEPS)
    out_tiny = registration_objective(tiny, template, target, cp, mu, ALPHA, "rk2", N_STEPS)
    np.testing.assert_allclose(out_tiny[0], out_full[0], rtol=1e-13)
    np.testing.assert_allclose(out_tiny[1], out_full[1], rtol=1e-11, atol=1e-13)


@pytest.mark.parametrize("dense", [True, False])
def test_compiled_backend_gradient_agrees(dense):
    template, target, cp, mu = make_problem(2, 30, dense, seed=9)
    ref = GaussianKernel(SIGMA, backend="numpy")
    fast = GaussianKernel(SIGMA, backend="numba")
    f_ref, g_ref, _, _ = registration_objective(ref, template, target, cp, mu, ALPHA, "rk4", 5)
    f_fast, g_fast, _, _ = registration_objective(fast, template, target, cp, mu, ALPHA, "rk4", 5)
    np.testing.assert_allclose(f_fast, f_ref, rtol=1e-12)
    assert np.linalg.norm(g_fast - g_ref) <= 1e-11 * np.linalg.norm(g_ref)


def ag_objective_c(cp, mu, template, target, scheme):
    """Objective as a function of the control points (template flowed as points)."""
    return ag_objective(mu, template, target, cp, scheme, False)


@pytest.mark.parametrize("dim, n_points", [(2, 30), (3, 24)])
@pytest.mark.parametrize("start", ["grid", "vertices"])
@pytest.mark.parametrize("integrator", list(TABLEAUS))
def test_control_point_gradient_matches_autograd_and_finite_differences(
    dim, n_points, start, integrator
):
    """d C / d c: adjoint state of c at t = 0 plus the regulariser's -2 alpha^2 dmu/dt(0)."""
    template, target, cp, mu = make_problem(dim, n_points, start == "vertices", seed=dim + 3)
    cp = cp.copy()  # distinct from the template: moving c does not move the shape
    kernel = GaussianKernel(SIGMA, backend="numpy")
    value, (g_c, g_mu), _, _ = registration_objective(
        kernel, template, target, cp, mu, ALPHA, integrator, N_STEPS, control_points_gradient=True
    )
    scheme = TABLEAUS[integrator]
    np.testing.assert_allclose(value, ag_objective_c(cp, mu, template, target, scheme), rtol=1e-12)
    g_ag = grad(ag_objective_c)(cp, mu, template, target, scheme)
    assert np.linalg.norm(g_c - g_ag) <= 1e-7 * np.linalg.norm(g_ag)
    g_mu_ag = grad(ag_objective_c, 1)(cp, mu, template, target, scheme)
    assert np.linalg.norm(g_mu - g_mu_ag) <= 1e-7 * np.linalg.norm(g_mu_ag)

    def f(c):
        return registration_objective(
            kernel, template, target, c, mu, ALPHA, integrator, N_STEPS, with_gradient=False
        )[0]

    eps = 1e-5
    g_fd = np.zeros_like(cp)
    for i in range(cp.size):
        e = np.zeros(cp.size)
        e[i] = eps
        e = e.reshape(cp.shape)
        g_fd.flat[i] = (f(cp + e) - f(cp - e)) / (2 * eps)
    assert np.linalg.norm(g_c - g_fd) <= 1e-7 * np.linalg.norm(g_c)
