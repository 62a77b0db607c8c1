"""Compiled Jacobian-vector products of the Gaussian-kernel sums (tangent-linear model).

The forward-mode counterparts of :func:`~manifolds.lddmm.kernels_numba.convolve`
and :func:`~manifolds.lddmm.kernels_numba.hamiltonian_rhs`, with the same
conventions: ``(3, n)`` coordinate arrays, the vectorisable exponential
:func:`~manifolds.kernels.numba_primitives.gexp`, fused row loops (every output row is
a reduction over the columns, so no buffer is shared between rows), serial below
``PARALLEL_MIN_PAIRS`` pairs. The numpy code of :mod:`manifolds.lddmm.kernels` is
the reference they are tested against.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..kernels.numba_primitives import JIT_FLAGS, check_dim, from_soa, gexp, to_soa, use_parallel

__all__ = ["convolve_jvp", "hamiltonian_jvp", "LOOPS"]


@njit(inline="always", **JIT_FLAGS)
def _cjvp_row(i, x, c, mom, dx, dc, dmom, inv_s2, out):  # pragma: no cover - compiled
    s = 2.0 * inv_s2
    x0, x1, x2 = x[0, i], x[1, i], x[2, i]
    e0, e1, e2 = dx[0, i], dx[1, i], dx[2, i]
    v0 = v1 = v2 = 0.0
    for j in range(c.shape[1]):
        d0, d1, d2 = x0 - c[0, j], x1 - c[1, j], x2 - c[2, j]
        k = gexp(-(d0 * d0 + d1 * d1 + d2 * d2) * inv_s2)
        de = d0 * (e0 - dc[0, j]) + d1 * (e1 - dc[1, j]) + d2 * (e2 - dc[2, j])
        w = s * k * de
        v0 += k * dmom[0, j] - w * mom[0, j]
        v1 += k * dmom[1, j] - w * mom[1, j]
        v2 += k * dmom[2, j] - w * mom[2, j]
    out[0, i], out[1, i], out[2, i] = v0, v1, v2


@njit(inline="always", **JIT_FLAGS)
def _hjvp_row(i, c, mu, dc, dmu, inv_s2, out_c, out_mu):  # pragma: no cover - compiled
    s = 2.0 * inv_s2
    c0, c1, c2 = c[0, i], c[1, i], c[2, i]
    m0, m1, m2 = mu[0, i], mu[1, i], mu[2, i]
    a0, a1, a2 = dc[0, i], dc[1, i], dc[2, i]
    b0, b1, b2 = dmu[0, i], dmu[1, i], dmu[2, i]
    v0 = v1 = v2 = 0.0
    f0 = f1 = f2 = 0.0
    for j in range(c.shape[1]):
        d0, d1, d2 = c0 - c[0, j], c1 - c[1, j], c2 - c[2, j]
        k = gexp(-(d0 * d0 + d1 * d1 + d2 * d2) * inv_s2)
        n0, n1, n2 = mu[0, j], mu[1, j], mu[2, j]
        e0, e1, e2 = a0 - dc[0, j], a1 - dc[1, j], a2 - dc[2, j]
        de = d0 * e0 + d1 * e1 + d2 * e2
        dk = -s * k * de
        v0 += k * dmu[0, j] + dk * n0
        v1 += k * dmu[1, j] + dk * n1
        v2 += k * dmu[2, j] + dk * n2
        mm = m0 * n0 + m1 * n1 + m2 * n2
        dmm = b0 * n0 + b1 * n1 + b2 * n2 + m0 * dmu[0, j] + m1 * dmu[1, j] + m2 * dmu[2, j]
        g = dmm * k + mm * dk
        h = mm * k
        f0 += g * d0 + h * e0
        f1 += g * d1 + h * e1
        f2 += g * d2 + h * e2
    out_c[0, i], out_c[1, i], out_c[2, i] = v0, v1, v2
    out_mu[0, i], out_mu[1, i], out_mu[2, i] = s * f0, s * f1, s * f2


@njit(parallel=True, **JIT_FLAGS)
def _cjvp_par(x, c, mom, dx, dc, dmom, inv_s2, out):  # pragma: no cover - compiled
    for i in prange(x.shape[1]):
        _cjvp_row(i, x, c, mom, dx, dc, dmom, inv_s2, out)


@njit(**JIT_FLAGS)
def _cjvp_ser(x, c, mom, dx, dc, dmom, inv_s2, out):  # pragma: no cover - compiled
    for i in range(x.shape[1]):
        _cjvp_row(i, x, c, mom, dx, dc, dmom, inv_s2, out)


@njit(parallel=True, **JIT_FLAGS)
def _hjvp_par(c, mu, dc, dmu, inv_s2, out_c, out_mu):  # pragma: no cover - compiled
    for i in prange(c.shape[1]):
        _hjvp_row(i, c, mu, dc, dmu, inv_s2, out_c, out_mu)


@njit(**JIT_FLAGS)
def _hjvp_ser(c, mu, dc, dmu, inv_s2, out_c, out_mu):  # pragma: no cover - compiled
    for i in range(c.shape[1]):
        _hjvp_row(i, c, mu, dc, dmu, inv_s2, out_c, out_mu)


#: ``(serial, parallel)`` loops on ``(3, n)`` arrays (see ``kernels_numba.LOOPS``).
LOOPS = {"convolve_jvp": (_cjvp_ser, _cjvp_par), "hamiltonian_jvp": (_hjvp_ser, _hjvp_par)}


def convolve_jvp(x, c, mom, dx, dc, dmom, inv_s2):
    """Tangent of ``v(x_i) = sum_j K(x_i, c_j) mom_j`` along ``(dx, dc, dmom)``."""
    check_dim(x, c, mom, dx, dc, dmom)
    out = np.empty((3, x.shape[0]))
    fn = _cjvp_par if use_parallel(x.shape[0] * c.shape[0]) else _cjvp_ser
    fn(to_soa(x), to_soa(c), to_soa(mom), to_soa(dx), to_soa(dc), to_soa(dmom), float(inv_s2), out)
    return from_soa(out, mom.shape[1])


def hamiltonian_jvp(c, mu, dc, dmu, inv_s2):
    """Tangent of the Hamiltonian right-hand side ``(K mu, dmu/dt)`` along ``(dc, dmu)``."""
    check_dim(c, mu, dc, dmu)
    n, d = mu.shape
    out_c, out_mu = np.empty((3, n)), np.empty((3, n))
    fn = _hjvp_par if use_parallel(n * n) else _hjvp_ser
    fn(to_soa(c), to_soa(mu), to_soa(dc), to_soa(dmu), float(inv_s2), out_c, out_mu)
    return from_soa(out_c, d), from_soa(out_mu, d)
