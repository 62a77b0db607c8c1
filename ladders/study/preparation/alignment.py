"""Rigid and similarity alignment of meshes: Procrustes with correspondence, ICP without.

A :class:`SimilarityTransform` ``x -> s R x + t`` (``R`` a rotation, never a
reflection) is what every function here returns and what the correspondence
records per subject (its 4 x 4 matrix). With corresponding points the
least-squares transform has a closed form (:func:`procrustes`: Kabsch and
Umeyama, SVD of the cross-covariance with the sign of the last singular
vector fixed). Without correspondence, :func:`icp_align` runs the iterative
closest point algorithm from several starts: the centroids matched with the
input's own orientation, and with the principal axes matched in each of their
four orientations that make a rotation, each run point to point on the target's
vertices and triangle centres (:func:`trimesh.registration.icp`, a k-d tree),
the best one refined point to surface (closest points on the triangles by
libigl's AABB tree, :func:`~ladders.study.surface_queries.closest_points`). Two meshes whose shapes differ are
then aligned by their surfaces, not by an anatomical frame; a corresponded
pair is best aligned again by :func:`procrustes` on its vertices. A rotation
that leaves the target surface unchanged (e.g. about the axis of an
axisymmetric atlas) cannot be determined by any surface fit: ICP then returns
one of the equally good rotations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from scipy import spatial

from manifolds.data_terms.mesh_geometry import check_mesh
from manifolds.validation import check_array, check_rng

from ..surface_queries import closest_points

__all__ = [
    "SimilarityTransform",
    "procrustes",
    "icp_align",
    "principal_frame",
    "second_moments",
    "icp_starts",
    "random_rigid_transform",
]


@dataclass(frozen=True)
class SimilarityTransform:
    """``x -> scale * rotation @ x + translation``.

    Attributes
    ----------
    rotation : array, shape ``(3, 3)``
        A rotation (determinant +1).
    translation : array, shape ``(3,)``
    scale : float
    """

    rotation: np.ndarray
    translation: np.ndarray
    scale: float = 1.0

    @classmethod
    def identity(cls) -> SimilarityTransform:
        """The identity."""
        return cls(np.eye(3), np.zeros(3), 1.0)

    @classmethod
    def from_matrix(cls, matrix) -> SimilarityTransform:
        """From a 4 x 4 homogeneous matrix ``[[s R, t], [0, 1]]`` (``s > 0``, ``det R = 1``)."""
        m = check_array(matrix, (4, 4), "SimilarityTransform: matrix")
        linear = m[:3, :3]
        det = np.linalg.det(linear)
        if m.ndim != 2 or det <= 0 or not np.allclose(m[3], [0, 0, 0, 1]):
            raise ValueError(
                "SimilarityTransform: matrix: expected [[s R, t], [0, 0, 0, 1]] with s > 0 and "
                f"a rotation R, got determinant {det:.3g} and last row {m[3].tolist()}"
            )
        scale = float(np.cbrt(det))
        rotation = linear / scale
        if not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-6):
            raise ValueError("SimilarityTransform: matrix: its linear part is not s R")
        return cls(rotation, m[:3, 3].copy(), scale)

    @property
    def matrix(self) -> np.ndarray:
        """The 4 x 4 homogeneous matrix."""
        out = np.eye(4)
        out[:3, :3] = self.scale * self.rotation
        out[:3, 3] = self.translation
        return out

    def apply(self, points) -> np.ndarray:
        """Transformed points, shape ``(n, 3)``."""
        pts = check_array(points, (3,), "SimilarityTransform.apply: points")
        return self.scale * pts @ self.rotation.T + self.translation

    def inverse(self) -> SimilarityTransform:
        """``x -> R^T (x - t) / s``."""
        rot = self.rotation.T
        return SimilarityTransform(rot, -(rot @ self.translation) / self.scale, 1.0 / self.scale)

    def compose(self, first: SimilarityTransform) -> SimilarityTransform:
        """``self o first``: ``first`` applied, then ``self``."""
        return SimilarityTransform(
            self.rotation @ first.rotation,
            self.scale * self.rotation @ first.translation + self.translation,
            self.scale * first.scale,
        )

    def rotation_angle(self) -> float:
        """Angle of the rotation, in degrees."""
        cos = np.clip((np.trace(self.rotation) - 1.0) / 2.0, -1.0, 1.0)
        return float(np.degrees(np.arccos(cos)))

    def as_dict(self) -> dict:
        """JSON-ready: the 4 x 4 matrix as nested lists and the scale."""
        return {"matrix": self.matrix.tolist(), "scale": self.scale}

    @classmethod
    def from_dict(cls, data: dict) -> SimilarityTransform:
        """Inverse of :meth:`as_dict`."""
        return cls.from_matrix(np.asarray(data["matrix"], dtype=float))


def procrustes(source, target, *, scale: bool = False, weights=None) -> SimilarityTransform:
    """The rigid (or similarity) transform minimising ``sum_i w_i |T(source_i) - target_i|^2``.

    Closed form (Kabsch, Umeyama 1991); reflections are excluded.

    Parameters
    ----------
    source, target : arrays, shape ``(k, 3)``
        Corresponding points.
    scale : bool, default False
        Also fit a uniform scale.
    weights : array, shape ``(k,)``, optional
        Non-negative weights (uniform by default).

    Returns
    -------
    SimilarityTransform
    """
    x = check_array(source, (3,), "procrustes: source")
    y = check_array(target, (3,), "procrustes: target")
    if x.ndim != 2 or x.shape != y.shape or len(x) < 3:
        raise ValueError(
            f"procrustes: source and target: expected corresponding points of one shape (k, 3), "
            f"k >= 3, got {x.shape} and {y.shape}"
        )
    w = np.ones(len(x)) if weights is None else check_array(weights, (), "procrustes: weights")
    if w.shape != (len(x),) or (w < 0).any() or w.sum() <= 0:
        raise ValueError(f"procrustes: weights: expected {len(x)} non-negative weights")
    w = w / w.sum()
    mx, my = w @ x, w @ y
    xc, yc = x - mx, y - my
    u, sing, vt = np.linalg.svd((yc * w[:, None]).T @ xc)
    d = np.ones(3)
    d[2] = np.sign(np.linalg.det(u @ vt)) or 1.0
    rotation = u @ np.diag(d) @ vt
    s = float((sing * d).sum() / (w @ (xc * xc).sum(1))) if scale else 1.0
    return SimilarityTransform(rotation, my - s * rotation @ mx, s)


def second_moments(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Area-weighted centroid ``(3,)`` and second-moment tensor ``(3, 3)`` of a surface.

    Each triangle counts its centre with its area: ``m = sum_t w_t c_t`` and
    ``M = sum_t w_t (c_t - m)(c_t - m)^T`` (``w`` the areas over their sum), so both
    depend on the surface, not on its triangulation; ``trace(M)`` is the squared RMS
    distance of the surface to its centroid.
    """
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    centres = (a + b + c) / 3.0
    w = area / area.sum()
    centroid = w @ centres
    d = centres - centroid
    return centroid, (d * w[:, None]).T @ d


def principal_frame(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Area-weighted centroid ``(3,)`` and principal axes ``(3, 3)`` (columns, decreasing variance).

    The eigenvectors of :func:`second_moments`; they form a rotation (determinant +1),
    their signs are arbitrary.
    """
    centroid, moments = second_moments(vertices, faces)
    _, vecs = np.linalg.eigh(moments)
    axes = vecs[:, ::-1].copy()
    if np.linalg.det(axes) < 0:
        axes[:, 2] *= -1
    return centroid, axes


def icp_starts(source_v, source_f, target_v, target_f):
    """Rigid starts, centroids matched: the input's own orientation, then the principal axes
    matched in their four proper orientations."""
    cs, axs = principal_frame(source_v, source_f)
    ct, axt = principal_frame(target_v, target_f)
    yield SimilarityTransform(np.eye(3), ct - cs)
    for flip in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)):
        rot = axt @ np.diag(flip) @ axs.T
        yield SimilarityTransform(rot, ct - rot @ cs)


def icp_align(
    source_vertices,
    source_faces,
    target_vertices,
    target_faces,
    *,
    scale: bool = False,
    initial: SimilarityTransform | None = None,
    max_iterations: int = 100,
    threshold: float = 1e-8,
    surface: bool = True,
) -> tuple[SimilarityTransform, float]:
    """Align a mesh onto another surface by ICP (no correspondence needed).

    ICP moves the source vertices onto the closest
    points of the target, from ``initial`` or, by default, from the five starts
    of the module docstring (point to point, keeping the lowest cost), and
    refines the best point to surface. On a near surface of revolution the
    lowest cost may be any turn about the axis: :func:`~.rigid_fit.fit_rigid`
    keeps the input's own orientation there.

    Parameters
    ----------
    source_vertices, source_faces : arrays ``(k, 3)``, ``(f, 3)``
        The mesh to move.
    target_vertices, target_faces : arrays ``(m, 3)``, ``(g, 3)``
        The fixed mesh (e.g. the atlas).
    scale : bool, default False
        Fit a similarity instead of a rigid motion.
    initial : SimilarityTransform, optional
    max_iterations : int
    threshold : float
        ICP stops when the mean distance changes by less than this.
    surface : bool, default True
        Refine the best start point to surface; False keeps the point-to-point fit
        (faster; the distance returned is then to the target's vertices and triangle
        centres).

    Returns
    -------
    transform : SimilarityTransform
        Maps the source into the target's frame.
    distance : float
        Mean distance of the moved source vertices to the target surface.
    """
    sv, sf = check_mesh(source_vertices, source_faces, "icp_align: source")
    tv, tf = check_mesh(target_vertices, target_faces, "icp_align: target")
    starts = [initial] if initial is not None else list(icp_starts(sv, sf, tv, tf))
    # every start by point-to-point ICP (k-d tree) on the target's vertices and triangle
    # centres, then the best one refined point-to-surface (AABB tree)
    cloud = np.vstack([tv, tv[tf].mean(axis=1)])
    best = None
    for start in starts:
        matrix, _, cost = trimesh.registration.icp(
            sv, cloud, initial=start.matrix, threshold=threshold,
            max_iterations=max_iterations, reflection=False, scale=scale,
        )  # fmt: skip
        if best is None or cost < best[1]:
            best = (matrix, float(cost))
    if not surface:
        transform = SimilarityTransform.from_matrix(best[0])
        distance = spatial.cKDTree(cloud).query(transform.apply(sv))[0]
        return transform, float(distance.mean())
    # the refinement stops when the mean squared distance changes by less than 1e-6 of itself
    transform = _refine_to_surface(
        sv, tv, tf, SimilarityTransform.from_matrix(best[0]), scale=scale,
        threshold=max(threshold, 1e-6 * best[1]), max_iterations=max_iterations,
    )  # fmt: skip
    distance = closest_points(transform.apply(sv), tv, tf)[1]
    return transform, float(distance.mean())


def _refine_to_surface(sv, tv, tf, transform, *, scale, threshold, max_iterations):
    """Point-to-surface ICP from ``transform``: closest points (libigl's AABB tree), Procrustes.

    Each step moves the source onto the closest points of the target surface by the
    least-squares transform; it stops when the mean squared distance after the step
    falls by less than ``threshold``.
    """
    previous = np.inf
    for _ in range(max_iterations):
        moved = transform.apply(sv)
        closest = closest_points(moved, tv, tf)[0]
        step = procrustes(moved, closest, scale=scale)
        transform = step.compose(transform)
        cost = float(np.mean(np.sum((step.apply(moved) - closest) ** 2, axis=1)))
        if previous - cost < threshold:
            break
        previous = cost
    return transform


def random_rigid_transform(
    rng: np.random.Generator, max_angle: float = 180.0, max_translation: float = 0.0
) -> SimilarityTransform:
    """A random rotation (axis uniform, angle uniform up to ``max_angle`` degrees) and translation.

    The translation is uniform in the cube ``[-max_translation, max_translation]^3``.
    """
    check_rng(rng)
    axis = rng.standard_normal(3)
    axis /= np.linalg.norm(axis)
    angle = np.radians(rng.uniform(0.0, max_angle))
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rotation = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
    return SimilarityTransform(rotation, rng.uniform(-max_translation, max_translation, 3))
