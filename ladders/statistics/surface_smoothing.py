r"""Heat-kernel smoothing of per-vertex data on a triangle mesh, by its full width at half maximum.

Vertex-wise surface analyses smooth each subject's map before the tests
(FreeSurfer's ``mri_glmfit --fwhm``, SurfStat's ``SurfSmooth``): measurement
noise that varies from vertex to vertex averages out, while an effect that spans
several centimetres of the wall stays. The smoothing here is heat diffusion on the
surface (Chung et al., NeuroImage 25:1256-1265, 2005): the data ``f`` are the
initial temperature, and the smoothed map is the temperature after a time ``t``,

.. math::

    M \frac{du}{dt} = L u, \quad u(0) = f, \qquad u(t) = e^{t M^{-1} L} f,

with ``L`` the cotangent Laplacian and ``M`` the lumped (Voronoi) mass matrix of
the mesh (libigl's ``cotmatrix`` and ``massmatrix``). The exponential is exact, not
a fixed number of implicit steps: on meshes of at most ``dense_max`` vertices (an
atlas) it is formed once from the eigendecomposition of the symmetric
``M^{-1/2} L M^{-1/2} = U diag(w) U^T``,
``e^{t M^{-1} L} = M^{-1/2} U diag(e^{t w}) U^T M^{1/2}``, and each map costs one
matrix product; on larger meshes it is applied by SciPy's ``expm_multiply``
(Al-Mohy and Higham's truncated Taylor series, to double precision).
``benchmarks/bench_surface_smoothing.py`` times both. On a plane the heat
kernel at time ``t`` is the Gaussian of variance ``2 t`` per axis, so a requested
full width at half maximum gives

.. math::

    t = \frac{\sigma^2}{2} = \frac{\mathrm{FWHM}^2}{16 \ln 2}.

Properties (``tests/test_surface_smoothing.py``): constants are kept, the
area-weighted sum ``1^T M f`` is kept (no data leave the surface, across a
boundary included: the cotangent Laplacian has natural, no-flux, boundary
conditions), a spherical harmonic of degree ``l`` on a sphere of radius ``R`` is
multiplied by ``exp(-t l (l + 1) / R^2)``, and a spike on a fine plane spreads to
the requested width.

A vertex mask restricts the smoothing to the surface made of the triangles whose
three vertices are in the mask (e.g. the vertices where a rotation about the long
axis is defined); the vertices outside it keep their values.
"""

from __future__ import annotations

import igl
import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import expm_multiply

from manifolds.validation import check_int

__all__ = ["SurfaceSmoother", "fwhm_to_time", "smooth_surface_data"]


def fwhm_to_time(fwhm: float) -> float:
    """Diffusion time ``t`` (length squared) of the heat kernel of full width ``fwhm``."""
    return float(fwhm) ** 2 / (16.0 * np.log(2.0))


def _check_mesh(vertices, faces):
    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"vertices: expected shape (k, 3), got {v.shape}")
    if not np.isfinite(v).all():
        raise ValueError("vertices: contain NaN or infinite coordinates")
    if f.ndim != 2 or f.shape[1] != 3 or not np.issubdtype(f.dtype, np.integer):
        raise ValueError(f"faces: expected integer shape (m, 3), got {f.dtype} {f.shape}")
    if f.size and (f.min() < 0 or f.max() >= len(v)):
        raise ValueError(f"faces: indices must lie in [0, {len(v)}), got [{f.min()}, {f.max()}]")
    return v, f.astype(np.int64)


class SurfaceSmoother:
    """The heat-kernel smoothing of one mesh, built once and applied to many maps.

    Parameters
    ----------
    vertices : array, shape (k, 3)
    faces : array of int, shape (m, 3)
    fwhm : float
        Full width at half maximum of the kernel, in the vertices' unit (> 0).
    mask : array of bool, shape (k,), optional
        Smooth on the triangles whose three vertices are in the mask; the other
        vertices are left as they are.
    dense_max : int, default 4000
        Up to this many smoothed vertices the kernel is formed as a dense matrix
        (``k^2`` floats; 128 MB at 4,000); above, ``expm_multiply`` applies it.
    """

    def __init__(self, vertices, faces, fwhm: float, mask=None, dense_max: int = 4000):
        v, f = _check_mesh(vertices, faces)
        fwhm = float(fwhm)
        if not np.isfinite(fwhm) or fwhm <= 0:
            raise ValueError(f"fwhm: expected a width > 0, got {fwhm}")
        dense_max = check_int(dense_max, "dense_max", minimum=0)
        k = len(v)
        if mask is None:
            mask = np.ones(k, dtype=bool)
        mask = np.asarray(mask)
        if mask.shape != (k,) or mask.dtype != bool:
            raise ValueError(f"mask: expected bool shape ({k},), got {mask.dtype} {mask.shape}")
        f = f[mask[f].all(axis=1)]
        used = np.zeros(k, dtype=bool)
        used[f.ravel()] = True
        if not used.any():
            raise ValueError("mask: no triangle has its three vertices in the mask")
        self.k, self.fwhm, self.time = k, fwhm, fwhm_to_time(fwhm)
        self.vertices_smoothed = np.flatnonzero(used)
        index = np.full(k, -1)
        index[self.vertices_smoothed] = np.arange(len(self.vertices_smoothed))
        sub_v, sub_f = v[self.vertices_smoothed], index[f]
        laplacian = igl.cotmatrix(sub_v, sub_f)
        mass = igl.massmatrix(sub_v, sub_f, igl.MASSMATRIX_TYPE_VORONOI).diagonal()
        if not (mass > 0).all():
            raise ValueError("vertices: the mesh has triangles of zero area around some vertex")
        self.mass = mass
        self._generator = self._kernel = None
        if len(mass) <= dense_max:
            root = np.sqrt(mass)
            symmetric = laplacian.toarray() / root[:, None] / root[None, :]
            w, u = np.linalg.eigh(0.5 * (symmetric + symmetric.T))
            self._kernel = ((u / root[:, None]) * np.exp(self.time * np.minimum(w, 0.0))) @ (
                u.T * root[None, :]
            )
        else:
            self._generator = (sp.diags(1.0 / mass) @ laplacian).tocsr() * self.time

    def __call__(self, values) -> np.ndarray:
        """Smoothed ``values`` of shape ``(..., k)`` (the last axis over the vertices)."""
        x = np.asarray(values, dtype=float)
        if x.ndim == 0 or x.shape[-1] != self.k:
            raise ValueError(f"values: expected shape (..., {self.k}), got {x.shape}")
        sub = x[..., self.vertices_smoothed]
        if not np.isfinite(sub).all():
            raise ValueError("values: contain NaN or infinite values on the smoothed vertices")
        columns = sub.reshape(-1, sub.shape[-1]).T
        if not columns.size:
            smoothed = columns
        elif self._kernel is not None:
            smoothed = self._kernel @ columns
        else:
            smoothed = expm_multiply(self._generator, columns)
        out = x.copy()
        out[..., self.vertices_smoothed] = smoothed.T.reshape(sub.shape)
        return out


def smooth_surface_data(values, vertices, faces, fwhm: float, mask=None) -> np.ndarray:
    """``values`` of shape ``(..., k)`` smoothed by the heat kernel of full width ``fwhm``.

    See :class:`SurfaceSmoother` (build it once to smooth many maps of one mesh).
    """
    return SurfaceSmoother(vertices, faces, fwhm, mask)(values)
