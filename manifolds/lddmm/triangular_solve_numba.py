"""Triangular solves of the registration's preconditioner (compiled, single-threaded).

``L X = B`` and ``L^T X = B`` with the Cholesky factor ``L`` of the preconditioner
(:mod:`manifolds.lddmm.preconditioner`), by substitution in a fixed order: unlike a
threaded BLAS ``trsm``, the loops neither compete with the kernel threads nor depend on
the thread count, and every element sees its subtractions in the same order, so the
results are bitwise the same however the loops are arranged. The forward substitution
and the back substitution of three right-hand sides (3-D momenta) run four rows at a
time (twelve independent accumulators, or one pass over the rows below a block); the
others go row by row.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["solve_lower"]


@njit(cache=True, nogil=True)
def _solve_lower(chol, rhs, transpose, out):  # pragma: no cover - compiled
    n, m = rhs.shape
    for i in range(n):
        for r in range(m):
            out[i, r] = rhs[i, r]
    if not transpose and m == 3:
        _forward_rows3(chol, out)
    elif not transpose:  # L X = B, rows of L in order
        for i in range(n):
            for j in range(i):
                lij = chol[i, j]
                for r in range(m):
                    out[i, r] -= lij * out[j, r]
            for r in range(m):
                out[i, r] /= chol[i, i]
    elif m == 3:
        _backward_rows3(chol, out)
    else:  # L^T X = B, column-oriented so that rows of L are read contiguously
        for i in range(n - 1, -1, -1):
            for r in range(m):
                out[i, r] /= chol[i, i]
            for j in range(i):
                lij = chol[i, j]
                for r in range(m):
                    out[j, r] -= lij * out[i, r]


@njit(cache=True, nogil=True)
def _forward_rows3(chol, out):  # pragma: no cover - compiled
    """``L X = B`` in place for 3 columns: four rows at a time, the same order per element."""
    n = out.shape[0]
    acc = np.empty((4, 3))
    i0 = 0
    while i0 + 4 <= n:
        a00, a01, a02 = out[i0, 0], out[i0, 1], out[i0, 2]
        a10, a11, a12 = out[i0 + 1, 0], out[i0 + 1, 1], out[i0 + 1, 2]
        a20, a21, a22 = out[i0 + 2, 0], out[i0 + 2, 1], out[i0 + 2, 2]
        a30, a31, a32 = out[i0 + 3, 0], out[i0 + 3, 1], out[i0 + 3, 2]
        for j in range(i0):  # the rows solved before the block
            o0, o1, o2 = out[j, 0], out[j, 1], out[j, 2]
            l0, l1, l2, l3 = chol[i0, j], chol[i0 + 1, j], chol[i0 + 2, j], chol[i0 + 3, j]
            a00 -= l0 * o0
            a01 -= l0 * o1
            a02 -= l0 * o2
            a10 -= l1 * o0
            a11 -= l1 * o1
            a12 -= l1 * o2
            a20 -= l2 * o0
            a21 -= l2 * o1
            a22 -= l2 * o2
            a30 -= l3 * o0
            a31 -= l3 * o1
            a32 -= l3 * o2
        acc[0, 0], acc[0, 1], acc[0, 2] = a00, a01, a02
        acc[1, 0], acc[1, 1], acc[1, 2] = a10, a11, a12
        acc[2, 0], acc[2, 1], acc[2, 2] = a20, a21, a22
        acc[3, 0], acc[3, 1], acc[3, 2] = a30, a31, a32
        for b in range(4):  # the block's own triangle
            i = i0 + b
            for j in range(i0, i):
                lij = chol[i, j]
                for r in range(3):
                    acc[b, r] -= lij * out[j, r]
            for r in range(3):
                out[i, r] = acc[b, r] / chol[i, i]
        i0 += 4
    for i in range(i0, n):  # the last rows
        for j in range(i):
            lij = chol[i, j]
            for r in range(3):
                out[i, r] -= lij * out[j, r]
        for r in range(3):
            out[i, r] /= chol[i, i]


@njit(cache=True, nogil=True)
def _backward_rows3(chol, out):  # pragma: no cover - compiled
    """``L^T X = B`` in place for 3 columns: four rows of ``L`` at a time, from the last,
    in the same order per element (for each row ``j``, the rows ``i > j`` from the last)."""
    top = out.shape[0]  # rows >= top are solved
    while top >= 4:
        i0 = top - 4
        for i in range(top - 1, i0 - 1, -1):  # the block's own triangle
            d = chol[i, i]
            out[i, 0] /= d
            out[i, 1] /= d
            out[i, 2] /= d
            for j in range(i0, i):
                lij = chol[i, j]
                out[j, 0] -= lij * out[i, 0]
                out[j, 1] -= lij * out[i, 1]
                out[j, 2] -= lij * out[i, 2]
        x30, x31, x32 = out[i0 + 3, 0], out[i0 + 3, 1], out[i0 + 3, 2]
        x20, x21, x22 = out[i0 + 2, 0], out[i0 + 2, 1], out[i0 + 2, 2]
        x10, x11, x12 = out[i0 + 1, 0], out[i0 + 1, 1], out[i0 + 1, 2]
        x00, x01, x02 = out[i0, 0], out[i0, 1], out[i0, 2]
        for j in range(i0):  # the rows below the block, the block's rows from the last
            l3, l2, l1, l0 = chol[i0 + 3, j], chol[i0 + 2, j], chol[i0 + 1, j], chol[i0, j]
            out[j, 0] = out[j, 0] - l3 * x30 - l2 * x20 - l1 * x10 - l0 * x00
            out[j, 1] = out[j, 1] - l3 * x31 - l2 * x21 - l1 * x11 - l0 * x01
            out[j, 2] = out[j, 2] - l3 * x32 - l2 * x22 - l1 * x12 - l0 * x02
        top = i0
    for i in range(top - 1, -1, -1):  # the first rows
        for r in range(3):
            out[i, r] /= chol[i, i]
        for j in range(i):
            lij = chol[i, j]
            for r in range(3):
                out[j, r] -= lij * out[i, r]


def solve_lower(chol: np.ndarray, rhs: np.ndarray, transpose: bool = False) -> np.ndarray:
    """Solve ``L X = B`` (or ``L^T X = B``) with a lower-triangular ``L``, single-threaded.

    A serial loop with a fixed summation order: unlike a threaded BLAS ``trsm``
    it neither competes with the kernel threads nor depends on the thread count.

    Parameters
    ----------
    chol : array, shape ``(n, n)``, C-contiguous lower triangle (upper part ignored)
    rhs : array, shape ``(n, m)``
    transpose : bool

    Returns
    -------
    array, shape ``(n, m)``
    """
    chol = np.ascontiguousarray(chol, dtype=np.float64)
    rhs = np.ascontiguousarray(rhs, dtype=np.float64)
    if chol.ndim != 2 or chol.shape[0] != chol.shape[1] or rhs.shape[0] != chol.shape[0]:
        raise ValueError(f"solve_lower: shapes {chol.shape} and {rhs.shape} do not match")
    out = np.empty_like(rhs)
    _solve_lower(chol, rhs, bool(transpose), out)
    return out
