"""Gaussian kernel sums: closed forms, blockwise evaluation, compiled backend."""

import os
import subprocess
import sys

import numpy as np
import pytest

from manifolds.errors import ManifoldError
from manifolds.lddmm.kernels import GaussianKernel, numba_available

SIGMA = 0.7


def data(n=23, m=17, dim=3, seed=0):
    rng = np.random.default_rng(seed)
    return [rng.standard_normal(shape) for shape in [(n, dim), (m, dim), (m, dim), (n, dim)]]


def dense_reference(x, c, mom):
    diff = x[:, None, :] - c[None, :, :]
    k = np.exp(-(diff**2).sum(-1) / SIGMA**2)
    return k, k @ mom


def test_matrix_and_convolve_match_closed_form():
    x, c, mom, _ = data()
    kernel = GaussianKernel(SIGMA, backend="numpy")
    k, v = dense_reference(x, c, mom)
    np.testing.assert_allclose(kernel.matrix(x, c), k, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(kernel.convolve(x, c, mom), v, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(np.diag(kernel.matrix(c)), 1.0, atol=1e-14)


def test_hamiltonian_rhs_closed_form():
    _, c, mu, _ = data()
    kernel = GaussianKernel(SIGMA, backend="numpy")
    k, dc = dense_reference(c, c, mu)
    p = mu @ mu.T
    dmu = (2 / SIGMA**2) * ((p * k)[:, :, None] * (c[:, None, :] - c[None, :, :])).sum(1)
    out = kernel.hamiltonian_rhs(c, mu)
    np.testing.assert_allclose(out[0], dc, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(out[1], dmu, rtol=1e-12, atol=1e-14)


def all_sums(kernel, x, c, mom, cot):
    return [
        kernel.convolve(x, c, mom),
        *kernel.hamiltonian_rhs(c, mom),
        *kernel.convolve_vjp(x, c, mom, cot),
        *kernel.hamiltonian_vjp(c, mom, mom[::-1] * 0.5, c * 0.3),
    ]


@pytest.mark.parametrize("block_size", [1, 7, 50])
def test_blockwise_equals_single_block(block_size):
    x, c, mom, cot = data()
    full = all_sums(GaussianKernel(SIGMA, backend="numpy"), x, c, mom, cot)
    small = GaussianKernel(SIGMA, backend="numpy", block_size=block_size)
    assert small._rows(c.shape[0]) * c.shape[0] <= max(block_size, c.shape[0])
    for a, b in zip(small_sums := all_sums(small, x, c, mom, cot), full):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-13)
    assert len(small_sums) == 8


def test_vjps_match_finite_differences():
    x, c, mom, cot = data(n=9, m=6, dim=2, seed=3)
    kernel = GaussianKernel(SIGMA, backend="numpy")
    b = np.random.default_rng(4).standard_normal(c.shape)

    def conv_scalar(xx, cc, mm):
        return (cot * kernel.convolve(xx, cc, mm)).sum()

    def ham_scalar(cc, mm):
        dc, dmu = kernel.hamiltonian_rhs(cc, mm)
        return (mom[::-1] * dc).sum() + (b * dmu).sum()

    def fd(f, args, which, eps=1e-6):
        out = np.zeros_like(args[which])
        for i in range(out.size):
            plus = [a.copy() for a in args]
            minus = [a.copy() for a in args]
            plus[which].flat[i] += eps
            minus[which].flat[i] -= eps
            out.flat[i] = (f(*plus) - f(*minus)) / (2 * eps)
        return out

    grads = kernel.convolve_vjp(x, c, mom, cot)
    for which in range(3):
        np.testing.assert_allclose(grads[which], fd(conv_scalar, [x, c, mom], which), atol=1e-8)
    grads = kernel.hamiltonian_vjp(c, mom, mom[::-1], b)
    for which in range(2):
        np.testing.assert_allclose(grads[which], fd(ham_scalar, [c, mom], which), atol=1e-8)


def test_solve_and_rkhs_inner():
    _, c, u, _ = data(m=12, seed=5)
    kernel = GaussianKernel(SIGMA, backend="numpy")
    k = kernel.matrix(c)
    rhs = k @ u
    np.testing.assert_allclose(kernel.solve(c, rhs), u, rtol=1e-8, atol=1e-8)
    v = u[::-1].copy()
    np.testing.assert_allclose(kernel.rkhs_inner(c, u, v), np.sum(u * (k @ v)), rtol=1e-12)
    np.testing.assert_allclose(kernel.rkhs_inner(c, u, v), kernel.rkhs_inner(c, v, u), rtol=1e-12)
    assert kernel.rkhs_inner(c, u, u) > 0


def test_invalid_parameters_raise():
    with pytest.raises(ManifoldError, match="sigma"):
        GaussianKernel(-1.0)
    with pytest.raises(ManifoldError, match="sigma"):
        GaussianKernel(float("nan"))
    with pytest.raises(ManifoldError, match="backend"):
        GaussianKernel(1.0, backend="gpu")
    with pytest.raises(ManifoldError, match="block_size"):
        GaussianKernel(1.0, block_size=0)


@pytest.mark.parametrize("dim", [2, 3])
def test_compiled_backend_agrees_with_numpy(dim):
    from manifolds.lddmm import kernels_numba

    sq = np.linspace(0, 39.9, 2001)
    np.testing.assert_allclose(kernels_numba.gaussian(sq), np.exp(-sq), rtol=3e-14, atol=0)
    x, c, mom, cot = data(
        n=150, m=310, dim=dim, seed=dim
    )  # serial path (the parallel one is tested in test_registration.py)
    ref = all_sums(GaussianKernel(SIGMA, backend="numpy"), x, c, mom, cot)
    fast = all_sums(GaussianKernel(SIGMA, backend="numba"), x, c, mom, cot)
    for a, b in zip(fast, ref):
        assert a.shape == b.shape
        np.testing.assert_allclose(a, b, rtol=1e-11, atol=1e-11 * np.abs(b).max())
    x, c, mom, cot = data(n=5, m=4, dim=dim, seed=7)  # serial path
    ref = all_sums(GaussianKernel(SIGMA, backend="numpy"), x, c, mom, cot)
    fast = all_sums(GaussianKernel(SIGMA, backend="numba"), x, c, mom, cot)
    for a, b in zip(fast, ref):
        np.testing.assert_allclose(a, b, rtol=1e-11, atol=1e-11 * np.abs(b).max())


def test_compiled_backend_is_the_default():
    """numba is a dependency: the default kernel runs the compiled sums."""
    assert numba_available()
    assert GaussianKernel(SIGMA).backend == "numba"


def test_the_parallel_sums_equal_the_serial_ones_to_the_last_bit():
    """Above PARALLEL_MIN_PAIRS the compiled sums run on every thread numba has; the result
    does not depend on the number of threads (and agrees with numpy)."""
    from manifolds.kernels import kernel_threads
    from manifolds.kernels.numba_primitives import PARALLEL_MIN_PAIRS

    x, c, mom, cot = data(n=700, m=400, dim=3, seed=3)
    assert x.shape[0] * c.shape[0] >= PARALLEL_MIN_PAIRS and c.shape[0] ** 2 >= PARALLEL_MIN_PAIRS
    kernel = GaussianKernel(SIGMA, backend="numba")
    with kernel_threads(1):
        serial = all_sums(kernel, x, c, mom, cot)
    with kernel_threads(2):
        parallel = all_sums(kernel, x, c, mom, cot)
    for a, b in zip(serial, parallel):
        np.testing.assert_array_equal(a, b)
    ref = all_sums(GaussianKernel(SIGMA, backend="numpy"), x, c, mom, cot)
    for a, b in zip(parallel, ref):
        np.testing.assert_allclose(a, b, rtol=1e-11, atol=1e-11 * np.abs(b).max())


def test_workers_share_the_cores_and_a_lone_computation_takes_them_all():
    import numba

    from manifolds.kernels import kernel_threads, threads_per_worker

    assert threads_per_worker(1) is None and threads_per_worker(None) is None
    assert threads_per_worker(2, cores=2) == 1
    assert threads_per_worker(2, cores=8) == 4
    assert threads_per_worker(-1, cores=8) == 1
    assert threads_per_worker(16, cores=8) == 1
    before = numba.get_num_threads()
    with kernel_threads(1):
        assert numba.get_num_threads() == 1
    assert numba.get_num_threads() == before
    with kernel_threads(None):
        assert numba.get_num_threads() == before


@pytest.mark.skipif(not numba_available(), reason="the compiled loops need numba")
@pytest.mark.parametrize("user_value", [None, "5"])
def test_idle_openmp_threads_spin_briefly_unless_the_user_chose(user_value):
    """Set before numba starts OpenMP (bench_threads_under_load.py measures why)."""
    from manifolds.kernels.numba_primitives import GOMP_SPINCOUNT

    expected = GOMP_SPINCOUNT if user_value is None else user_value
    assert int(GOMP_SPINCOUNT) <= 10_000  # far below GNU OpenMP's 300,000
    env = {k: v for k, v in os.environ.items() if k != "GOMP_SPINCOUNT"}
    if user_value is not None:
        env["GOMP_SPINCOUNT"] = user_value
    code = "import os, manifolds.lddmm.kernels_numba; print(os.environ['GOMP_SPINCOUNT'])"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == expected


@pytest.mark.skipif(not numba_available(), reason="the compiled solve needs numba")
@pytest.mark.parametrize("n, m", [(1, 3), (9, 3), (13, 3), (9, 2), (6, 4)])
def test_compiled_triangular_solves_keep_the_textbook_order_bit_for_bit(n, m):
    """Blocked or not, each element sees its subtractions in the order of plain substitution."""
    from manifolds.lddmm.kernels_numba import solve_lower

    rng = np.random.default_rng(n * 10 + m)
    a = rng.normal(size=(n, n))
    chol = np.ascontiguousarray(np.linalg.cholesky(a @ a.T + n * np.eye(n)))
    rhs = rng.normal(size=(n, m))
    forward, backward = np.empty_like(rhs), np.empty_like(rhs)
    for i in range(n):  # L X = B
        for r in range(m):
            acc = rhs[i, r]
            for j in range(i):
                acc -= chol[i, j] * forward[j, r]
            forward[i, r] = acc / chol[i, i]
    for i in range(n - 1, -1, -1):  # L^T X = B
        for r in range(m):
            acc = rhs[i, r]
            for j in range(n - 1, i, -1):
                acc -= chol[j, i] * backward[j, r]
            backward[i, r] = acc / chol[i, i]
    np.testing.assert_array_equal(solve_lower(chol, rhs), forward)
    np.testing.assert_array_equal(solve_lower(chol, rhs, transpose=True), backward)
