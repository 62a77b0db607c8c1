"""Compiled pairwise sums of the surface data terms (backend of :mod:`.surface_kernels`).

The same sums as the numpy reference, as fused loops over pairs of triangles:
each kernel value is computed and consumed at once, so no ``F_X x F_Y``
matrix is stored and memory stays linear in the number of triangles. The
layout and the exponential are the kernel layer's (:mod:`manifolds.kernels.numba_primitives`)
(coordinates as contiguous ``(3, n)`` arrays, a vectorisable polynomial
``exp``). Every row ``i`` of ``X`` writes only its own outputs (value, centre
and normal gradients), so rows run in parallel without buffers; the value is
summed over rows afterwards in a fixed order, so the result does not depend
on the number of threads. Below ``PARALLEL_MIN_PAIRS`` pairs the serial loop
runs.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from manifolds.kernels.numba_primitives import gexp, to_soa, use_parallel

__all__ = ["pair_sum"]

JIT_FLAGS = {"fastmath": True, "cache": True, "nogil": True}


@njit(inline="always", **JIT_FLAGS)
def _current_row(i, cx, nx, ax, cy, ny, ay, inv_s2, val, g_c, g_n):  # pragma: no cover
    c0, c1, c2 = cx[0, i], cx[1, i], cx[2, i]
    n0, n1, n2 = nx[0, i], nx[1, i], nx[2, i]
    v = gc0 = gc1 = gc2 = gn0 = gn1 = gn2 = 0.0
    for j in range(cy.shape[1]):
        d0, d1, d2 = c0 - cy[0, j], c1 - cy[1, j], c2 - cy[2, j]
        k = gexp(-(d0 * d0 + d1 * d1 + d2 * d2) * inv_s2)
        m0, m1, m2 = ny[0, j], ny[1, j], ny[2, j]
        kp = k * (n0 * m0 + n1 * m1 + n2 * m2)
        v += kp
        gn0 += k * m0
        gn1 += k * m1
        gn2 += k * m2
        gc0 += kp * d0
        gc1 += kp * d1
        gc2 += kp * d2
    s = -2.0 * inv_s2
    val[i] = v
    g_c[0, i], g_c[1, i], g_c[2, i] = s * gc0, s * gc1, s * gc2
    g_n[0, i], g_n[1, i], g_n[2, i] = gn0, gn1, gn2


@njit(inline="always", **JIT_FLAGS)
def _varifold_row(i, cx, ux, ax, cy, uy, ay, inv_s2, val, g_c, g_n):  # pragma: no cover
    c0, c1, c2 = cx[0, i], cx[1, i], cx[2, i]
    u0, u1, u2 = ux[0, i], ux[1, i], ux[2, i]
    s = gc0 = gc1 = gc2 = gn0 = gn1 = gn2 = 0.0
    for j in range(cy.shape[1]):
        d0, d1, d2 = c0 - cy[0, j], c1 - cy[1, j], c2 - cy[2, j]
        k = gexp(-(d0 * d0 + d1 * d1 + d2 * d2) * inv_s2)
        w0, w1, w2 = uy[0, j], uy[1, j], uy[2, j]
        r = u0 * w0 + u1 * w1 + u2 * w2
        kbr = k * ay[j] * r
        q = kbr * r
        s += q
        gn0 += kbr * w0
        gn1 += kbr * w1
        gn2 += kbr * w2
        gc0 += q * d0
        gc1 += q * d1
        gc2 += q * d2
    a = ax[i]
    val[i] = a * s
    f = -2.0 * inv_s2 * a
    g_c[0, i], g_c[1, i], g_c[2, i] = f * gc0, f * gc1, f * gc2
    g_n[0, i] = 2.0 * gn0 - s * u0
    g_n[1, i] = 2.0 * gn1 - s * u1
    g_n[2, i] = 2.0 * gn2 - s * u2


@njit(parallel=True, **JIT_FLAGS)
def _current_par(cx, nx, ax, cy, ny, ay, inv_s2, val, g_c, g_n):  # pragma: no cover
    for i in prange(cx.shape[1]):
        _current_row(i, cx, nx, ax, cy, ny, ay, inv_s2, val, g_c, g_n)


@njit(**JIT_FLAGS)
def _current_ser(cx, nx, ax, cy, ny, ay, inv_s2, val, g_c, g_n):  # pragma: no cover
    for i in range(cx.shape[1]):
        _current_row(i, cx, nx, ax, cy, ny, ay, inv_s2, val, g_c, g_n)


@njit(parallel=True, **JIT_FLAGS)
def _varifold_par(cx, ux, ax, cy, uy, ay, inv_s2, val, g_c, g_n):  # pragma: no cover
    for i in prange(cx.shape[1]):
        _varifold_row(i, cx, ux, ax, cy, uy, ay, inv_s2, val, g_c, g_n)


@njit(**JIT_FLAGS)
def _varifold_ser(cx, ux, ax, cy, uy, ay, inv_s2, val, g_c, g_n):  # pragma: no cover
    for i in range(cx.shape[1]):
        _varifold_row(i, cx, ux, ax, cy, uy, ay, inv_s2, val, g_c, g_n)


_LOOPS = {
    "current": (_current_ser, _current_par),
    "varifold": (_varifold_ser, _varifold_par),
}


def pair_sum(kind: str, x, y, inv_s2: float) -> tuple[float, np.ndarray, np.ndarray]:
    """Compiled :func:`manifolds.data_terms.surface_kernels.pair_sum`.

    Parameters
    ----------
    kind : {"current", "varifold"}
    x, y : SurfaceFeatures
    inv_s2 : float

    Returns
    -------
    value : float
    g_centres, g_normals : arrays, shape ``(F_X, 3)``
    """
    serial, parallel = _LOOPS[kind]
    n_x, n_y = x.centres.shape[0], y.centres.shape[0]
    direction = "normals" if kind == "current" else "units"
    val = np.empty(n_x)
    g_c, g_n = np.empty((3, n_x)), np.empty((3, n_x))
    loop = parallel if use_parallel(n_x * n_y) else serial
    loop(
        to_soa(x.centres), to_soa(getattr(x, direction)), np.ascontiguousarray(x.areas),
        to_soa(y.centres), to_soa(getattr(y, direction)), np.ascontiguousarray(y.areas),
        float(inv_s2), val, g_c, g_n,
    )  # fmt: skip
    return float(val.sum()), np.ascontiguousarray(g_c.T), np.ascontiguousarray(g_n.T)
