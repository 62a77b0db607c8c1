"""The valve plane of every frame of a label series, estimated from its images.

On a short-axis stack the top of a frame's cavity label is the edge of the last slice
the blood pool reaches: the base lies anywhere within a slice above it, and the rim of
the frame's surface follows the slices, not the base (``docs/tracking.md``). Where no
valve plane is given, :func:`estimate_base_planes` places one per frame from the
series itself and the ED mesh:

1. **The ED plane** is the plane of the ED mesh's rim (:func:`rim_plane`: the rim's
   centroid and the normal of its least-squares plane, away from the mesh). Every
   frame's plane is this plane moved along its normal ``n``: the tilt is the ED mesh's.
2. **Each frame bounds its plane's height.** With ``h_t`` the largest height ``n . x``
   of the voxel centres of the frame's cavity (the largest component of the label, as
   the meshing keeps it) and ``e`` a voxel's extent along ``n`` (the slice thickness
   for a plane across the slices), the base lies in ``[h_t, h_t + e]``: above every
   voxel centre of the cavity, below the next voxel centre up. The ED plane's height
   is held in frame 0's interval.
   Where the plane is tilted against the slices, the columns of voxels pin it closer:
   a column whose top cavity voxel lies two voxels inside the cavity's section (so that
   the base, not the wall, ends it) bounds the plane by the height of the voxel above
   it, and the lowest such bound replaces ``h_t + e``.
3. **The descent follows the cavity's volume below the base.** ``V_t``, the cavity's
   voxels at heights up to ``H = min_t h_t`` (the part of the ventricle no frame's
   base crosses, so that the slices the base moves through do not enter), gives the
   profile ``g_t = (V_0 - V_t) / (V_0 - min_t V_t)``, 0 at ED and 1 at the smallest
   volume; the plane descends by ``D g_{t - lag}``: the base's descent keeps time with
   the contraction of the rest of the ventricle, or lags it by ``lag`` frames.
4. **The amplitude ``D`` and the lag are those the slices allow.** Each frame with
   ``|g| >= 0.05`` bounds ``D`` by its interval; ``D`` is the middle of the amplitudes
   every such frame allows, for the smallest lag (0 first, then in steps of a quarter of
   a frame up to 15 % of the frames, the profile interpolated between frames) for which
   one amplitude is allowed by all. Every frame's height is then held in its interval,
   so that a plane never leaves the slice its frame's cavity ends in. When no lag is
   consistent with every frame, each frame's plane is the middle of its interval and the
   estimate says so (``consistent``).

What this is worth against the truth (the synthetic cohort's ``valve_planes.csv`` and an
analytic ventricle) is measured in ``benchmarks/bench_base_planes.py`` and reported in
``docs/tracking.md``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from manifolds.data_terms.mesh_geometry import check_mesh

from ..imaging.label_images import ImageError
from ..imaging.plane_table import PLANES_FILE, write_plane_table
from ..imaging.surface_extraction import largest_component, voxel_extent
from ..volume import boundary_vertices

__all__ = [
    "BasePlaneEstimate",
    "THICK_RATIO",
    "estimate_base_planes",
    "gather_plane_table",
    "planes_wanted",
    "rim_plane",
    "thick_sliced",
]

#: A series is thick-sliced when its largest voxel spacing is at least this many times
#: its smallest (:func:`thick_sliced`).
THICK_RATIO = 2.0

#: Frames whose profile ``|g_t|`` is below this do not bound the amplitude.
_MIN_PROFILE = 0.05
#: The largest lag of the base's descent tried, as a fraction of the frames, and its step
#: in frames.
_MAX_LAG, _LAG_STEP = 0.15, 0.25
#: A column bounds the plane from above when its top cavity voxel lies this many voxels
#: inside the cavity's section (across the slices): its end is the base, not the wall.
_INTERIOR = 2


def rim_plane(vertices, faces) -> np.ndarray:
    """The plane of an open surface's rim: ``(x, y, z, nx, ny, nz)``, shape ``(6,)``.

    The centroid of the rim's vertices (those on boundary edges) and the unit normal of
    their least-squares plane, pointing away from the centroid of the surface's
    vertices (the side ``MeshingSettings.cut_plane`` removes).

    Raises
    ------
    ValueError
        A surface with fewer than three rim vertices (closed).
    """
    v = np.asarray(vertices, dtype=float)
    rim = boundary_vertices(faces)
    if len(rim) < 3:
        raise ValueError(f"rim_plane: expected an open surface, got {len(rim)} rim vertices")
    centre = v[rim].mean(axis=0)
    normal = np.linalg.svd(v[rim] - centre)[2][-1]
    if np.dot(centre - v.mean(axis=0), normal) < 0:
        normal = -normal
    return np.r_[centre, normal]


def thick_sliced(affine) -> bool:
    """Whether a grid's largest voxel spacing is at least :data:`THICK_RATIO` times its smallest."""
    spacing = np.linalg.norm(np.asarray(affine, dtype=float)[:3, :3], axis=0)
    return bool(spacing.max() >= THICK_RATIO * spacing.min())


def planes_wanted(settings, affine, faces, given) -> bool:
    """Whether a subject's valve planes are estimated from its images: none ``given``, an
    open ED mesh (``faces``: the estimate starts from its rim; a closed one, whose label
    was meshed without a valve plane, has none), and ``settings.estimate_planes``
    "always", or "auto" on a thick-sliced grid (``affine``)."""
    mode = getattr(settings, "estimate_planes", "never")
    if given or mode == "never" or len(boundary_vertices(faces)) == 0:
        return False
    return mode == "always" or thick_sliced(affine)


def gather_plane_table(output, subjects) -> Path | None:
    """``output/valve_planes.csv`` from the tracking records (``<subject>.json``) of the
    ``subjects`` whose planes were estimated; removed when none was. Returns its path."""
    planes = {}
    for subject in subjects:
        try:
            record = json.loads((Path(output) / f"{subject}.json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        estimated = record.get("estimated_planes") if record.get("status") == "ok" else None
        if isinstance(estimated, dict) and "planes" in estimated:
            planes[subject] = dict(enumerate(estimated["planes"]))
    path = Path(output) / PLANES_FILE
    if not planes:
        path.unlink(missing_ok=True)
        return None
    return write_plane_table(path, planes)


@dataclass
class BasePlaneEstimate:
    """Outcome of :func:`estimate_base_planes`.

    Attributes
    ----------
    planes : ndarray, shape (n_frames, 6)
        ``(x, y, z, nx, ny, nz)`` per frame, in the images' world frame (mm).
    heights : ndarray, shape (n_frames,)
        Each plane's height along the ED normal (mm).
    bounds : ndarray, shape (n_frames, 2)
        ``[h_t, h_t + e]``: the heights the frame's cavity allows.
    profile : ndarray, shape (n_frames,)
        ``g_t`` (0 at ED, 1 at the smallest volume below the base).
    descent : float
        ``D``, the plane's descent at ``g = 1`` (mm); NaN when not ``consistent``.
    lag : float
        The lag of the descent behind the profile, in frames; NaN when not ``consistent``.
    consistent : bool
        Whether one amplitude and lag agreed with every frame's interval (else every
        plane is the middle of its frame's interval).
    extent : float
        A voxel's extent along the ED normal (mm).
    """

    planes: np.ndarray
    heights: np.ndarray
    bounds: np.ndarray
    profile: np.ndarray
    descent: float
    lag: float
    consistent: bool
    extent: float

    def as_dict(self) -> dict:
        """JSON-ready: every field as lists and numbers."""
        return {"planes": self.planes.tolist(), "heights": self.heights.tolist(),
                "bounds": self.bounds.tolist(), "profile": self.profile.tolist(),
                "descent": self.descent, "lag": self.lag, "consistent": self.consistent,
                "extent": self.extent}  # fmt: skip


def _cavity(frame, label: int, normal: np.ndarray) -> tuple[np.ndarray, float, float]:
    """The heights ``n . x`` of the cavity's voxel centres and the bounds ``[low, high]`` of
    the plane's height (see the module)."""
    mask = np.asarray(frame.labels) == int(label)
    if not mask.any():
        where = f"{frame.path}{'' if frame.frame is None else f' frame {frame.frame}'}"
        raise ImageError(f"{where}: label {label} is absent: no valve plane can be estimated")
    mask = largest_component(mask)[0]
    affine = np.asarray(frame.affine, dtype=float)
    index = np.argwhere(mask)
    heights = (index @ affine[:3, :3].T + affine[:3, 3]) @ normal
    low = float(heights.max())
    rise = affine[:3, :3].T @ normal  # the height gained by one step along each voxel axis
    axis = int(np.argmax(np.abs(rise)))
    # the voxel axis across the slices last, pointing up (towards the base)
    column = np.moveaxis(mask, axis, -1)[..., :: 1 if rise[axis] > 0 else -1]
    above = np.ones_like(column)  # the grid's last slice has no voxel above: no bound
    above[..., :-1] = column[..., 1:]
    interior = ndimage.binary_erosion(column, np.ones((3, 3, 1), bool), iterations=_INTERIOR)
    ends = column & ~above & interior
    ends = np.moveaxis(ends[..., :: 1 if rise[axis] > 0 else -1], -1, axis)
    tops = np.argwhere(ends)
    if len(tops) == 0:
        return heights, low, low + voxel_extent(normal, affine)
    top_heights = (tops @ affine[:3, :3].T + affine[:3, 3]) @ normal
    return heights, low, max(low, float(top_heights.min() + abs(rise[axis])))


def _amplitude(base: float, bounds: np.ndarray, profile: np.ndarray):
    """``(D, lag)``: the middle of the amplitudes every frame's interval allows, for the
    smallest lag that allows one (see the module); None when no lag does."""
    frames = np.arange(len(profile), dtype=float)
    steps = int(_MAX_LAG * len(profile) / _LAG_STEP)
    for lag in sorted(_LAG_STEP * np.arange(-steps, steps + 1), key=lambda x: (abs(x), x < 0)):
        shifted = np.interp(frames - lag, frames, profile)
        use = np.abs(shifted) >= _MIN_PROFILE
        if not use.any():
            return 0.0, 0.0
        ends = (base - bounds[use]) / shifted[use, None]  # each frame's two ends of D
        low, high = ends.min(axis=1).max(), ends.max(axis=1).min()
        if low <= high:
            return float(0.5 * (low + high)), float(lag)
    return None


def estimate_base_planes(ed_vertices, faces, frames, label: int) -> BasePlaneEstimate:
    """Every frame's valve plane from its label image and the ED mesh's rim (see the module).

    Parameters
    ----------
    ed_vertices : array, shape (k, 3)
        The ED mesh in the images' world frame (mm), open at the base.
    faces : array of int, shape (f, 3)
    frames : sequence of LabelImage
        The series' frames (one grid), frame 0 at ED.
    label : int
        The cavity's label.

    Returns
    -------
    BasePlaneEstimate

    Raises
    ------
    ValueError
        A closed ED mesh (no rim), or no frame.
    ImageError
        The label absent from a frame (naming it).
    """
    v, f = check_mesh(ed_vertices, faces, "estimate_base_planes: ED mesh")
    frames = list(frames)
    if not frames:
        raise ValueError("estimate_base_planes: frames: no frame")
    ed_plane = rim_plane(v, f)
    normal = ed_plane[3:]
    extent = voxel_extent(normal, frames[0].affine)
    cavities = [_cavity(frame, label, normal) for frame in frames]
    heights = [c[0] for c in cavities]
    bounds = np.array([c[1:] for c in cavities])
    below = bounds[:, 0].min() + 1e-9 * extent
    volumes = np.array([np.count_nonzero(h <= below) for h in heights], dtype=float)
    span = volumes[0] - volumes.min()
    profile = (volumes[0] - volumes) / span if span > 0 else np.zeros(len(frames))
    base = float(np.clip(ed_plane[:3] @ normal, *bounds[0]))
    fit = _amplitude(base, bounds, profile)
    if fit is None:
        descent, lag, height = float("nan"), float("nan"), bounds.mean(axis=1)
    else:
        descent, lag = fit
        shifted = np.interp(np.arange(len(frames)) - lag, np.arange(len(frames)), profile)
        height = np.clip(base - descent * shifted, bounds[:, 0], bounds[:, 1])
    points = ed_plane[:3] + (height - ed_plane[:3] @ normal)[:, None] * normal
    planes = np.c_[points, np.tile(normal, (len(frames), 1))]
    return BasePlaneEstimate(planes, height, bounds, profile, descent, lag, fit is not None,
                             extent)  # fmt: skip
