"""The tangent-linear (forward-mode) passes of the flows are exact.

Kernel Jacobian-vector products, the LDDMM shooting's and the stationary flow's
tangent-linear models are compared with central finite differences and with
autograd's Jacobian of independent implementations of the same discrete schemes,
to 1e-7 relative; the compiled kernels with the numpy reference; and the
tangent-linear and adjoint passes satisfy the dot-product test
``<w, J v> = <J^T w, v>`` to round-off.
"""

import autograd.numpy as anp
import numpy as np
import pytest
from autograd import jacobian

from manifolds.lddmm.hamiltonian_shooting import shoot, shooting_jvp, shooting_vjp
from manifolds.lddmm.kernels import GaussianKernel, numba_available
from manifolds.lddmm.stationary_flow import kernel_flow, kernel_flow_jvp, kernel_flow_vjp
from manifolds.numerics.integrators import RK2, RK4, Euler
from tests.test_lddmm_gradient import SIGMA, ag_shoot
from tests.test_svf_flow import ag_flow

SCHEMES = [Euler, RK2, RK4]
N_STEPS = 4


def rel(a, b):
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / np.abs(np.asarray(b)).max())


def problem(seed, dim=3, n=9, k=14):
    rng = np.random.default_rng(seed)
    c = rng.uniform(-1, 1, (n, dim))
    x = rng.uniform(-1, 1, (k, dim))
    mu = 0.5 * rng.standard_normal((n, dim))
    tangents = [rng.standard_normal(a.shape) for a in (c, mu, x)]
    return c, mu, x, tangents


@pytest.mark.parametrize("backend", ["numpy", "numba"])
@pytest.mark.parametrize("dim", [2, 3])
def test_kernel_jvps_match_central_differences(backend, dim):
    if backend == "numba" and not numba_available():
        pytest.skip("numba not installed")
    kernel = GaussianKernel(SIGMA, backend=backend)
    c, mu, x, (dc, dmu, dx) = problem(0, dim)
    eps = 1e-6
    fd = (
        kernel.convolve(x + eps * dx, c + eps * dc, mu + eps * dmu)
        - kernel.convolve(x - eps * dx, c - eps * dc, mu - eps * dmu)
    ) / (2 * eps)
    # the compiled exponential is a polynomial with ~3e-14 relative error: FD noise ~1e-8
    tol = 1e-7 if backend == "numpy" else 1e-6
    assert rel(kernel.convolve_jvp(x, c, mu, dx, dc, dmu), fd) <= tol
    plus = kernel.hamiltonian_rhs(c + eps * dc, mu + eps * dmu)
    minus = kernel.hamiltonian_rhs(c - eps * dc, mu - eps * dmu)
    for got, p, m in zip(kernel.hamiltonian_jvp(c, mu, dc, dmu), plus, minus):
        assert rel(got, (p - m) / (2 * eps)) <= tol


@pytest.mark.skipif(not numba_available(), reason="numba not installed")
def test_compiled_kernel_jvps_match_numpy():
    c, mu, x, (dc, dmu, dx) = problem(1, 3, n=40, k=60)
    ref, fast = GaussianKernel(SIGMA, backend="numpy"), GaussianKernel(SIGMA, backend="numba")
    assert (
        rel(fast.convolve_jvp(x, c, mu, dx, dc, dmu), ref.convolve_jvp(x, c, mu, dx, dc, dmu))
        < 1e-11
    )
    for a, b in zip(fast.hamiltonian_jvp(c, mu, dc, dmu), ref.hamiltonian_jvp(c, mu, dc, dmu)):
        assert rel(a, b) < 1e-11


def ag_final_state(flat, shapes, scheme):
    """Final state ``(c, mu, x)`` of the initial state ``flat``, flattened, in autograd."""
    sizes = np.cumsum([int(np.prod(s)) for s in shapes])[:-1]
    parts = [anp.reshape(p, s) for p, s in zip(anp.split(flat, sizes), shapes)]
    return anp.concatenate([anp.ravel(y) for y in ag_shoot(parts, scheme, N_STEPS)])


@pytest.mark.parametrize("scheme", SCHEMES, ids=lambda s: s.name)
def test_shooting_jvp_matches_autograd_and_central_differences(scheme):
    kernel = GaussianKernel(SIGMA, backend="numpy")
    c, mu, x, (dc, dmu, dx) = problem(2)
    res = shoot(kernel, c, mu, scheme, N_STEPS, points=x, keep_stages=True)
    got = np.concatenate([t.ravel() for t in shooting_jvp(kernel, res, dc, dmu, dx)])
    flat = np.concatenate([c.ravel(), mu.ravel(), x.ravel()])
    direction = np.concatenate([dc.ravel(), dmu.ravel(), dx.ravel()])
    shapes = [c.shape, mu.shape, x.shape]
    ag = jacobian(lambda f: ag_final_state(f, shapes, scheme))(flat) @ direction
    assert rel(got, ag) <= 1e-10

    def final(f):
        cc, mm, xx = np.split(f, np.cumsum([c.size, mu.size]))
        r = shoot(kernel, cc.reshape(c.shape), mm.reshape(mu.shape), scheme, N_STEPS,
                  points=xx.reshape(x.shape))  # fmt: skip
        return np.concatenate([r.control_points.ravel(), r.momenta.ravel(), r.points.ravel()])

    eps = 1e-6
    fd = (final(flat + eps * direction) - final(flat - eps * direction)) / (2 * eps)
    assert rel(got, fd) <= 1e-7


@pytest.mark.parametrize("scheme", SCHEMES, ids=lambda s: s.name)
@pytest.mark.parametrize("backend", ["numpy", "numba"])
def test_shooting_jvp_and_vjp_pass_the_dot_product_test(scheme, backend):
    if backend == "numba" and not numba_available():
        pytest.skip("numba not installed")
    kernel = GaussianKernel(SIGMA, backend=backend)
    c, mu, x, (dc, dmu, dx) = problem(3)
    rng = np.random.default_rng(4)
    res = shoot(kernel, c, mu, scheme, N_STEPS, points=x, keep_stages=True)
    w = [rng.standard_normal(a.shape) for a in (c, mu, x)]
    jv = shooting_jvp(kernel, res, dc, dmu, dx)
    jtw = shooting_vjp(kernel, res, *w)
    lhs = sum(float((a * b).sum()) for a, b in zip(w, jv))
    rhs = sum(float((a * b).sum()) for a, b in zip(jtw, (dc, dmu, dx)))
    assert abs(lhs - rhs) <= 1e-12 * max(abs(lhs), 1.0)


def test_shooting_jvp_without_points_and_with_zero_tangent():
    kernel = GaussianKernel(SIGMA, backend="numpy")
    c, mu, _, (dc, dmu, _) = problem(5)
    res = shoot(kernel, c, mu, "rk2", N_STEPS, keep_stages=True)
    t_c, t_mu, t_x = shooting_jvp(kernel, res)
    assert t_x is None and not t_c.any() and not t_mu.any()
    with pytest.raises(ValueError, match="keep_stages"):
        shooting_jvp(kernel, shoot(kernel, c, mu, "rk2", N_STEPS), dc, dmu)


@pytest.mark.parametrize("scheme", SCHEMES, ids=lambda s: s.name)
def test_stationary_flow_jvp_matches_autograd_central_differences_and_adjoint(scheme):
    kernel = GaussianKernel(SIGMA, backend="numpy")
    c, m, x, (dc, dm, dx) = problem(6)
    res = kernel_flow(kernel, c, m, x, scheme, N_STEPS, keep_stages=True)
    got = kernel_flow_jvp(kernel, c, m, res, dm, dc, dx)

    def ag(f):
        cc, mm, xx = (
            anp.reshape(p, s)
            for p, s in zip(anp.split(f, np.cumsum([c.size, m.size])), (c.shape, m.shape, x.shape))
        )
        return anp.ravel(ag_flow(xx, cc, mm, scheme, N_STEPS))

    flat = np.concatenate([c.ravel(), m.ravel(), x.ravel()])
    direction = np.concatenate([dc.ravel(), dm.ravel(), dx.ravel()])
    assert rel(got.ravel(), jacobian(ag)(flat) @ direction) <= 1e-10
    eps = 1e-6
    fd = (
        kernel_flow(kernel, c + eps * dc, m + eps * dm, x + eps * dx, scheme, N_STEPS).points
        - kernel_flow(kernel, c - eps * dc, m - eps * dm, x - eps * dx, scheme, N_STEPS).points
    ) / (2 * eps)
    assert rel(got, fd) <= 1e-7
    w = np.random.default_rng(7).standard_normal(x.shape)
    g_x, g_m, g_c = kernel_flow_vjp(kernel, c, m, res, w)
    lhs = float((w * got).sum())
    rhs = float((g_x * dx).sum() + (g_m * dm).sum() + (g_c * dc).sum())
    assert abs(lhs - rhs) <= 1e-12 * max(abs(lhs), 1.0)
