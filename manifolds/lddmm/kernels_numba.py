"""Compiled Gaussian-kernel sums (optional backend of :mod:`manifolds.lddmm.kernels`, needs numba).

The same four sums as the numpy reference, written as fused loops over pairs
of points: each kernel value is computed and consumed at once, so no
``k x n`` matrix is ever stored and memory stays linear in the number of
points. Coordinates are stored as ``(3, n)`` arrays (2-D inputs get a zero
third coordinate, which changes no distance, product or gradient) so that the
inner loops vectorise; the exponential is evaluated by a vectorisable
polynomial (:func:`manifolds.kernels.numba_primitives.gexp`, relative error below
``3e-14`` and exactly zero below ``exp(-40) ~ 4e-18``; the compiled primitives shared
with the surface data terms live in the kernel layer :mod:`manifolds.kernels`). Outer loops run in parallel over rows above a
size threshold; sums over columns that several rows write to go through one
buffer per chunk of rows. Below ``PARALLEL_MIN_PAIRS`` pairs (about a quarter of a
millisecond of work) the serial loop is used; batches of workers run with one kernel
thread each (:mod:`manifolds.kernels.threads`).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..kernels.numba_primitives import (
    JIT_FLAGS,
    PARALLEL_MIN_PAIRS,
    check_dim,
    from_soa,
    gexp,
    to_soa,
    use_parallel,
)
from .triangular_solve_numba import solve_lower

__all__ = [
    "convolve",
    "hamiltonian_rhs",
    "convolve_vjp",
    "hamiltonian_vjp",
    "gaussian",
    "gexp",
    "to_soa",
    "from_soa",
    "check_dim",
    "use_parallel",
    "JIT_FLAGS",
    "PARALLEL_MIN_PAIRS",
    "solve_lower",
    "LOOPS",
    "CVJP_CHUNKS",
]


@njit(**JIT_FLAGS)
def _gexp_array(x):  # pragma: no cover - compiled
    out = np.empty_like(x)
    for i in range(x.size):
        out[i] = gexp(x[i])
    return out


@njit(inline="always", **JIT_FLAGS)
def _conv_row(i, x, c, mom, inv_s2, out):  # pragma: no cover - compiled
    x0, x1, x2 = x[0, i], x[1, i], x[2, i]
    v0 = v1 = v2 = 0.0
    for j in range(c.shape[1]):
        d0, d1, d2 = x0 - c[0, j], x1 - c[1, j], x2 - c[2, j]
        k = gexp(-(d0 * d0 + d1 * d1 + d2 * d2) * inv_s2)
        v0 += k * mom[0, j]
        v1 += k * mom[1, j]
        v2 += k * mom[2, j]
    out[0, i], out[1, i], out[2, i] = v0, v1, v2


@njit(inline="always", **JIT_FLAGS)
def _rhs_row(i, c, mu, inv_s2, dc, dmu):  # pragma: no cover - compiled
    c0, c1, c2 = c[0, i], c[1, i], c[2, i]
    m0, m1, m2 = mu[0, i], mu[1, i], mu[2, i]
    v0 = v1 = v2 = 0.0
    f0 = f1 = f2 = 0.0
    for j in range(c.shape[1]):
        d0, d1, d2 = c0 - c[0, j], c1 - c[1, j], c2 - c[2, j]
        k = gexp(-(d0 * d0 + d1 * d1 + d2 * d2) * inv_s2)
        n0, n1, n2 = mu[0, j], mu[1, j], mu[2, j]
        v0 += k * n0
        v1 += k * n1
        v2 += k * n2
        w = k * (m0 * n0 + m1 * n1 + m2 * n2)
        f0 += w * d0
        f1 += w * d1
        f2 += w * d2
    s = 2.0 * inv_s2
    dc[0, i], dc[1, i], dc[2, i] = v0, v1, v2
    dmu[0, i], dmu[1, i], dmu[2, i] = s * f0, s * f1, s * f2


@njit(inline="always", **JIT_FLAGS)
def _hvjp_row(i, c, mu, a, b, inv_s2, g_c, g_mu):  # pragma: no cover - compiled
    s = 2.0 * inv_s2
    c0, c1, c2 = c[0, i], c[1, i], c[2, i]
    m0, m1, m2 = mu[0, i], mu[1, i], mu[2, i]
    a0, a1, a2 = a[0, i], a[1, i], a[2, i]
    b0, b1, b2 = b[0, i], b[1, i], b[2, i]
    gm0 = gm1 = gm2 = 0.0
    gc0 = gc1 = gc2 = 0.0
    for j in range(c.shape[1]):
        d0, d1, d2 = c0 - c[0, j], c1 - c[1, j], c2 - c[2, j]
        k = gexp(-(d0 * d0 + d1 * d1 + d2 * d2) * inv_s2)
        n0, n1, n2 = mu[0, j], mu[1, j], mu[2, j]
        aj0, aj1, aj2 = a[0, j], a[1, j], a[2, j]
        e0, e1, e2 = b0 - b[0, j], b1 - b[1, j], b2 - b[2, j]
        bij = e0 * d0 + e1 * d1 + e2 * d2
        kb = s * k * bij
        gm0 += k * aj0 + kb * n0
        gm1 += k * aj1 + kb * n1
        gm2 += k * aj2 + kb * n2
        w = k * (m0 * n0 + m1 * n1 + m2 * n2)
        am = a0 * n0 + a1 * n1 + a2 * n2 + m0 * aj0 + m1 * aj1 + m2 * aj2
        r = -k * am - s * w * bij
        gc0 += r * d0 + w * e0
        gc1 += r * d1 + w * e1
        gc2 += r * d2 + w * e2
    g_mu[0, i], g_mu[1, i], g_mu[2, i] = gm0, gm1, gm2
    g_c[0, i], g_c[1, i], g_c[2, i] = s * gc0, s * gc1, s * gc2


@njit(inline="always", **JIT_FLAGS)
def _cvjp_row(i, t, x, c, mom, cot, inv_s2, g_x, buf_c, buf_m):  # pragma: no cover
    s = 2.0 * inv_s2
    x0, x1, x2 = x[0, i], x[1, i], x[2, i]
    a0, a1, a2 = cot[0, i], cot[1, i], cot[2, i]
    gx0 = gx1 = gx2 = 0.0
    for j in range(c.shape[1]):
        d0, d1, d2 = x0 - c[0, j], x1 - c[1, j], x2 - c[2, j]
        k = gexp(-(d0 * d0 + d1 * d1 + d2 * d2) * inv_s2)
        buf_m[t, 0, j] += k * a0
        buf_m[t, 1, j] += k * a1
        buf_m[t, 2, j] += k * a2
        w = s * k * (a0 * mom[0, j] + a1 * mom[1, j] + a2 * mom[2, j])
        gx0 -= w * d0
        gx1 -= w * d1
        gx2 -= w * d2
        buf_c[t, 0, j] += w * d0
        buf_c[t, 1, j] += w * d1
        buf_c[t, 2, j] += w * d2
    g_x[0, i], g_x[1, i], g_x[2, i] = gx0, gx1, gx2


@njit(parallel=True, **JIT_FLAGS)
def _conv_par(x, c, mom, inv_s2, out):  # pragma: no cover - compiled
    for i in prange(x.shape[1]):
        _conv_row(i, x, c, mom, inv_s2, out)


@njit(**JIT_FLAGS)
def _conv_ser(x, c, mom, inv_s2, out):  # pragma: no cover - compiled
    for i in range(x.shape[1]):
        _conv_row(i, x, c, mom, inv_s2, out)


@njit(parallel=True, **JIT_FLAGS)
def _rhs_par(c, mu, inv_s2, dc, dmu):  # pragma: no cover - compiled
    for i in prange(c.shape[1]):
        _rhs_row(i, c, mu, inv_s2, dc, dmu)


@njit(**JIT_FLAGS)
def _rhs_ser(c, mu, inv_s2, dc, dmu):  # pragma: no cover - compiled
    for i in range(c.shape[1]):
        _rhs_row(i, c, mu, inv_s2, dc, dmu)


@njit(parallel=True, **JIT_FLAGS)
def _hvjp_par(c, mu, a, b, inv_s2, g_c, g_mu):  # pragma: no cover - compiled
    for i in prange(c.shape[1]):
        _hvjp_row(i, c, mu, a, b, inv_s2, g_c, g_mu)


@njit(**JIT_FLAGS)
def _hvjp_ser(c, mu, a, b, inv_s2, g_c, g_mu):  # pragma: no cover - compiled
    for i in range(c.shape[1]):
        _hvjp_row(i, c, mu, a, b, inv_s2, g_c, g_mu)


@njit(parallel=True, **JIT_FLAGS)
def _cvjp_par(x, c, mom, cot, inv_s2, g_x, buf_c, buf_m):  # pragma: no cover - compiled
    n, n_chunks = x.shape[1], buf_c.shape[0]
    for t in prange(n_chunks):
        for i in range(t, n, n_chunks):
            _cvjp_row(i, t, x, c, mom, cot, inv_s2, g_x, buf_c, buf_m)


@njit(**JIT_FLAGS)
def _cvjp_ser(x, c, mom, cot, inv_s2, g_x, buf_c, buf_m):  # pragma: no cover - compiled
    n, n_chunks = x.shape[1], buf_c.shape[0]
    for t in range(n_chunks):
        for i in range(t, n, n_chunks):
            _cvjp_row(i, t, x, c, mom, cot, inv_s2, g_x, buf_c, buf_m)


CVJP_CHUNKS = 8

#: The compiled loops on ``(3, n)`` arrays, ``(serial, parallel)`` for each sum (indexed by
#: :func:`use_parallel`): what :class:`~manifolds.lddmm.hamiltonian_system.CompiledHamiltonianSystem`
#: calls without converting layouts.
LOOPS = {
    "convolve": (_conv_ser, _conv_par),
    "hamiltonian_rhs": (_rhs_ser, _rhs_par),
    "hamiltonian_vjp": (_hvjp_ser, _hvjp_par),
    "convolve_vjp": (_cvjp_ser, _cvjp_par),
}


def gaussian(sq_dist: np.ndarray) -> np.ndarray:
    """The backend's ``exp(-sq_dist)`` for ``sq_dist >= 0`` (for tests)."""
    flat = -np.ascontiguousarray(sq_dist, dtype=np.float64).ravel()
    return _gexp_array(flat).reshape(np.shape(sq_dist))


def convolve(x, c, mom, inv_s2):
    """``sum_j K(x_i, c_j) mom_j``, shape ``(len(x), d)``."""
    check_dim(x, c, mom)
    out = np.empty((3, x.shape[0]))
    fn = _conv_par if use_parallel(x.shape[0] * c.shape[0]) else _conv_ser
    fn(to_soa(x), to_soa(c), to_soa(mom), float(inv_s2), out)
    return from_soa(out, mom.shape[1])


def hamiltonian_rhs(c, mu, inv_s2):
    """``(K mu, (2/sigma^2) sum_j (mu_i . mu_j) K_ij (c_i - c_j))``."""
    check_dim(c, mu)
    n, d = mu.shape
    dc, dmu = np.empty((3, n)), np.empty((3, n))
    fn = _rhs_par if use_parallel(n * n) else _rhs_ser
    fn(to_soa(c), to_soa(mu), float(inv_s2), dc, dmu)
    return from_soa(dc, d), from_soa(dmu, d)


def hamiltonian_vjp(c, mu, cot_c, cot_mu, inv_s2):
    """Gradients ``(g_c, g_mu)`` of ``<cot_c, K mu> + <cot_mu, dmu>``."""
    check_dim(c, mu, cot_c, cot_mu)
    n, d = mu.shape
    g_c, g_mu = np.empty((3, n)), np.empty((3, n))
    fn = _hvjp_par if use_parallel(n * n) else _hvjp_ser
    fn(to_soa(c), to_soa(mu), to_soa(cot_c), to_soa(cot_mu), float(inv_s2), g_c, g_mu)
    return from_soa(g_c, d), from_soa(g_mu, d)


def convolve_vjp(x, c, mom, cot, inv_s2):
    """Gradients ``(g_x, g_c, g_mom)`` of ``sum_i cot_i . sum_j K(x_i, c_j) mom_j``."""
    check_dim(x, c, mom, cot)
    d = mom.shape[1]
    par = use_parallel(x.shape[0] * c.shape[0])
    # A fixed chunking (not the thread count) keeps the summation order, hence
    # the result, identical whatever the number of threads.
    n_chunks = max(1, min(CVJP_CHUNKS, x.shape[0]))
    g_x = np.empty((3, x.shape[0]))
    buf_c = np.zeros((n_chunks, 3, c.shape[0]))
    buf_m = np.zeros((n_chunks, 3, c.shape[0]))
    fn = _cvjp_par if par else _cvjp_ser
    fn(to_soa(x), to_soa(c), to_soa(mom), to_soa(cot), float(inv_s2), g_x, buf_c, buf_m)
    return from_soa(g_x, d), from_soa(buf_c.sum(axis=0), d), from_soa(buf_m.sum(axis=0), d)
