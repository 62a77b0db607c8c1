"""The statistic maps of permuted data: the null distribution of :func:`~.permutation_glm.glm_test`.

For Freedman-Lane (and Manly) permutations the refit of the permuted data ``P W``
(``W = R_z``, the residuals of the reduced model, or ``Y``) depends only on the
projections ``[U_x, U_z]^T P W`` (:mod:`.permutation_glm`): with ``S = U_x^T P W`` and
``Z = U_z^T P W``, at every vertex the scatter ``H + E = W^T W - Z^T Z`` and ``H = S^T S``
are ``d x d`` matrices formed from a few numbers. A chunk of ``m`` permutations costs

- one gather of the rows of ``[U_x, U_z]^T`` in the order of each permutation
  (``(p, m, n)``, compiled, parallel over the permutations);
- one matrix product ``(p m, n) @ (n, d k)``, the only step whose cost grows with both
  the subjects and the vertices (BLAS, both cores);
- per permutation and vertex, closed-form ``d x d`` algebra (compiled, parallel): a
  Cholesky factorisation of ``H + E`` and the triangular solves of Pillai's trace,
  ``V = sum_r s_r^T (H + E)^{-1} s_r``, or the ``t`` / ``F`` of a scalar.

A direction ``u`` of the nuisance space that every permutation leaves in place
(``P^T u = u``: the intercept, or the indicator of an exchangeability block when the
design has it) projects every permuted ``W`` to the same ``u^T W`` (zero for the
residuals ``R_z``, which are orthogonal to the nuisance); such directions are taken out of
the product once and their constant part of ``Z^T Z`` folded into ``W^T W``. For the usual
design with an intercept this removes one of the ``p`` rows of every permutation's product.

The maps equal, to rounding, :func:`~.linear_model.fit_statistic` of the permuted data
(``tests/test_null_maps.py``); Draper-Stoneman permutations (the tested columns of the
design permuted) keep their own route.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .linear_model import contrast_bases, scatter_entries, statistic_of

__all__ = ["NullMaps", "KIND_CODES", "block_codes"]

#: The statistic computed by :func:`_maps_kernel`.
KIND_CODES = {"t": 0, "F": 1, "pillai": 2}
#: ``1 - cos`` of the angle below which a nuisance direction counts as invariant.
_INVARIANT_TOL = 1e-10


@njit(cache=True, parallel=True, nogil=True)
def _gather(basis_t, perm, out):  # pragma: no cover - compiled
    """``out[r, i, j] = basis_t[perm[i, j], r]`` for ``basis_t (n, p)``, ``perm (m, n)``."""
    n, p = basis_t.shape
    for i in prange(perm.shape[0]):
        for j in range(n):
            row = perm[i, j]
            for r in range(p):
                out[r, i, j] = basis_t[row, r]


@njit(cache=True, parallel=True, nogil=True)
def _maps_kernel(proj, q, base, floor, df_resid, kind, out):  # pragma: no cover - compiled
    """The statistic of every permutation and vertex from the projections.

    ``proj`` ``(p, m, k, d)``: rows ``r < q`` the tested projections ``s_r``, the others the
    nuisance ones ``z_r``; ``base`` ``(d, d, k)``: ``W^T W`` (lower triangle read); ``kind``:
    0 ``t``, 1 ``F``, 2 Pillai's trace. ``H + E = base - sum_r z_r z_r^T``; a vertex whose
    ``H + E`` has a pivot at most ``floor`` gets 0 (as :func:`~.linear_model.statistic_of`).
    """
    p, m, k, d = proj.shape
    for i in prange(m):
        chol = np.empty((d, d))
        solved = np.empty(d)
        for v in range(k):
            for a in range(d):
                for b in range(a + 1):
                    value = base[a, b, v]
                    for r in range(q, p):
                        value -= proj[r, i, v, a] * proj[r, i, v, b]
                    chol[a, b] = value
            if kind != 2:
                total = chol[0, 0]
                if not total > floor:
                    out[i, v] = 0.0
                    continue
                hyp = 0.0
                for r in range(q):
                    hyp += proj[r, i, v, 0] ** 2
                scale = max(total - hyp, 1e-300) / df_resid
                if kind == 0:
                    out[i, v] = proj[0, i, v, 0] / np.sqrt(scale)
                else:
                    out[i, v] = hyp / q / scale
                continue
            ok = True
            for b in range(d):
                pivot = chol[b, b]
                for c in range(b):
                    pivot -= chol[b, c] ** 2
                if not pivot > floor:
                    ok = False
                    break
                chol[b, b] = np.sqrt(pivot)
                for a in range(b + 1, d):
                    value = chol[a, b]
                    for c in range(b):
                        value -= chol[a, c] * chol[b, c]
                    chol[a, b] = value / chol[b, b]
            if not ok:
                out[i, v] = 0.0
                continue
            trace = 0.0
            for r in range(q):
                for a in range(d):
                    value = proj[r, i, v, a]
                    for c in range(a):
                        value -= chol[a, c] * solved[c]
                    solved[a] = value / chol[a, a]
                    trace += solved[a] ** 2
            out[i, v] = trace


def block_codes(blocks, n: int) -> np.ndarray:
    """The exchangeability block of each of the ``n`` subjects as codes ``0, 1, ...``."""
    labels = np.asarray(blocks)
    if labels.shape != (n,):
        raise ValueError(f"blocks: expected {n} labels (one per subject), got {labels.shape}")
    return np.unique(labels, return_inverse=True)[1].reshape(-1)


def invariant_directions(n: int, blocks=None) -> np.ndarray:
    """Orthonormal vectors ``(n, b)`` every permutation leaves in place: the normalised
    indicators of the exchangeability blocks (the constant vector without blocks)."""
    if blocks is None:
        return np.full((n, 1), 1.0 / np.sqrt(n))
    codes = block_codes(blocks, n)
    indicators = (codes[:, None] == np.arange(codes.max() + 1)).astype(np.float64)
    return indicators / np.sqrt(indicators.sum(axis=0))


def split_invariant(u_z: np.ndarray, invariant: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """An orthonormal basis of ``span(u_z)`` split into its part in ``span(invariant)`` and
    the rest: ``(fixed (n, a), moving (n, p_z - a))``."""
    if u_z.shape[1] == 0:
        return u_z, u_z
    left, cosines, _ = np.linalg.svd(u_z.T @ invariant, full_matrices=True)
    cosines = np.concatenate([cosines, np.zeros(u_z.shape[1] - cosines.size)])
    fixed = cosines > 1.0 - _INVARIANT_TOL
    rotated = u_z @ left
    return rotated[:, fixed], rotated[:, ~fixed]


class NullMaps:
    """The statistic maps of chunks of permutations for one model and one method.

    Parameters
    ----------
    y : ndarray, shape (n, k, d)
    x : ndarray, shape (n, p)
    c : ndarray, shape (q, p)
    method : {"freedman_lane", "manly", "draper_stoneman"}
    scalar : bool
        ``t`` / ``F`` (``d = 1``) rather than Pillai's trace.
    ridge : float
        Vectors only: relative shift of the diagonal of ``H + E``.
    blocks : array, shape (n,), optional
        The exchangeability blocks the permutations respect.
    """

    def __init__(self, y, x, c, method, scalar, ridge, blocks=None):
        n, k, d = y.shape
        self.q, self.d, self.k, self.scalar = c.shape[0], d, k, scalar
        self.df_resid, self.method = n - x.shape[1], method
        self.kind = ("t" if self.q == 1 else "F") if scalar else "pillai"
        u_z, u_x = contrast_bases(x, c)
        flat = y.reshape(n, k * d)  # a view: columns vertex-major
        w = u_z @ (u_z.T @ flat)
        w = np.subtract(flat, w, out=w)  # R_z, in place of the fit (one array of the data's size)
        total = np.einsum("nki,nkj->kij", w.reshape(n, k, d), w.reshape(n, k, d))
        self.entries, self.floor, shift = scatter_entries(total, 0.0 if scalar else ridge)
        self.u_z, self.u_x = u_z, u_x
        if method == "manly":
            ones = np.ones(n) / np.sqrt(n)
            if np.linalg.norm(ones - u_z @ (u_z.T @ ones)) < 1e-8:
                flat = flat - flat.mean(axis=0)  # the intercept is nuisance: no change
            w = flat
            wk = flat.reshape(n, k, d)
            gram = np.einsum("nki,nkj->kij", wk, wk)
            self.entries = [
                [gram[:, i, j] + (shift if i == j else 0.0) for j in range(d)] for i in range(d)
            ]
        self.w = w
        fixed, moving = split_invariant(u_z, invariant_directions(n, blocks))
        constant = (fixed.T @ w).reshape(-1, k, d)  # the same for every permutation
        self.base = np.empty((d, d, k))
        for i in range(d):
            for j in range(i + 1):
                self.base[i, j] = self.entries[i][j] - (constant[..., i] * constant[..., j]).sum(0)
        self.basis = np.vstack([u_x.T, moving.T])  # (p, n): tested rows first
        self.basis_t = np.ascontiguousarray(self.basis.T)
        self._buffers: dict[str, np.ndarray] = {}

    def bytes_per_permutation(self) -> int:
        """Memory of one permutation in a chunk: its gathered rows, projections and map."""
        rows, n = self.basis.shape
        return 8 * (rows * n + rows * self.d * self.k + n + 2 * self.k)

    def _buffer(self, name: str, size: int) -> np.ndarray:
        """A work array of ``size`` floats, reused from chunk to chunk (no fresh pages)."""
        buffer = self._buffers.get(name)
        if buffer is None or buffer.size < size:
            buffer = self._buffers[name] = np.empty(size)
        return buffer[:size]

    def maps(self, perm: np.ndarray) -> np.ndarray:
        """Statistic maps ``(m, k)`` of the permutations ``perm`` ``(m, n)``."""
        if self.method == "draper_stoneman":
            return self._draper_stoneman(perm)
        perm = np.ascontiguousarray(perm, dtype=np.int64)
        rows, n = self.basis.shape
        m, d, k = perm.shape[0], self.d, self.k
        gathered = self._buffer("gathered", rows * m * n).reshape(rows * m, n)
        _gather(self.basis_t, perm, gathered.reshape(rows, m, n))
        proj = self._buffer("proj", rows * m * k * d).reshape(rows * m, k * d)
        np.matmul(gathered, self.w, out=proj)
        proj = proj.reshape(rows, m, k, d)
        out = np.empty((m, k))
        _maps_kernel(proj, self.q, self.base, self.floor, float(self.df_resid),
                     KIND_CODES[self.kind], out)  # fmt: skip
        return out

    def _draper_stoneman(self, perm: np.ndarray) -> np.ndarray:
        """The tested part of the design permuted, ``Z`` kept: its own projections."""
        m, q, d, k = perm.shape[0], self.q, self.d, self.k
        moved = self.u_x[perm]  # (m, n, q)
        raw = (moved.transpose(0, 2, 1).reshape(m * q, -1) @ self.w).reshape(m, q, k, d)
        overlap = np.einsum("nz,mnq->mzq", self.u_z, moved)
        gram = np.eye(q) - np.einsum("mzq,mzr->mqr", overlap, overlap)
        inv_chol = np.linalg.inv(np.linalg.cholesky(gram))
        proj = np.einsum("mqr,mrkd->mqdk", inv_chol, raw)
        sx = [[proj[:, r, i] for i in range(d)] for r in range(q)]
        return statistic_of(sx, self.entries, self.df_resid, self.scalar, self.floor)
