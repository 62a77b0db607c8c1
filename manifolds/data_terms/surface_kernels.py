"""Pairwise kernel sums of the surface data terms, with their gradients (numpy reference).

For two sets of triangles ``X`` (centres ``c_i``, normals ``n_i``) and ``Y``
(centres ``d_j``, normals ``m_j``) and the Gaussian ``k_ij = exp(-|c_i - d_j|^2 /
sigma_W^2)``:

* current: ``<X, Y> = sum_ij k_ij n_i . m_j``;
* varifold: ``<X, Y> = sum_ij k_ij a_i b_j (u_i . v_j)^2`` with areas ``a, b``
  and unit normals ``u, v``.

:func:`pair_sum` returns the value and the gradients with respect to the first
set's centres and normals (``n_i = a_i u_i``)::

    g_c_i = -(2 / sigma_W^2) sum_j k_ij phi_ij (c_i - d_j)
    g_n_i = sum_j k_ij m_j                                       (current)
    g_n_i = sum_j k_ij b_j [2 (u_i . v_j) v_j - (u_i . v_j)^2 u_i]   (varifold)

with ``phi_ij`` the summand without ``k_ij``. The varifold's normal gradient is
written with unit normals only, so it stays bounded (zero for a triangle whose
unit normal is zero, see :func:`~manifolds.data_terms.mesh_geometry.unit_normals`).

The numpy code evaluates the ``F_X x F_Y`` matrices by row blocks of at most
``block_size`` entries (a few temporaries of that size live at once), so memory
is bounded whatever the meshes' sizes. The compiled backend
(:mod:`.surface_kernels_numba`) computes the same sums in fused loops with no
``F_X x F_Y`` temporary; this code is the reference it is tested against.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["KINDS", "SurfaceFeatures", "pair_sum", "DEFAULT_BLOCK_SIZE"]

#: The surface representations: oriented (current) or not (varifold).
KINDS = ("current", "varifold")
#: Kernel-matrix entries per block of the numpy backend (16 MB per temporary).
DEFAULT_BLOCK_SIZE = 2**21


@dataclass(frozen=True)
class SurfaceFeatures:
    """A mesh as its triangles' centres ``(f, 3)``, areas ``(f,)`` and unit normals ``(f, 3)``.

    The area-weighted normal is ``areas[:, None] * units`` (exactly the normal
    for a triangle of non-zero area).
    """

    centres: np.ndarray
    areas: np.ndarray
    units: np.ndarray
    normals: np.ndarray


def _sqdist(x: np.ndarray, y: np.ndarray, y2: np.ndarray) -> np.ndarray:
    d = (x * x).sum(1)[:, None] + y2[None, :] - 2.0 * (x @ y.T)
    np.maximum(d, 0.0, out=d)
    return d


def _rows(n_rows: int, n_cols: int, block_size: int):
    step = max(1, block_size // max(n_cols, 1))
    for start in range(0, n_rows, step):
        yield slice(start, min(start + step, n_rows))


def _block_current(x: SurfaceFeatures, y: SurfaceFeatures, k: np.ndarray, rows: slice):
    """``(phi k, g_n)`` of a row block of the current."""
    phi_k = (x.normals[rows] @ y.normals.T) * k
    return phi_k, k @ y.normals


def _block_varifold(x: SurfaceFeatures, y: SurfaceFeatures, k: np.ndarray, rows: slice):
    """``(phi k, g_n)`` of a row block of the varifold."""
    r = x.units[rows] @ y.units.T  # u_i . v_j
    kbr = k * y.areas[None, :] * r
    s = (kbr * r).sum(1)  # sum_j k b (u.v)^2
    g_n = 2.0 * (kbr @ y.units) - s[:, None] * x.units[rows]
    kbr *= r
    kbr *= x.areas[rows, None]
    return kbr, g_n


_BLOCKS = {"current": _block_current, "varifold": _block_varifold}


def pair_sum_numpy(kind, x, y, inv_s2: float, block_size: int = DEFAULT_BLOCK_SIZE):
    """:func:`pair_sum` with numpy, by row blocks of at most ``block_size`` entries."""
    block = _BLOCKS[kind]
    n_x = x.centres.shape[0]
    g_c = np.empty((n_x, 3))
    g_n = np.empty((n_x, 3))
    value = 0.0
    y2 = (y.centres * y.centres).sum(1)
    for rows in _rows(n_x, y.centres.shape[0], block_size):
        k = _sqdist(x.centres[rows], y.centres, y2)
        k *= -inv_s2
        np.exp(k, out=k)
        phi_k, g_n[rows] = block(x, y, k, rows)
        value += float(phi_k.sum())
        g_c[rows] = x.centres[rows] * phi_k.sum(1)[:, None] - phi_k @ y.centres
    g_c *= -2.0 * inv_s2
    return value, g_c, g_n


def pair_sum(
    kind: str,
    x: SurfaceFeatures,
    y: SurfaceFeatures,
    inv_s2: float,
    backend: str = "numpy",
    block_size: int = DEFAULT_BLOCK_SIZE,
) -> tuple[float, np.ndarray, np.ndarray]:
    """``<X, Y>`` of ``kind`` and its gradients with respect to ``X``'s centres and normals.

    Parameters
    ----------
    kind : {"current", "varifold"}
    x, y : SurfaceFeatures
        ``F_X`` and ``F_Y`` triangles.
    inv_s2 : float
        ``1 / sigma_W^2``.
    backend : {"numpy", "numba"}
    block_size : int
        Kernel entries per block of the numpy backend.

    Returns
    -------
    value : float
    g_centres, g_normals : arrays, shape ``(F_X, 3)``
    """
    if backend == "numba":
        from . import surface_kernels_numba

        return surface_kernels_numba.pair_sum(kind, x, y, inv_s2)
    return pair_sum_numpy(kind, x, y, inv_s2, block_size)
