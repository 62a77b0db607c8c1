"""Follow a corresponded end-diastolic mesh through the frames of a cardiac cycle.

:func:`track_surfaces` takes a mesh in the atlas's vertex correspondence at
end-diastole (frame 0, e.g. the output of ``symladders correspond``) and the surface
of every frame (any triangulation, one scanner frame, mm), and moves the mesh from
frame to frame: frame ``t``'s mesh starts from frame ``t - 1``'s result and is moved
onto frame ``t``'s surface, either by its affine fit followed by a projection of
every vertex along its normal (``method="projection"``, as
:func:`~ladders.study.preparation.correspondence.project_mesh`: the global change of
shape is carried by the affine part, the regional motion across the wall by the
normal part, and no regional motion along the wall is invented), or by an LDDMM
registration with a varifold data term (``method="registration"``, as
:func:`~ladders.study.preparation.correspondence.correspond_mesh`, with the
transform fixed to the identity). Before each step the frame's surface is cropped
to the triangles within ``crop_distance`` of the moving mesh, so that a lid closing
the label at the valve plane or another structure does not pull the mesh.

Frame 0 is the ED mesh moved along its normals onto frame 0's surface
(``settings.project_ed``), so that every frame's motion is measured between surfaces
extracted alike; every normal projection takes the closest point instead of a hit
that detours more than ``settings.max_detour`` past it (a line that crossed to
another part of the surface).

A chain of small steps drifts: every step adds its own error along the wall, and
nothing brings the vertices back. With ``refine_ed`` every frame is also reached
from end-diastole directly (one step from the ED mesh, the surface cropped about the
chain's result, the affine fit started from the affine map of the ED mesh onto the
chain's result, which only saves iterations), and the two results are combined with the weight of the direct one
growing with the frame's position in the cycle (:func:`combine_weight`,
``w_t = t / n``, ``n`` the number of frames): early frames, a short chain away from
ED, follow the chain; late frames, which relax back towards ED and end a long chain,
follow the direct result, which is then a short step. This is the weighting by
which cine pipelines combine a forward chain with a backward one starting from the
next end-diastole; the ED mesh plays the next end-diastole here (a cycle is
periodic). The weighted mean of two points on a surface lies slightly off it, so
the combination is projected back along its normals; the chain goes on from the
combined result. The distance between the two results (``drift_rms``) is recorded.

With ``base_planes`` (the valve plane of every frame, e.g. from long-axis views, or
``symladders track --cut-planes`` with a plane per frame), every affine fit also
brings the height of the source frame's plane to that of the target frame's (an
anchor along the target plane's normal, :func:`~ladders.study.preparation.affine.affine_icp`'s
``anchors``) and leaves out the pairs whose closest point lies on a rim (``skip_rim``),
and a vertex whose normal misses the surface (above a rim lower than the base) keeps
its place instead of going to the rim's closest point. On short-axis
stacks the rim of a frame's surface lies at a slice's edge, up to a slice below the
base and by an amount that changes from frame to frame; without the planes that rim
sets the longitudinal part of the affine fit (``docs/tracking.md``).

What a surface cannot show is said in ``docs/tracking.md``: the motion along the wall
(the twist about the long axis above all) is not in the surfaces, so the tracked
vertices carry the motion across the wall and the affine part of the motion along it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from manifolds.data_terms.mesh_geometry import check_mesh

from ..preparation.affine import affine_icp, apply_affine
from ..preparation.alignment import SimilarityTransform
from ..preparation.correspondence import correspond_mesh
from ..preparation.surface_distance import distances_to_surface
from ..surface_queries import closest_points
from ..wall_motion import normal_wall_motion
from .settings import TrackingSettings

__all__ = ["TrackedSurfaces", "track_surfaces", "combine_weight", "crop_surface"]

#: A cropped surface keeping fewer faces than this fraction is refused.
_MIN_KEPT = 0.05


@dataclass
class TrackedSurfaces:
    """A mesh followed through the frames of a cycle.

    Attributes
    ----------
    vertices : ndarray, shape (n_frames, k, 3)
        The tracked mesh at every frame (mm; frame 0 is the ED mesh moved along its
        normals onto frame 0's surface with ``settings.project_ed``, else the ED mesh as
        given), in the frame of the surfaces.
    faces : ndarray of int, shape (f, 3)
        The mesh's triangles (the atlas's), shared by every frame.
    quality : list of dict
        Per frame: ``mean_distance``, ``max_distance`` (of the vertices to the frame's
        surface, mm), ``step_rms`` (RMS motion from the previous frame, mm),
        ``hit_fraction`` (vertices whose normal met the surface; projection),
        ``converged`` and ``n_iter`` (registration), ``weight_ed`` and ``drift_rms``
        (with ``refine_ed``: the weight of the direct result and the RMS distance
        between the chain's and the direct result, mm), ``kept_faces`` (fraction of the
        surface kept by the crop); at frame 0 with ``project_ed``, ``onto_surface_rms``
        (RMS motion of the given ED mesh onto frame 0's surface, mm).
    settings : TrackingSettings
    """

    vertices: np.ndarray
    faces: np.ndarray
    quality: list = field(default_factory=list)
    settings: TrackingSettings = field(default_factory=TrackingSettings)

    @property
    def n_frames(self) -> int:
        """Number of frames."""
        return int(self.vertices.shape[0])


def combine_weight(frame: int, n_frames: int) -> float:
    """Weight of the result reached from ED directly at ``frame`` of ``n_frames``: ``frame / n_frames``.

    0 at ED, growing with the chain's length; the (virtual) frame ``n_frames`` is the
    next end-diastole, where the direct result would be exact.
    """
    if n_frames < 1 or not 0 <= frame < n_frames:
        raise ValueError(f"combine_weight: expected 0 <= frame < n_frames, got {frame}, {n_frames}")
    return float(frame) / float(n_frames)


def crop_surface(vertices, faces, near_vertices, near_faces, distance: float | None):
    """The triangles of ``(vertices, faces)`` whose centroid lies within ``distance`` of a mesh.

    Parameters
    ----------
    vertices, faces : arrays ``(m, 3)``, ``(g, 3)``
        The surface cropped (mm).
    near_vertices, near_faces : arrays ``(k, 3)``, ``(f, 3)``
        The mesh it is cropped about.
    distance : float or None
        mm; None keeps the whole surface.

    Returns
    -------
    vertices, faces, kept : the cropped surface (unused vertices dropped) and the
    fraction of the faces kept.
    """
    if distance is None:
        return vertices, faces, 1.0
    centroids = vertices[faces].mean(axis=1)
    near = closest_points(centroids, near_vertices, near_faces)[1] <= distance
    kept = faces[near]
    used = np.unique(kept)
    index = np.full(len(vertices), -1, dtype=np.int64)
    index[used] = np.arange(len(used))
    return vertices[used], index[kept], float(near.mean()) if len(faces) else 0.0


def _cropped(target, about, faces, settings: TrackingSettings, frame: int):
    tv, tf, kept = crop_surface(*target, about, faces, settings.crop_distance)
    if len(tf) < 4 or kept < _MIN_KEPT:
        raise ValueError(
            f"frame {frame}: the mesh is farther than crop_distance = {settings.crop_distance} mm "
            f"from the frame's surface ({100 * kept:.1f} % of it within): a surface of another "
            "subject or frame, or a motion between frames larger than crop_distance"
        )
    return tv, tf, kept


def _point_affine(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """The least-squares affine map ``(4, 4)`` of corresponding points ``source -> target``."""
    solution = np.linalg.lstsq(np.c_[source, np.ones(len(source))], target, rcond=None)[0]
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = solution[:3].T, solution[3]
    return out


def _onto(vertices, faces, tv, tf, settings: TrackingSettings, keep_missed: bool = False):
    """Each vertex along its normal onto the surface ``(tv, tf)``, with the settings' limits;
    with ``keep_missed`` a vertex whose normal misses the surface stays where it is."""
    out = normal_wall_motion(vertices, faces, tv, tf, max_distance=settings.normal_max_distance,
                             max_detour=settings.max_detour)  # fmt: skip
    if keep_missed and not out.hit.all():
        points = out.points.copy()
        points[~out.hit] = vertices[~out.hit]
        out = dataclasses.replace(out, points=points, distance=np.where(out.hit, out.distance, 0.0))
    return out


def _projection(start, faces, tv, tf, settings: TrackingSettings, guess=None, anchor=None):
    """The affine fit of ``start`` onto the surface, then along its normals onto it.

    ``guess`` (points corresponding to ``start``, e.g. the chain's result for a step
    from ED) starts the affine fit at their least-squares affine map. ``anchor``
    ``(source plane, target plane)``, each ``(6,)`` (point, unit normal): the fit also
    brings the source plane's point to the target plane's height along its normal."""
    warm = np.eye(4) if guess is None else _point_affine(start, guess)
    moved = apply_affine(warm, start)
    extra = {}
    if anchor is not None:
        source, target = anchor
        extra = {"anchors": (apply_affine(warm, source[None, :3]), target[None, :3]),
                 "anchor_direction": target[3:], "skip_rim": True}  # fmt: skip
    matrix = affine_icp(moved, faces, tv, tf, iterations=settings.affine_iterations,
                        tol=settings.affine_tol, **extra) @ warm  # fmt: skip
    proj = _onto(apply_affine(matrix, start), faces, tv, tf, settings, anchor is not None)
    return proj.points, {"hit_fraction": float(proj.hit.mean())}


def _registration(start, faces, tv, tf, settings: TrackingSettings, guess=None, anchor=None):
    """``start`` registered onto the surface (LDDMM, varifold), no rigid re-alignment."""
    out = correspond_mesh(start, faces, tv, tf, settings.correspondence,
                          transform=SimilarityTransform.identity())  # fmt: skip
    return out.vertices, {"converged": out.quality["converged"], "n_iter": out.quality["n_iter"]}


def _step(start, faces, target, about, settings: TrackingSettings, frame: int, guess=None,
          anchor=None):  # fmt: skip
    tv, tf, kept = _cropped(target, about, faces, settings, frame)
    move = _projection if settings.method == "projection" else _registration
    points, info = move(start, faces, tv, tf, settings, guess, anchor)
    return points, {**info, "kept_faces": kept}, (tv, tf)


def _combine(chain, direct, weight, faces, cropped, settings: TrackingSettings,
             keep_missed: bool = False) -> np.ndarray:  # fmt: skip
    """The weighted mean of two results on a surface, projected back onto it along its normals."""
    mean = (1.0 - weight) * chain + weight * direct
    return _onto(mean, faces, *cropped, settings, keep_missed).points


def _planes(base_planes, n: int, settings: TrackingSettings) -> np.ndarray | None:
    """``base_planes`` checked: ``(n, 6)`` points and unit normals, or None."""
    if base_planes is None:
        return None
    if settings.method != "projection":
        raise ValueError("track_surfaces: base_planes: only with method='projection'")
    try:
        planes = np.asarray(base_planes, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(
            "track_surfaces: base_planes: expected numbers, shape (n_frames, 6)"
        ) from None
    if planes.shape != (n, 6):
        raise ValueError(
            f"track_surfaces: base_planes: expected one plane (x, y, z, nx, ny, nz) per frame, "
            f"shape ({n}, 6), got {planes.shape}"
        )
    if not np.isfinite(planes).all():
        raise ValueError("track_surfaces: base_planes: not finite (NaN or infinity)")
    norms = np.linalg.norm(planes[:, 3:], axis=1)
    if (norms == 0).any():
        t = int(np.flatnonzero(norms == 0)[0])
        raise ValueError(f"track_surfaces: base_planes: frame {t}: the normal is zero")
    planes[:, 3:] /= norms[:, None]
    return planes


def _frames(frame_surfaces) -> list[tuple[np.ndarray, np.ndarray]]:
    try:
        surfaces = list(frame_surfaces)
    except TypeError:
        raise ValueError(
            "track_surfaces: frame_surfaces: expected a list of (vertices, faces)"
        ) from None
    if not surfaces:
        raise ValueError("track_surfaces: frame_surfaces: no frame")
    out = []
    for t, surface in enumerate(surfaces):
        try:
            v, f = surface
        except (TypeError, ValueError):
            raise ValueError(f"track_surfaces: frame {t}: expected (vertices, faces)") from None
        out.append(check_mesh(v, f, f"track_surfaces: frame {t}"))
    return out


def track_surfaces(
    ed_vertices, faces, frame_surfaces, settings: TrackingSettings | None = None,
    base_planes=None,
) -> TrackedSurfaces:  # fmt: skip
    """Follow the ED mesh through the frames' surfaces (see the module).

    Parameters
    ----------
    ed_vertices : array, shape (k, 3)
        The end-diastolic mesh in the atlas's vertex correspondence, in the frame and
        unit (mm) of the surfaces.
    faces : array of int, shape (f, 3)
        Its triangles (outward normals).
    frame_surfaces : sequence of (vertices (m_t, 3), faces (g_t, 3))
        The surface of every frame, any triangulation; frame 0 is end-diastole.
    settings : TrackingSettings, optional
    base_planes : array, shape (n_frames, 6), optional
        The valve plane of every frame, ``(x, y, z, nx, ny, nz)`` (a point and a normal,
        in the frame of the surfaces): every affine fit brings the height of its source
        frame's plane to its target frame's (see the module). Projection only.

    Returns
    -------
    TrackedSurfaces
        ``vertices`` of shape ``(n_frames, k, 3)`` (float64, mm) and a quality per frame.

    Raises
    ------
    ValueError
        A bad mesh or surface, a frame's surface that does not lie within
        ``settings.crop_distance`` of the mesh moved onto it, or bad ``base_planes``.
    """
    settings = settings or TrackingSettings()
    ed, faces = check_mesh(ed_vertices, faces, "track_surfaces: ED mesh")
    ed = np.asarray(ed, dtype=np.float64)
    surfaces = _frames(frame_surfaces)
    n = len(surfaces)
    planes = _planes(base_planes, n, settings)
    keep = planes is not None
    tracked = np.empty((n, len(ed), 3))
    quality = [
        {"step_rms": 0.0, **({"weight_ed": 0.0, "drift_rms": 0.0} if settings.refine_ed else {})}
    ]
    if settings.project_ed:
        tv, tf, kept = _cropped(surfaces[0], ed, faces, settings, 0)
        onto = _onto(ed, faces, tv, tf, settings, keep)
        quality[0].update(onto_surface_rms=_rms(onto.points - ed), hit_fraction=onto.hit_fraction,
                          kept_faces=kept)  # fmt: skip
        ed = onto.points
    tracked[0] = ed
    for t in range(1, n):
        previous = tracked[t - 1]
        chain_anchor = None if planes is None else (planes[t - 1], planes[t])
        points, info, cropped = _step(previous, faces, surfaces[t], previous, settings, t,
                                      anchor=chain_anchor)  # fmt: skip
        if settings.refine_ed:
            ed_anchor = None if planes is None else (planes[0], planes[t])
            direct, _, _ = _step(ed, faces, surfaces[t], points, settings, t, guess=points,
                                 anchor=ed_anchor)  # fmt: skip
            weight = combine_weight(t, n)
            info.update(weight_ed=weight, drift_rms=_rms(points - direct))
            points = _combine(points, direct, weight, faces, cropped, settings, keep)
        tracked[t] = points
        info["step_rms"] = _rms(points - previous)
        quality.append(info)
    for t, (v, f) in enumerate(surfaces):
        d = distances_to_surface(tracked[t], v, f)
        quality[t].update(mean_distance=float(d.mean()), max_distance=float(d.max()))
    return TrackedSurfaces(tracked, faces, quality, settings)


def _rms(displacement: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(displacement**2, axis=-1))))
