"""Synthetic cine images of the whole cycle: label and intensity images of a known motion.

A subject of the synthetic cohort gets a myocardium around its left-ventricle
cavity. At end-diastole (ED), in the subject's frame (apex at the origin, long axis
``+z``, mm), a point with cylindrical coordinates ``(rho, phi, z)`` is

* blood pool (label :data:`BLOOD_POOL` = 1, the cavity ``symladders mesh --label 1``
  meshes) when ``0 <= z <= c`` and ``rho < R(u, phi)``, the endocardium's radius at
  that height ``u = z / c`` (:func:`~ladders.study.cohort.synthetic_lv.lv_shapes`);
* myocardium (label :data:`MYOCARDIUM` = 2) when ``0 <= z <= c`` and
  ``R <= rho < R + w`` (the epicardium is the endocardium offset outward along the
  radial direction by the wall thickness ``w``, 9 mm by default), or below the apex
  inside the cap ``rho^2 / w^2 + z^2 / w_apex^2 < 1``, ``z < 0``, which closes it;
* background (label 0) otherwise: above the base plane ``z = c`` and outside.

At a fraction ``f`` of the end-systolic motion the images are rendered by pulling each
sample point back to ED with :func:`~ladders.study.cohort.cardiac_cycle.motion_inverse`
and classifying it there: :func:`render_labels` is the exact image of the known
deformation (the base is cut at the valve plane, the ED base plane moved by the
motion, which keeps the myocardium's volume: the wall thickens in systole while the
blood pool is ejected), and :func:`render_cine` an intensity image (blood bright,
myocardium dark, background mid-grey) with partial volume, noise and optional tagging
lines fixed in the material. :func:`write_series` writes the frames as one 4-D NIfTI file, which
:func:`~ladders.study.imaging.label_images.read_label_image` reads frame by frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import nibabel as nib
import numpy as np

from ..cohort.cardiac_cycle import motion_inverse
from ..cohort.planted_effect import MotionAbnormality
from ..cohort.synthetic_lv import SubjectParameters, lv_shapes
from .label_images import IMAGE_SUFFIXES, ImageError
from .rv_label import voxel_centres

__all__ = [
    "BACKGROUND",
    "BLOOD_POOL",
    "MYOCARDIUM",
    "TagGrid",
    "ed_labels",
    "tag_pattern",
    "render_labels",
    "render_cine",
    "write_series",
]

#: Labels of the rendered images.
BACKGROUND, BLOOD_POOL, MYOCARDIUM = 0, 1, 2
_CHUNK = 1 << 18  # points pulled back at once


@dataclass(frozen=True)
class TagGrid:
    """Tagging lines: dark planes ``x = k spacing`` and ``y = k spacing`` of the ED frame.

    In a short-axis slice they are a grid of dark lines that moves with the material.
    The intensity is multiplied by ``m(x) m(y)``, with
    ``m(s) = 1 - depth exp(-d(s)^2 / (2 sigma^2))``, ``d`` the distance to the nearest
    line and ``sigma = width / 2.355`` (``width`` is the full width at half depth).
    With ``axes=(0, 1, 2)`` the planes ``z = k spacing`` across the long axis are added
    (``m(x) m(y) m(z)``): 3-D tagging, whose planes move with the shortening along the
    long axis, as the in-plane grid does not; they show only in images whose
    through-plane resolution is finer than ``spacing``.

    Attributes
    ----------
    spacing : float
        Distance between lines, mm (default 7).
    width : float
        Full width at half depth of a line, mm (default 1.5).
    depth : float
        Intensity removed at a line's centre, in ``[0, 1]`` (default 0.8).
    axes : tuple of int
        The ED frame's axes across which the tag planes lie: ``(0, 1)`` (default, a grid
        in the short-axis planes) or ``(0, 1, 2)`` (3-D tagging); distinct, in 0..2.
    """

    spacing: float = 7.0
    width: float = 1.5
    depth: float = 0.8
    axes: tuple = (0, 1)

    def __post_init__(self):
        for name in ("spacing", "width"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ImageError(f"tagging.{name}: expected a length > 0 mm, got {value!r}")
        if not (np.isfinite(self.depth) and 0.0 <= self.depth <= 1.0):
            raise ImageError(f"tagging.depth: expected a fraction in [0, 1], got {self.depth!r}")
        try:
            axes = tuple(self.axes)
        except TypeError:
            axes = None
        if (not axes or len(set(axes)) != len(axes)
                or not all(isinstance(a, int | np.integer) and not isinstance(a, bool)
                           and 0 <= a <= 2 for a in axes)):  # fmt: skip
            raise ImageError(f"tagging.axes: expected distinct axes among 0, 1, 2, got "
                             f"{self.axes!r}")  # fmt: skip
        object.__setattr__(self, "axes", tuple(int(a) for a in axes))


def tag_pattern(points, tagging: TagGrid) -> np.ndarray:
    """The tag modulation (``m(x) m(y)``, times ``m(z)`` with 3-D tagging) at ED points,
    shape ``points.shape[:-1]``, in ``[0, 1]``."""
    x = np.asarray(points, dtype=float)
    sigma = tagging.width / (2.0 * np.sqrt(2.0 * np.log(2.0)))
    out = np.ones(x.shape[:-1])
    for axis in tagging.axes:
        s = x[..., axis] / tagging.spacing
        d = (s - np.round(s)) * tagging.spacing
        out = out * (1.0 - tagging.depth * np.exp(-0.5 * (d / sigma) ** 2))
    return out


def _positive(value, name: str) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = np.nan
    if isinstance(value, bool) or not (np.isfinite(x) and x > 0):
        raise ImageError(f"{name}: expected a length > 0 mm, got {value!r}")
    return x


def ed_labels(
    params: SubjectParameters,
    points,
    wall_thickness: float = 9.0,
    apex_thickness: float | None = None,
) -> np.ndarray:
    """Labels of points of the ED frame: 1 blood pool, 2 myocardium, 0 background.

    Parameters
    ----------
    params : SubjectParameters
    points : array, shape (..., 3)
        ED points in mm.
    wall_thickness : float, default 9.0
        Radial distance from the endocardium to the epicardium, mm.
    apex_thickness : float, optional
        Thickness of the cap below the apex, mm (default ``wall_thickness``).

    Returns
    -------
    ndarray of int16, shape ``points.shape[:-1]``
    """
    w = _positive(wall_thickness, "wall_thickness")
    w_apex = w if apex_thickness is None else _positive(apex_thickness, "apex_thickness")
    x = np.asarray(points, dtype=float)
    shape = x.shape[:-1]
    x = x.reshape(-1, 3)
    rho = np.hypot(x[:, 0], x[:, 1])
    phi = np.arctan2(x[:, 1], x[:, 0])
    z = x[:, 2]
    labels = np.zeros(len(x), dtype=np.int16)
    c = params.long_axis
    wall = (z >= 0.0) & (z <= c)
    if wall.any():
        theta = np.arccos(1.0 - z[wall] / c)
        ed, _ = lv_shapes(params, theta, phi[wall])
        radius = np.hypot(ed[:, 0], ed[:, 1])
        labels[wall] = np.where(
            rho[wall] < radius, BLOOD_POOL, np.where(rho[wall] < radius + w, MYOCARDIUM, 0)
        )
    cap = (z < 0.0) & ((rho / w) ** 2 + (z / w_apex) ** 2 < 1.0)
    labels[cap] = MYOCARDIUM
    return labels.reshape(shape)


def _check_grid(affine, shape) -> tuple[np.ndarray, tuple[int, int, int]]:
    try:
        a = np.asarray(affine, dtype=float)
    except (TypeError, ValueError):
        raise ImageError("affine: expected a 4 x 4 matrix of numbers") from None
    if a.shape != (4, 4) or not np.isfinite(a).all() or not np.allclose(a[3], [0, 0, 0, 1]):
        raise ImageError(
            f"affine: expected a finite 4 x 4 matrix with last row (0, 0, 0, 1), got shape {a.shape}"
        )
    if abs(np.linalg.det(a[:3, :3])) < 1e-9:
        raise ImageError("affine: singular (voxels of zero size)")
    try:
        dims = tuple(int(n) for n in shape)
        ok = len(dims) == 3 and all(n >= 1 for n in dims) and dims == tuple(shape)
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ImageError(
            f"shape: expected 3 positive integers (the affine maps 3 voxel indices), got {shape!r}"
        )
    return a, dims


def _pulled_back(params, points, f, abnormality):
    return np.concatenate(
        [motion_inverse(params, points[i : i + _CHUNK], f, abnormality)
         for i in range(0, len(points), _CHUNK)]
    )  # fmt: skip


def render_labels(
    params: SubjectParameters,
    affine,
    shape,
    f: float,
    abnormality: MotionAbnormality | None = None,
    wall_thickness: float = 9.0,
    apex_thickness: float | None = None,
) -> np.ndarray:
    """Label image at fraction ``f`` of the motion: each voxel centre's ED label.

    Parameters
    ----------
    params : SubjectParameters
    affine : array (4, 4)
        Voxel indices to the subject's frame, mm (e.g. :func:`short_axis_affine`).
    shape : (int, int, int)
    f : float
        Fraction of the end-systolic motion in ``[0, 1]`` (:func:`cycle_fraction`).
    abnormality : MotionAbnormality, optional
        A planted change of the motion (a patient's).
    wall_thickness, apex_thickness : float
        The myocardium (:func:`ed_labels`).

    Returns
    -------
    ndarray of int16, shape ``shape``
        0 background, 1 blood pool (LV cavity), 2 myocardium.

    Raises
    ------
    ImageError
        A bad ``affine`` or ``shape``.
    CohortError
        ``f`` outside ``[0, 1]`` or a motion that is not invertible.
    """
    a, dims = _check_grid(affine, shape)
    ed = _pulled_back(params, voxel_centres(a, dims), f, abnormality)
    return ed_labels(params, ed, wall_thickness, apex_thickness).reshape(dims)


def render_cine(
    params: SubjectParameters,
    affine,
    shape,
    f: float,
    rng: np.random.Generator | None = None,
    noise: float = 0.05,
    tagging: TagGrid | None = None,
    supersample: int = 3,
    abnormality: MotionAbnormality | None = None,
    wall_thickness: float = 9.0,
    apex_thickness: float | None = None,
    intensities: tuple[float, float, float] = (0.45, 1.0, 0.15),
    rician: bool = False,
) -> np.ndarray:
    """Intensity image at fraction ``f``: a synthetic cine (or tagged) frame.

    Each voxel is the mean over ``supersample^3`` sub-voxel points (a regular grid in
    index space) of ``intensities[label(X)] * tags(X)``, ``X`` the point pulled back
    to ED (partial volume); then noise of standard deviation ``noise`` is added,
    Gaussian, or Rician (the magnitude of a complex Gaussian) with ``rician=True``.

    Parameters
    ----------
    params : SubjectParameters
    affine : array (4, 4)
    shape : (int, int, int)
    f : float
        Fraction of the end-systolic motion in ``[0, 1]``.
    rng : numpy.random.Generator
        Draws of the noise (required when ``noise > 0``).
    noise : float, default 0.05
        Standard deviation of the noise, in the intensities' unit.
    tagging : TagGrid, optional
        Tagging lines fixed in the ED (material) coordinates.
    supersample : int, default 3
        Sub-voxel samples per axis (1: the voxel centre only).
    abnormality : MotionAbnormality, optional
    wall_thickness, apex_thickness : float
        The myocardium (:func:`ed_labels`).
    intensities : (float, float, float), default (0.45, 1.0, 0.15)
        Intensity of the background, the blood pool and the myocardium.
    rician : bool, default False

    Returns
    -------
    ndarray of float64, shape ``shape``
    """
    a, dims = _check_grid(affine, shape)
    n = supersample
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ImageError(f"supersample: expected an integer >= 1, got {supersample!r}")
    level = np.asarray(intensities, dtype=float)
    if level.shape != (3,) or not np.isfinite(level).all():
        raise ImageError(f"intensities: expected 3 finite numbers, got {intensities!r}")
    try:
        sd = float(noise)
    except (TypeError, ValueError):
        sd = np.nan
    if not (np.isfinite(sd) and sd >= 0):
        raise ImageError(f"noise: expected a standard deviation >= 0, got {noise!r}")
    if sd > 0 and not isinstance(rng, np.random.Generator):
        raise ImageError(f"rng: expected a numpy.random.Generator for the noise, got {rng!r}")
    if tagging is not None and not isinstance(tagging, TagGrid):
        raise ImageError(f"tagging: expected a TagGrid or None, got {type(tagging).__name__}")
    centres = voxel_centres(a, dims)
    offsets = (np.arange(n) + 0.5) / n - 0.5
    total = np.zeros(len(centres))
    for oi in offsets:
        for oj in offsets:
            for ok in offsets:
                ed = _pulled_back(params, centres + a[:3, :3] @ [oi, oj, ok], f, abnormality)
                value = level[ed_labels(params, ed, wall_thickness, apex_thickness)]
                if tagging is not None:
                    value = value * tag_pattern(ed, tagging)
                total += value
    image = (total / n**3).reshape(dims)
    if sd > 0:
        if rician:
            image = np.hypot(image + rng.normal(0.0, sd, dims), rng.normal(0.0, sd, dims))
        else:
            image = image + rng.normal(0.0, sd, dims)
    return image


def write_series(path, frames_images, affine) -> Path:
    """Write frames as one 4-D NIfTI image ``(x, y, z, t)`` with ``affine`` (sform and qform).

    Integer frames (labels) are written as int16 and read back by
    ``read_label_image(path, frame)``; float frames as float32.

    Parameters
    ----------
    path : str or Path
        ``.nii`` or ``.nii.gz``.
    frames_images : sequence of arrays of one shape (i, j, k), or array (t, i, j, k)
    affine : array (4, 4)
        Voxel indices to world mm, any (oblique, flipped, anisotropic such as a
        short-axis stack of :func:`short_axis_affine`).

    Returns
    -------
    Path
    """
    path = Path(path)
    if not path.name.lower().endswith(IMAGE_SUFFIXES):
        raise ImageError(f"path: expected a .nii or .nii.gz file name, got {path.name!r}")
    frames = [np.asarray(frame) for frame in frames_images]
    if not frames:
        raise ImageError("frames_images: no frame")
    if frames[0].ndim != 3:
        raise ImageError(f"frames_images: expected 3-D frames, frame 0 has shape {frames[0].shape}")
    a, dims = _check_grid(affine, frames[0].shape)
    for t, frame in enumerate(frames):
        if frame.shape != dims:
            raise ImageError(
                f"frames_images: frame {t} has shape {frame.shape}, frame 0 has {dims}"
            )
    data = np.stack(frames, axis=-1)
    if all(np.issubdtype(frame.dtype, np.integer) for frame in frames):
        if data.size and (data.min() < -32768 or data.max() > 32767):
            raise ImageError("frames_images: labels outside the int16 range")
        data = data.astype(np.int16)
    else:
        data = data.astype(np.float32)
        if not np.isfinite(data).all():
            raise ImageError("frames_images: NaN or infinite intensities")
    img = nib.Nifti1Image(data, a)
    img.set_sform(a, code=1)
    img.set_qform(a, code=1)
    img.header.set_xyzt_units("mm", "sec")
    path.parent.mkdir(parents=True, exist_ok=True)
    nib.save(img, str(path))
    return path
