"""Gaussian kernel sums for LDDMM landmarks (paper, Section 2.1).

``K(x, y) = exp(-|x - y|^2 / sigma^2)``. Every sum over a ``k x n`` kernel
matrix is evaluated by row blocks so that at most ``block_size`` matrix
entries (a few temporaries of that size) live in memory at any time; below
that size the sum is a single vectorised block. The four sums needed by
Hamiltonian shooting and its adjoint are

* :meth:`GaussianKernel.convolve` -- ``v(x_i) = sum_j K(x_i, c_j) mu_j``;
* :meth:`GaussianKernel.hamiltonian_rhs` -- ``(dc/dt, dmu/dt)`` of eq. (2);
* :meth:`GaussianKernel.convolve_vjp` and :meth:`GaussianKernel.hamiltonian_vjp`,
  their vector-Jacobian products (the building blocks of the adjoint pass);
* :meth:`GaussianKernel.convolve_jvp` and :meth:`GaussianKernel.hamiltonian_jvp`,
  their Jacobian-vector products (the tangent-linear pass).

A compiled backend (:mod:`manifolds.lddmm.kernels_numba`; ``numba`` is a dependency)
computes the same sums with fused loops and no ``k x n`` temporaries; the
numpy code here is the reference it is tested against.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ..errors import ManifoldError
from ..kernels.backends import numba_available, resolve_backend
from ..validation import check_float, check_int

__all__ = ["GaussianKernel", "numba_available"]

DEFAULT_BLOCK_SIZE = 2**21  # kernel-matrix entries per block (16 MB per temporary)


def _sqdist(x: np.ndarray, y: np.ndarray, x2: np.ndarray, y2: np.ndarray) -> np.ndarray:
    d = x2[:, None] + y2[None, :] - 2.0 * (x @ y.T)
    np.maximum(d, 0.0, out=d)
    return d


class GaussianKernel:
    """Gaussian kernel ``exp(-|x - y|^2 / sigma^2)`` with blockwise sums.

    Parameters
    ----------
    sigma : float
        Kernel width (same unit as the points).
    backend : {"auto", "numpy", "numba"}, default "auto"
        ``"auto"`` uses the compiled backend when ``numba`` imports (it is a
        dependency; the numpy backend remains as the reference and the fallback).
    block_size : int, optional
        Maximum number of kernel-matrix entries per block of the numpy backend.
    """

    def __init__(self, sigma: float, backend: str = "auto", block_size: int | None = None):
        sigma = check_float(sigma, "GaussianKernel: sigma", minimum=0.0, strict=True)
        self.sigma = sigma
        self.inv_s2 = 1.0 / sigma**2
        self.block_size = check_int(
            DEFAULT_BLOCK_SIZE if block_size is None else block_size,
            "GaussianKernel: block_size",
            minimum=1,
        )
        if backend not in ("auto", "numpy", "numba"):
            raise ManifoldError(
                f"GaussianKernel: backend must be 'auto', 'numpy' or 'numba', got {backend!r}"
            )
        if backend == "numba" and not numba_available():
            raise ImportError("GaussianKernel: backend='numba' needs the optional package numba")
        backend = resolve_backend(backend, "GaussianKernel: backend")  # the one "auto" rule
        self.backend = backend
        self._nb = None
        self._nb_jvp = None
        if backend == "numba":
            from . import kernels_numba, kernels_numba_jvp

            self._nb = kernels_numba
            self._nb_jvp = kernels_numba_jvp

    def __repr__(self) -> str:
        return f"GaussianKernel(sigma={self.sigma:g}, backend={self.backend!r})"

    def with_sigma(self, sigma: float) -> GaussianKernel:
        """A kernel of width ``sigma`` with this kernel's backend and block size."""
        return GaussianKernel(sigma, backend=self.backend, block_size=self.block_size)

    def solve_triangular(self, chol: np.ndarray, rhs: np.ndarray, transpose: bool = False):
        """``L^{-1} rhs`` (or ``L^{-T} rhs``) for a lower-triangular ``chol``.

        The compiled backend uses a serial loop (no BLAS threads inside the
        optimiser); the numpy backend calls :func:`scipy.linalg.solve_triangular`.
        """
        if self._nb is not None:
            return self._nb.solve_lower(chol, rhs, transpose)
        return scipy.linalg.solve_triangular(
            chol, rhs, lower=True, trans="T" if transpose else "N", check_finite=False
        )

    # ------------------------------------------------------------ helpers
    def _rows(self, n_cols: int) -> int:
        return max(1, self.block_size // max(n_cols, 1))

    def _kernel_block(self, x_rows, c, x2_rows, c2):
        """``K(x_rows, c)`` as a dense block (the numpy backend's unit of work)."""
        kb = _sqdist(x_rows, c, x2_rows, c2)
        kb *= -self.inv_s2
        return np.exp(kb, out=kb)

    def _blocks(self, n_rows: int, n_cols: int):
        step = self._rows(n_cols)
        for start in range(0, n_rows, step):
            yield slice(start, min(start + step, n_rows))

    # ------------------------------------------------------------ matrices
    def matrix(self, x: np.ndarray, y: np.ndarray | None = None) -> np.ndarray:
        """Dense kernel matrix ``K[i, j] = K(x_i, y_j)``, shape ``(len(x), len(y))``.

        Use it for small point sets only (e.g. control points); the sums below
        never build it.
        """
        x = np.asarray(x, dtype=float)
        y = x if y is None else np.asarray(y, dtype=float)
        out = _sqdist(x, y, (x * x).sum(1), (y * y).sum(1))
        out *= -self.inv_s2
        return np.exp(out, out=out)

    def solve(self, c: np.ndarray, rhs: np.ndarray, nugget: float = 0.0) -> np.ndarray:
        """Solve ``(K(c, c) + nugget I) X = rhs`` (e.g. velocities back to momenta).

        Parameters
        ----------
        c : array, shape ``(n, d)``
        rhs : array, shape ``(n, ...)``
        nugget : float, default 0
            Ridge added to the diagonal for badly conditioned kernels.
        """
        mat = self.matrix(c)
        if nugget:
            mat[np.diag_indices_from(mat)] += nugget
        try:
            factor = scipy.linalg.cho_factor(mat, lower=True, check_finite=False)
            return scipy.linalg.cho_solve(factor, rhs, check_finite=False)
        except np.linalg.LinAlgError:
            return scipy.linalg.lstsq(mat, rhs, check_finite=False)[0]

    def rkhs_inner(self, c: np.ndarray, u: np.ndarray, v: np.ndarray) -> float:
        """``<u, v>_H = sum_ij K(c_i, c_j) u_i . v_j`` (eq. 1)."""
        return float((np.asarray(u, dtype=float) * self.convolve(c, c, v)).sum())

    # ------------------------------------------------------------ forward sums
    def convolve(self, x: np.ndarray, c: np.ndarray, mom: np.ndarray) -> np.ndarray:
        """Velocity ``v(x_i) = sum_j K(x_i, c_j) mom_j``, shape ``(len(x), d)``."""
        if self._nb is not None:
            return self._nb.convolve(x, c, mom, self.inv_s2)
        out = np.empty((x.shape[0], mom.shape[1]))
        x2, c2 = (x * x).sum(1), (c * c).sum(1)
        for rows in self._blocks(x.shape[0], c.shape[0]):
            kb = self._kernel_block(x[rows], c, x2[rows], c2)
            out[rows] = kb @ mom
        return out

    def hamiltonian_rhs(self, c: np.ndarray, mu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Right-hand side of the Hamiltonian equations (eq. 2).

        Returns ``(dc, dmu)`` with ``dc_i = sum_j K_ij mu_j`` and
        ``dmu_i = (2/sigma^2) sum_j (mu_i . mu_j) K_ij (c_i - c_j)``, each ``(n, d)``.
        """
        if self._nb is not None:
            return self._nb.hamiltonian_rhs(c, mu, self.inv_s2)
        n = c.shape[0]
        dc = np.empty_like(mu)
        dmu = np.empty_like(mu)
        c2 = (c * c).sum(1)
        for rows in self._blocks(n, n):
            kb = self._kernel_block(c[rows], c, c2[rows], c2)
            dc[rows] = kb @ mu
            kb *= mu[rows] @ mu.T  # W = K o (mu mu^T)
            dmu[rows] = c[rows] * kb.sum(1)[:, None] - kb @ c
        dmu *= 2.0 * self.inv_s2
        return dc, dmu

    # ------------------------------------------------------------ adjoint sums
    def convolve_vjp(self, x, c, mom, cot):
        """Vector-Jacobian product of :meth:`convolve` with the cotangent ``cot``.

        Returns ``(g_x, g_c, g_mom)``, the gradients of ``sum_i cot_i . v(x_i)``
        with respect to ``x``, ``c`` and ``mom``.
        """
        if self._nb is not None:
            return self._nb.convolve_vjp(x, c, mom, cot, self.inv_s2)
        g_x = np.empty_like(x)
        g_c = np.zeros_like(c)
        g_mom = np.zeros_like(mom)
        w_col = np.zeros(c.shape[0])
        x2, c2 = (x * x).sum(1), (c * c).sum(1)
        for rows in self._blocks(x.shape[0], c.shape[0]):
            kb = self._kernel_block(x[rows], c, x2[rows], c2)
            g_mom += kb.T @ cot[rows]
            kb *= cot[rows] @ mom.T  # W_ij = K_ij (cot_i . mom_j)
            g_x[rows] = x[rows] * kb.sum(1)[:, None] - kb @ c
            g_c += kb.T @ x[rows]
            w_col += kb.sum(0)
        g_c -= c * w_col[:, None]
        scale = 2.0 * self.inv_s2
        return -scale * g_x, scale * g_c, g_mom

    def hamiltonian_vjp(self, c, mu, cot_c, cot_mu):
        """Vector-Jacobian product of :meth:`hamiltonian_rhs`.

        Returns ``(g_c, g_mu)``, the gradients of
        ``sum_i cot_c_i . dc_i + cot_mu_i . dmu_i`` with respect to ``c`` and ``mu``.
        With ``W = K o (mu mu^T)``, ``A_ij = K_ij (a_i . mu_j + mu_i . a_j)`` and
        ``B_ij = (b_i - b_j) . (c_i - c_j)`` (``a = cot_c``, ``b = cot_mu``)::

            g_mu = K a + (2/s^2) (K o B) mu
            g_c_i = (2/s^2) [ sum_j R_ij (c_i - c_j) + sum_j W_ij (b_i - b_j) ],
            R = -A - (2/s^2) W o B.
        """
        if self._nb is not None:
            return self._nb.hamiltonian_vjp(c, mu, cot_c, cot_mu, self.inv_s2)
        n = c.shape[0]
        s = 2.0 * self.inv_s2
        g_c = np.empty_like(c)
        g_mu = np.empty_like(mu)
        c2 = (c * c).sum(1)
        bc = (cot_mu * c).sum(1)
        for rows in self._blocks(n, n):
            cr, mr, ar, br = c[rows], mu[rows], cot_c[rows], cot_mu[rows]
            kb = self._kernel_block(cr, c, c2[rows], c2)
            bmat = bc[rows][:, None] + bc[None, :] - br @ c.T - cr @ cot_mu.T
            kbm = kb * bmat
            g_mu[rows] = kb @ cot_c + s * (kbm @ mu)
            w = kb * (mr @ mu.T)
            r = ar @ mu.T
            r += mr @ cot_c.T
            r *= kb
            r += s * (w * bmat)
            r *= -1.0
            g_c[rows] = cr * r.sum(1)[:, None] - r @ c + br * w.sum(1)[:, None] - w @ cot_mu
        g_c *= s
        return g_c, g_mu

    # ------------------------------------------------------------ tangent-linear sums
    def convolve_jvp(self, x, c, mom, dx, dc, dmom):
        """Jacobian-vector product of :meth:`convolve` along ``(dx, dc, dmom)``.

        ``dv_i = sum_j K_ij [dmom_j - (2/s^2) ((x_i - c_j) . (dx_i - dc_j)) mom_j]``,
        shape ``(len(x), d)``.
        """
        if self._nb_jvp is not None:
            return self._nb_jvp.convolve_jvp(x, c, mom, dx, dc, dmom, self.inv_s2)
        out = np.empty((x.shape[0], mom.shape[1]))
        x2, c2 = (x * x).sum(1), (c * c).sum(1)
        dxc = (dc * c).sum(1)
        for rows in self._blocks(x.shape[0], c.shape[0]):
            kb = self._kernel_block(x[rows], c, x2[rows], c2)
            # (x_i - c_j) . (dx_i - dc_j) = x_i.dx_i - x_i.dc_j - c_j.dx_i + c_j.dc_j
            xr, dxr = x[rows], dx[rows]
            de = (xr * dxr).sum(1)[:, None] - xr @ dc.T - dxr @ c.T + dxc[None, :]
            out[rows] = kb @ dmom - 2.0 * self.inv_s2 * ((kb * de) @ mom)
        return out

    def hamiltonian_jvp(self, c, mu, dc, dmu):
        """Jacobian-vector product of :meth:`hamiltonian_rhs` along ``(dc, dmu)``.

        Returns the tangents ``(d(dc/dt), d(dmu/dt))``, each ``(n, d)``. With
        ``D_ij = c_i - c_j``, ``E_ij = dc_i - dc_j``, ``dK_ij = -(2/s^2) K_ij D_ij . E_ij``::

            d(dc/dt)_i  = sum_j K_ij dmu_j + dK_ij mu_j,
            d(dmu/dt)_i = (2/s^2) sum_j [(dmu_i . mu_j + mu_i . dmu_j) K_ij + (mu_i . mu_j) dK_ij] D_ij
                                       + (mu_i . mu_j) K_ij E_ij.
        """
        if self._nb_jvp is not None:
            return self._nb_jvp.hamiltonian_jvp(c, mu, dc, dmu, self.inv_s2)
        n = c.shape[0]
        s = 2.0 * self.inv_s2
        out_c = np.empty_like(mu)
        out_mu = np.empty_like(mu)
        c2 = (c * c).sum(1)
        cdc = (c * dc).sum(1)
        for rows in self._blocks(n, n):
            cr, dcr, mr, dmr = c[rows], dc[rows], mu[rows], dmu[rows]
            kb = self._kernel_block(cr, c, c2[rows], c2)
            de = cdc[rows][:, None] - cr @ dc.T - dcr @ c.T + cdc[None, :]
            dk = -s * kb * de
            out_c[rows] = kb @ dmu + dk @ mu
            mm = mr @ mu.T
            g = (dmr @ mu.T + mr @ dmu.T) * kb + mm * dk
            h = mm * kb
            out_mu[rows] = s * (cr * g.sum(1)[:, None] - g @ c + dcr * h.sum(1)[:, None] - h @ dc)
        return out_c, out_mu
