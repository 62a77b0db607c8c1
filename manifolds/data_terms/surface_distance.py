"""What the current and varifold data terms share: a target mesh, an RKHS distance, its gradient.

A surface data term compares the deformed template, a triangle mesh with the
template's faces, to a target mesh with any triangulation (no vertex
correspondence). Both are represented by their triangles' centres and normals;
the distance is the RKHS norm of the difference of their representations,

    D(x) = w ||A(x) - B||^2 = w (<A, A> - 2 <A, B> + <B, B>),

with ``A(x)`` the deformed template, ``B`` the target (``<B, B>`` computed
once), ``<., .>`` the product of :mod:`.current` or :mod:`.varifold` with the
Gaussian ``exp(-|c - c'|^2 / sigma_W^2)`` and ``w`` a weight. Its gradient with
respect to the template's points is ``2 w (d_1<A, A> - d_1<A, B>)`` pulled back
through the triangle geometry (:mod:`.mesh_geometry`).

The weight sets the term's scale against the regulariser ``alpha^2 ||v||_H^2``.
``weight="landmarks"`` chooses the one that makes a small translation ``t`` of
the target cost what it costs to ``k`` landmarks in correspondence, ``k |t|^2``,
so that ``alpha^2`` keeps its meaning from :class:`SquaredDistance` (see
``docs/preparation.md``).
"""

from __future__ import annotations

import hashlib

import numpy as np

from ..kernels.backends import resolve_backend
from ..validation import check_array, check_float, check_int
from .base import DataTerm
from .mesh_geometry import (
    check_faces,
    check_mesh,
    triangle_geometry,
    triangle_geometry_vjp,
    unit_normals,
)
from .surface_kernels import DEFAULT_BLOCK_SIZE, SurfaceFeatures, pair_sum

__all__ = ["SurfaceDistance", "surface_features"]

_BACKENDS = ("auto", "numpy", "numba")


def surface_features(vertices: np.ndarray, faces: np.ndarray) -> SurfaceFeatures:
    """Centres, areas, unit and area-weighted normals of a mesh's triangles."""
    centres, normals = triangle_geometry(vertices, faces)
    areas, units = unit_normals(normals)
    return SurfaceFeatures(centres, areas, units, normals)


class SurfaceDistance(DataTerm):
    """``w ||A(x) - B||^2`` between the deformed template and a target mesh (see the module).

    Parameters
    ----------
    target_vertices : array, shape ``(m, 3)``
    target_faces : int array, shape ``(g, 3)``
        The target mesh ``B``; any vertex count and triangulation.
    template_faces : int array, shape ``(f, 3)``
        The template's triangles: the deformed points ``x`` are read as the
        mesh ``(x, template_faces)``.
    sigma_w : float
        Width of the data term's Gaussian kernel, a length in the meshes' unit.
    weight : float or "landmarks", default 1.0
        ``w``; ``"landmarks"`` calibrates it on the target (module docstring).
    n_points : int, optional
        Number of template points (default: the largest face index plus one).
    backend : {"auto", "numpy", "numba"}, default "auto"
        Kernel sums: compiled (``"auto"``) or the numpy reference.
    block_size : int, optional
        Kernel entries per block of the numpy backend (memory bound).

    Attributes
    ----------
    target_norm_sq : float
        ``<B, B>``.
    """

    kind = ""

    def __init__(
        self,
        target_vertices,
        target_faces,
        template_faces,
        sigma_w: float,
        *,
        weight: float | str = 1.0,
        n_points: int | None = None,
        backend: str = "auto",
        block_size: int | None = None,
    ):
        name = type(self).__name__
        self.target_vertices, self.target_faces = check_mesh(
            target_vertices, target_faces, f"{name}: target"
        )
        if n_points is not None:
            n_points = check_int(n_points, f"{name}: n_points", minimum=3)
        self.template_faces = check_faces(template_faces, n_points, f"{name}: template_faces")
        self.n_points = int(self.template_faces.max()) + 1 if n_points is None else n_points
        self.sigma_w = check_float(sigma_w, f"{name}: sigma_w", minimum=0.0, strict=True)
        self.inv_s2 = 1.0 / self.sigma_w**2
        if backend not in _BACKENDS:
            raise ValueError(f"{name}: backend: expected one of {list(_BACKENDS)}, got {backend!r}")
        self.backend = resolve_backend(backend, f"{name}: backend")  # the one "auto" rule
        self.block_size = check_int(
            DEFAULT_BLOCK_SIZE if block_size is None else block_size,
            f"{name}: block_size",
            minimum=1,
        )
        self._target = surface_features(self.target_vertices, self.target_faces)
        self.target_norm_sq = self._pair(self._target, self._target)[0]
        self.weight = self._resolve_weight(weight)
        self._key = self._digest()

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(target with {len(self.target_vertices)} vertices and "
            f"{len(self.target_faces)} faces, template with {self.n_points} points and "
            f"{len(self.template_faces)} faces, sigma_w={self.sigma_w:g}, "
            f"weight={self.weight:.6g}, backend={self.backend!r})"
        )

    # ------------------------------------------------------------ pieces
    def _pair(self, x: SurfaceFeatures, y: SurfaceFeatures):
        return pair_sum(self.kind, x, y, self.inv_s2, self.backend, self.block_size)

    def _resolve_weight(self, weight) -> float:
        name = type(self).__name__
        if isinstance(weight, str):
            if weight != "landmarks":
                raise ValueError(
                    f"{name}: weight: expected a positive number or 'landmarks', got {weight!r}"
                )
            return self.landmark_weight()
        return check_float(weight, f"{name}: weight", minimum=0.0, strict=True)

    def landmark_weight(self, step: float = 0.01) -> float:
        """The weight making a translation ``t`` of the target cost about ``n_points |t|^2``.

        ``||B(. + t) - B||^2`` is evaluated for ``t = step * sigma_w`` along each
        axis; the weight is ``n_points |t|^2`` over their mean.
        """
        shift = step * self.sigma_w
        moved = []
        for axis in range(3):
            offset = np.zeros(3)
            offset[axis] = shift
            feats = surface_features(self.target_vertices + offset, self.target_faces)
            moved.append(2.0 * (self.target_norm_sq - self._pair(feats, self._target)[0]))
        return float(self.n_points * shift**2 / np.mean(moved))

    def _digest(self) -> str:
        h = hashlib.blake2b(digest_size=16)
        params = (type(self).__name__, self.sigma_w, self.weight, self.n_points, self.backend)
        h.update(repr(params).encode())
        for arr in (self.target_vertices, self.target_faces, self.template_faces):
            h.update(np.ascontiguousarray(arr).tobytes())
        return h.hexdigest()

    def key(self) -> str:
        """Stable hash of the term: kind, kernel width, weight, backend and the meshes."""
        return self._key

    def features(self, points) -> SurfaceFeatures:
        """The deformed template ``(points, template_faces)`` as triangle features."""
        return surface_features(self._check(points), self.template_faces)

    def _check(self, points) -> np.ndarray:
        x = check_array(points, (3,), f"{type(self).__name__}: deformed points")
        self.check_points(x, (self.n_points, 3))
        return x

    # ------------------------------------------------------------ data term
    def value_and_gradient(self, points) -> tuple[float, np.ndarray]:
        """``(D(x), dD/dx)`` with the gradient of shape ``(n_points, 3)``."""
        x = self._check(points)
        fx = surface_features(x, self.template_faces)
        aa, g_c_aa, g_n_aa = self._pair(fx, fx)
        ab, g_c_ab, g_n_ab = self._pair(fx, self._target)
        w = self.weight
        value = w * (aa - 2.0 * ab + self.target_norm_sq)
        grad = triangle_geometry_vjp(
            x, self.template_faces, 2.0 * w * (g_c_aa - g_c_ab), 2.0 * w * (g_n_aa - g_n_ab)
        )
        return float(value), grad

    def norm_sq(self, vertices, faces) -> float:
        """``<A, A>`` of any mesh ``(vertices, faces)`` (unweighted)."""
        v, f = check_mesh(vertices, faces, f"{type(self).__name__}: mesh")
        feats = surface_features(v, f)
        return self._pair(feats, feats)[0]
