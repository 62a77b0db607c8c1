"""SVF registration: exact gradient (autograd, central differences), recovery, warning."""

import autograd.numpy as anp
import numpy as np
import pytest
from autograd import grad

from manifolds.errors import ConvergenceWarning
from manifolds.lddmm.control_points import grid_control_points
from manifolds.lddmm.kernels import GaussianKernel, numba_available
from manifolds.lddmm.registration import register, registration_objective
from manifolds.lddmm.settings import RegistrationSettings
from manifolds.lddmm.stationary_flow import StationaryKernelFlow, kernel_flow
from manifolds.lddmm.svf_registration import register_svf, svf_objective
from manifolds.numerics.integrators import RK2, RK4, Euler
from tests.test_svf_flow import ag_flow

SIGMA = 0.6
SETTINGS = RegistrationSettings(sigma=SIGMA)
ALPHA = 0.3
N_STEPS = 4


def ag_objective(m, template, target, cp, scheme):
    reg = anp.sum(m * anp.dot(anp.exp(-anp.sum((cp[:, None] - cp[None]) ** 2, -1) / SIGMA**2), m))
    deformed = ag_flow(template, cp, m, scheme, N_STEPS)
    return anp.sum((target - deformed) ** 2) + ALPHA**2 * reg


def problem(dim, n_points, dense, seed):
    rng = np.random.default_rng(seed)
    template = rng.uniform(-1, 1, size=(n_points, dim))
    target = template + 0.2 * rng.standard_normal((n_points, dim))
    cp = template if dense else grid_control_points(template, SIGMA)
    return template, target, cp, 0.4 * rng.standard_normal(cp.shape)


def objective(*args):
    return registration_objective(*args, flow=StationaryKernelFlow)


def register_svf_(template, target, alpha, settings, **kw):
    return register(template, target, alpha, settings, flow=StationaryKernelFlow, **kw)


BACKENDS = ["numpy"] + (["numba"] if numba_available() else [])


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("dim, dense", [(2, True), (2, False), (3, False)])
@pytest.mark.parametrize("scheme", [Euler, RK2, RK4], ids=lambda s: s.name)
def test_gradient_matches_autograd_and_central_differences(scheme, dim, dense, backend):
    kernel = GaussianKernel(SIGMA, backend=backend)
    template, target, cp, m = problem(dim, 24, dense, seed=dim)
    value, g, _, _ = objective(kernel, template, target, cp, m, ALPHA, scheme, N_STEPS)
    np.testing.assert_allclose(value, ag_objective(m, template, target, cp, scheme), rtol=1e-12)
    ref = grad(ag_objective)(m, template, target, cp, scheme)
    assert np.linalg.norm(g - ref) <= 1e-7 * np.linalg.norm(ref)
    d = np.random.default_rng(5).standard_normal(m.shape)
    eps = 1e-5

    def f(mm):
        return objective(kernel, template, target, cp, mm, ALPHA, scheme, N_STEPS, False)[0]

    fd = (f(m + eps * d) - f(m - eps * d)) / (2 * eps)
    assert abs(fd - (g * d).sum()) <= 1e-7 * abs(fd)


@pytest.mark.parametrize("dense", [True, False])
def test_registration_recovers_the_field(dense):
    kernel = GaussianKernel(SIGMA)
    rng = np.random.default_rng(6)
    template = rng.uniform(-1, 1, (12, 2))
    cp = template if dense else grid_control_points(template, SIGMA)
    true = 0.2 * rng.standard_normal(cp.shape)
    target = kernel_flow(kernel, cp, true, template).points
    res = register_svf_(template, target, 1e-4, SETTINGS, control_points=cp)
    assert res.converged and res.rms_error < 1e-4
    np.testing.assert_allclose(res.residual, target - res.deformed)
    assert res.history[-1] <= res.history[0]
    if dense:  # dense control points: the field at the vertices is identifiable
        np.testing.assert_allclose(res.momenta, true, atol=1e-3)


def test_regularisation_trades_matching_for_norm():
    template, target, cp, _ = problem(2, 15, True, seed=7)
    loose = register_svf_(template, target, 1e-2, SETTINGS, control_points=cp)
    tight = register_svf_(template, target, 1.0, SETTINGS, control_points=cp)
    assert tight.rkhs_norm < loose.rkhs_norm
    assert tight.registration_error > loose.registration_error


def test_non_convergence_warns_and_flags():
    template, target, cp, _ = problem(2, 15, True, seed=8)
    with pytest.warns(ConvergenceWarning, match="SVF registration did not converge"):
        res = register_svf_(template, target, 1e-3, SETTINGS.replace(max_iter=1), control_points=cp)
    assert not res.converged and res.n_iter == 1


def test_the_svf_keeps_its_control_points():
    template, target, cp, m = problem(2, 10, True, seed=9)
    with pytest.raises(ValueError, match="optimize_control_points"):
        register_svf_(template, target, 1.0, SETTINGS.replace(optimize_control_points=True))
    with pytest.raises(ValueError, match="control_points_gradient"):
        registration_objective(
            GaussianKernel(SIGMA), template, target, cp, m, ALPHA,
            control_points_gradient=True, flow=StationaryKernelFlow,
        )  # fmt: skip


def test_the_former_svf_functions_warn_and_give_the_same_results():
    kernel = GaussianKernel(SIGMA)
    template, target, cp, m = problem(2, 12, True, seed=10)
    with pytest.warns(DeprecationWarning, match="svf_objective is deprecated"):
        old = svf_objective(kernel, template, target, cp, m, ALPHA)
    new = objective(kernel, template, target, cp, m, ALPHA)  # RK4, the SVF's default
    assert old[0] == new[0]
    np.testing.assert_array_equal(old[1], new[1])
    with pytest.warns(DeprecationWarning, match="register_svf is deprecated"):
        old = register_svf(template, target, 0.1, SETTINGS, control_points=cp)
    new = register_svf_(template, target, 0.1, SETTINGS, control_points=cp)
    np.testing.assert_array_equal(old.momenta, new.momenta)
