"""Rigid alignment of a mesh onto a surface that keeps what the input knows about its pose.

A left ventricle is close to a surface of revolution: a surface fit (ICP)
determines its long axis and position, but hardly how it is turned about that
axis. Segmentations come in scanner coordinates, where that turn is already
consistent across subjects, or with anatomical landmarks that fix it. So
:func:`fit_rigid`:

1. runs ICP (:func:`~.alignment.icp_align`, point to point) from the input's own
   orientation and from the principal-axes starts, and among the fits whose
   residual (mean point-to-plane distance to the target) is within ``start_tolerance``
   (relative, plus the triangulation's own ripple) of the best, keeps the smallest
   rotation (between two different ventricles a flipped fit can fit a few per cent
   better than the true one: 10 % keeps the input's orientation);
2. replaces its rotation by that of the affine fit between the moved mesh and the
   target (the polar factor of :func:`~.affine.affine_icp`): the rigid motion left
   once size and elongation are fitted, which a rigid fit between ventricles of
   different proportions tilts by a few degrees;
3. scans the turns about the target's long axis (through its centroid, every
   degree): the arc of turns whose residual stays within ``tolerance`` of the best
   is the *axial spread*, the turns the surface cannot tell apart (360 for a surface
   of revolution). Within it, the turn giving the smallest total rotation is
   applied: a subject already in the atlas's orientation stays there, a posed one is
   turned back by its pose less the pose's twist about the long axis, which no
   surface shows;
4. with landmarks (:class:`~.landmarks.Landmarks` of the source and of the target)
   instead: the rotation is the landmarks' (:func:`~.landmarks.landmark_transform`),
   the translation the surface's. The surface fit from the landmarks' start (ICP and
   the affine rotation) is still made, and its angle to the landmarks' rotation is
   reported: a large one means that landmarks and surface disagree.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from scipy import spatial

from manifolds.data_terms.mesh_geometry import check_mesh
from manifolds.validation import check_float

from ..surface_queries import closest_points
from .affine import affine_icp
from .alignment import SimilarityTransform, icp_align, icp_starts, principal_frame
from .landmarks import Landmarks, axial_angle, landmark_transform

__all__ = ["AlignmentFit", "fit_rigid", "axis_rotation"]

_MAX_SCAN_POINTS = 1500
#: Residuals within this fraction of the target's mean edge length of the best are equally
#: good whatever ``tolerance`` says: a surface of revolution turned about its axis changes the
#: point-to-plane residual by up to 2 % of an edge through its triangulation alone.
_RIPPLE = 0.02


@dataclass(frozen=True)
class AlignmentFit:
    """A rigid (or similarity) alignment and what the surfaces said about it.

    Attributes
    ----------
    transform : SimilarityTransform
        Maps the source into the target's frame.
    distance : float
        Mean distance of the moved source vertices to the target surface.
    method : str
        ``"icp"`` (surfaces only), ``"landmarks"`` (landmarks and surfaces),
        ``"given"`` or ``"none"``.
    axial_spread : float or None
        Degrees of rotation about the target's long axis over which the residual
        stays within the tolerance of the best (360: the surface does not fix the turn).
    axial_turn : float
        Degrees turned about the long axis after ICP (to the smallest rotation, or to
        the landmarks' septum).
    landmark_disagreement : float or None
        Degrees between the ICP fit and the landmarks' frame (``"landmarks"`` only).
    """

    transform: SimilarityTransform
    distance: float
    method: str
    axial_spread: float | None = None
    axial_turn: float = 0.0
    landmark_disagreement: float | None = None

    def as_dict(self) -> dict:
        """JSON-ready fields (the transform as its matrix)."""
        return {
            "method": self.method,
            "distance": self.distance,
            "axial_spread_deg": self.axial_spread,
            "axial_turn_deg": self.axial_turn,
            "landmark_disagreement_deg": self.landmark_disagreement,
            "transform": self.transform.as_dict(),
        }


def axis_rotation(axis, angle_deg: float, centre) -> SimilarityTransform:
    """The rotation by ``angle_deg`` about the line through ``centre`` along ``axis``."""
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    t = np.radians(angle_deg)
    rot = np.eye(3) + np.sin(t) * k + (1 - np.cos(t)) * k @ k
    c = np.asarray(centre, dtype=float)
    return SimilarityTransform(rot, c - rot @ c)


class _Surface:
    """The target as points (vertices, triangle centres) with their unit normals: the
    distance of a point is that to the tangent plane of its nearest sample (point to plane),
    which ripples much less with the triangulation as a mesh turns than the distance to the
    nearest sample; ``ripple`` is what is left of it (see ``_RIPPLE``)."""

    def __init__(self, vertices, faces):
        mesh = trimesh.Trimesh(vertices, faces, process=False)
        self.points = np.vstack([vertices, mesh.triangles_center])
        self.normals = np.vstack([mesh.vertex_normals, mesh.face_normals])
        self.tree = spatial.cKDTree(self.points)
        edges = mesh.edges_unique_length
        #: residual differences below this are the triangulation's, not the shapes'
        self.ripple = _RIPPLE * float(edges.mean()) if len(edges) else 0.0

    def nearest(self, points):
        return self.points[self.tree.query(points)[1]]

    def residual(self, points) -> float:
        _, index = self.tree.query(points)
        gap = np.einsum("ij,ij->i", points - self.points[index], self.normals[index])
        return float(np.abs(gap).mean())


def _subsample(points: np.ndarray) -> np.ndarray:
    step = max(1, int(np.ceil(len(points) / _MAX_SCAN_POINTS)))
    return points[::step]


def _axial_scan(transform, source, target, axis, centre, tolerance):
    """The turn about ``axis`` to apply and the spread of equally good turns (degrees)."""
    angles = np.arange(-180, 180)
    moved = transform.apply(source)
    residuals = np.array(
        [target.residual(axis_rotation(axis, a, centre).apply(moved)) for a in angles]
    )
    good = residuals <= residuals.min() * (1.0 + tolerance) + target.ripple + 1e-12
    sizes = [axis_rotation(axis, a, centre).compose(transform).rotation_angle() for a in angles]
    choice = int(np.argmin(np.where(good, sizes, np.inf)))
    if good.all():
        return float(angles[choice]), 360.0
    # the contiguous arc of good angles around the choice (on the circle)
    spread = 1
    for step in (1, -1):
        i = choice + step
        while good[i % 360] and spread < 360:
            spread += 1
            i += step
    return float(angles[choice]), float(spread)


def _fit_translation(rotation, scale, points, target, translation, iterations=10):
    """Translation-only ICP: the best translation for a fixed rotation and scale."""
    moved = scale * points @ rotation.T
    t = np.array(translation, dtype=float)
    for _ in range(iterations):
        t = (target.nearest(moved + t) - moved).mean(axis=0)
    return t


def _affine_rotation(transform, sv, sf, tv, tf, target, sample):
    """``transform`` corrected by the rotation of the affine fit between the moved source and
    the target (its polar factor): the rigid motion left once size and elongation are fitted,
    which a rigid fit between shapes of different proportions tilts by a few degrees."""
    moved = transform.apply(sv)
    try:
        with np.errstate(all="ignore"):
            matrix = affine_icp(tv, tf, moved, sf)
    except np.linalg.LinAlgError:  # degenerate triangles: keep the rigid fit
        return transform
    if not np.isfinite(matrix).all() or np.linalg.det(matrix[:3, :3]) <= 0:
        return transform
    u, _, vt = np.linalg.svd(matrix[:3, :3])
    polar = u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt
    rotation = polar.T @ transform.rotation
    t = _fit_translation(rotation, transform.scale, sample, target, transform.translation)
    return SimilarityTransform(rotation, t, transform.scale)


def fit_rigid(
    source_vertices,
    source_faces,
    target_vertices,
    target_faces,
    *,
    scale: bool = False,
    tolerance: float = 0.05,
    start_tolerance: float = 0.10,
    source_landmarks: Landmarks | None = None,
    target_landmarks: Landmarks | None = None,
) -> AlignmentFit:
    """Align a mesh onto a surface, keeping its pose where the surfaces cannot tell (see module).

    Parameters
    ----------
    source_vertices, source_faces : arrays ``(k, 3)``, ``(f, 3)``
        The mesh to move (e.g. a subject's end-diastole).
    target_vertices, target_faces : arrays ``(m, 3)``, ``(g, 3)``
        The fixed surface (e.g. the atlas).
    scale : bool, default False
        Fit a similarity instead of a rigid motion.
    tolerance : float, default 0.05
        Turns about the long axis whose residual is at most ``(1 + tolerance)`` times the
        best (plus 2 % of the target's mean edge length, the triangulation's own ripple)
        are equally good.
    start_tolerance : float, default 0.10
        The same for the ICP fits from the different starts.
    source_landmarks, target_landmarks : Landmarks, optional
        Both or neither: the landmarks of the source (in its own frame) and of the target.

    Returns
    -------
    AlignmentFit
    """
    sv, sf = check_mesh(source_vertices, source_faces, "fit_rigid: source")
    tv, tf = check_mesh(target_vertices, target_faces, "fit_rigid: target")
    tolerance = check_float(tolerance, "fit_rigid: tolerance", minimum=0.0)
    start_tolerance = check_float(start_tolerance, "fit_rigid: start_tolerance", minimum=0.0)
    if (source_landmarks is None) != (target_landmarks is None):
        raise ValueError("fit_rigid: source_landmarks and target_landmarks: give both or neither")
    target = _Surface(tv, tf)
    sample = _subsample(sv)
    centre, axes = principal_frame(tv, tf)

    if source_landmarks is not None:
        start = landmark_transform(source_landmarks, target_landmarks, scale=scale)
        fitted, _ = icp_align(sv, sf, tv, tf, scale=scale, initial=start)
        fitted = _affine_rotation(fitted, sv, sf, tv, tf, target, sample)
        disagreement = fitted.compose(start.inverse()).rotation_angle()
        axis = target_landmarks.long_axis
        mapped = fitted.rotation @ source_landmarks.septal_direction
        turn = axial_angle(target_landmarks.septal_direction, mapped, axis)
        spread = _axial_scan(fitted, sample, target, axis, centre, tolerance)[1]
        t = _fit_translation(start.rotation, start.scale, sample, target, fitted.translation)
        final = SimilarityTransform(start.rotation, t, start.scale)
        method = "landmarks"
    else:
        fits = [icp_align(sv, sf, tv, tf, scale=scale, initial=s, surface=False)[0]
                for s in icp_starts(sv, sf, tv, tf)]  # fmt: skip
        residuals = np.array([target.residual(f.apply(sample)) for f in fits])
        good = residuals <= residuals.min() * (1.0 + start_tolerance) + target.ripple + 1e-12
        pick = int(np.argmin([f.rotation_angle() if g else np.inf for f, g in zip(fits, good)]))
        fitted = _affine_rotation(fits[pick], sv, sf, tv, tf, target, sample)
        turn, spread = _axial_scan(fitted, sample, target, axes[:, 0], centre, tolerance)
        final = axis_rotation(axes[:, 0], turn, centre).compose(fitted)
        disagreement, method = None, "icp"
    distance = float(closest_points(final.apply(sv), tv, tf)[1].mean())
    return AlignmentFit(final, distance, method, spread, float(turn), disagreement)
