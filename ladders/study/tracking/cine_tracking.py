"""Follow a mesh through cine intensity images by B-spline (FFD) image registration.

Two schemes (``CineTrackingSettings.reference``), with SimpleITK's free-form
deformation (a cubic B-spline transform on a grid of control points
``control_point_spacing`` mm apart; with ``affine_stage``, on top of an affine transform
fitted first, :mod:`.cine_registration`):

* ``"ed"`` (default): every frame ``t`` is registered to end-diastole (ED) directly,
  the B-spline started from the transform fitted at the neighbouring frame, along two
  chains: forward ``1, 2, ...`` to the middle of the cycle (or to ``es_frame``) and
  backward from the last frame. The ED vertices are moved by each frame's own
  transform, so that no error is composed from frame to frame (the idea of
  4Dsegment's refinement against ED, Duan et al., IEEE TMI 2019). ``n - 1``
  registrations for ``n`` frames; the two chains run at the same time with ``jobs``.
* ``"consecutive"``: the method of the UK Biobank motion pipeline (Bai et al., Nature
  Medicine 2020, ``ukbb_cardiac``):

  1. every pair of consecutive frames is registered, in both directions:
     ``k -> k + 1`` (forward) and ``k + 1 -> k`` (backward), the cycle being periodic
     (frame ``n`` is frame 0, ED);
  2. the forward transforms are composed from ED to frame ``t``
     (``0 -> 1 -> ... -> t``) and the backward ones from the next ED back to ``t``
     (``n = 0 -> n - 1 -> ... -> t``); the composition is evaluated at the mesh's
     points (each transform applied in turn), which is the exact composition at those
     points;
  3. the two estimates of each ED point's position at ``t`` are averaged with weights
     by the frame's position in the cycle, ``w_forward = 1 - t / n`` and
     ``w_backward = t / n`` (``combine="both"``), so that each chain counts most where
     it is short; ``combine="forward"`` keeps the forward chain only.

Conventions
-----------
* An image is a numpy array ``(X, Y, Z)`` with a 4 x 4 affine from voxel indices
  ``(i, j, k)`` to world millimetres (any orientation, spacing, flip or stack of thick
  slices). The SimpleITK image is built with the same index order (``array[i, j, k]`` is
  ITK index ``(i, j, k)``), origin ``affine[:3, 3]``, spacing the column norms of
  ``affine[:3, :3]`` and direction those columns normalised, so that ITK's physical
  space *is* the affine's world frame. ITK's own files use LPS and NIfTI's RAS; no
  file is read or written here, so no axis is flipped: every point given and returned
  is in the affine's world frame (RAS for a NIfTI affine, the synthetic ventricle's
  frame for :func:`~ladders.study.imaging.render_cine`).
* :func:`register_frames` ``(fixed, moving)`` returns the transform ``T`` that the
  optimiser fitted so that ``moving(T(x)) ~ fixed(x)``: ``T`` maps a point ``x`` of the
  fixed frame to the point of the moving frame showing the same material, i.e. it
  moves points *forward from the fixed frame to the moving frame*. Tracking from frame
  ``k`` to ``k + 1`` therefore registers ``fixed = frame k``, ``moving = frame k + 1``.
* Deterministic given the settings: the metric samples its voxels at random with a
  fixed ``seed`` (or uses every voxel with ``sampling_percentage=None``), and the
  registration runs on ``threads`` threads (1 by default; the result is reproducible
  for a fixed thread count on a given machine: ITK's global default number of threads,
  the machine's cores, also enters it).
"""

from __future__ import annotations

import numpy as np

from .cine_images import (
    _check_affine,
    _check_mask,
    _check_volume,
    _grid_affine,
    _mask_image,
    image_from_array,
    wall_mask,
)
from .cine_registration import identity_bspline
from .cine_registration import register_images as _register
from .cine_settings import CineTrackingSettings

__all__ = [
    "CineTrackingSettings",
    "register_frames",
    "track_cine",
    "image_from_array",
    "wall_mask",
    "identity_bspline",
]


def register_frames(
    fixed, moving, spacing, settings: CineTrackingSettings | None = None, mask=None
):
    """B-spline (FFD) registration of two frames: the transform from fixed to moving points.

    Parameters
    ----------
    fixed, moving : array (X, Y, Z)
        Intensities of two frames on the same grid.
    spacing : 3 floats or array (4, 4)
        The grid: voxel sizes in mm (axes aligned, origin 0) or the voxel-to-world affine.
    settings : CineTrackingSettings, optional
    mask : array (X, Y, Z) of 0 and 1, optional
        The voxels of the fixed frame the metric samples (e.g. :func:`wall_mask`);
        ``settings.sampling_percentage`` is then a fraction of them. None: every voxel
        (``settings.mask_distance`` is for :func:`track_cine`, which builds the mask).

    Returns
    -------
    SimpleITK.BSplineTransform or SimpleITK.CompositeTransform
        ``T`` with ``moving(T(x)) ~ fixed(x)``: ``T.TransformPoint(x)`` maps a world point
        ``x`` of the fixed frame to the same material point in the moving frame (points
        move forward from ``fixed`` to ``moving``). The B-spline's domain is the fixed
        image's extent; outside it the B-spline is the identity. With
        ``settings.affine_stage``, the composite ``A(B(x))`` of an affine ``A`` and the
        B-spline ``B`` (:mod:`.cine_registration`).

    Raises
    ------
    ValueError
        Naming ``fixed``, ``moving``, ``spacing``, ``settings`` or ``mask``.
    """
    settings = _check_settings(settings)
    a = _grid_affine(spacing)
    f = _check_volume(fixed, "fixed")
    m = _check_volume(moving, "moving")
    if f.shape != m.shape:
        raise ValueError(f"moving: shape {m.shape} differs from fixed's {f.shape}")
    fixed_image = image_from_array(f, a)
    if mask is not None:
        mask = _mask_image(_check_mask(mask, f.shape, "fixed"), fixed_image)
    return _register(fixed_image, image_from_array(m, a), settings, mask=mask)


def _check_settings(settings) -> CineTrackingSettings:
    if settings is None:
        return CineTrackingSettings()
    if not isinstance(settings, CineTrackingSettings):
        raise ValueError(
            f"settings: expected CineTrackingSettings or None, got {type(settings).__name__}"
        )
    return settings


def _check_series(series) -> np.ndarray:
    try:
        s = np.asarray(series, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(
            "series: expected a 4-D array (n_frames, X, Y, Z) of intensities"
        ) from None
    if s.ndim != 4:
        raise ValueError(f"series: expected a 4-D array (n_frames, X, Y, Z), got shape {s.shape}")
    if s.shape[0] < 2:
        raise ValueError(f"series: expected at least 2 frames, got {s.shape[0]}")
    if min(s.shape[1:]) < 2:
        raise ValueError(f"series: every spatial axis needs at least 2 voxels, got {s.shape}")
    if not np.isfinite(s).all():
        raise ValueError("series: NaN or infinite intensities")
    return s


def _check_vertices(vertices, affine, shape) -> np.ndarray:
    try:
        v = np.asarray(vertices, dtype=float)
    except (TypeError, ValueError):
        raise ValueError("ed_vertices: expected an array (k, 3) of points in mm") from None
    if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0:
        raise ValueError(f"ed_vertices: expected shape (k, 3) with k >= 1, got {v.shape}")
    if not np.isfinite(v).all():
        raise ValueError("ed_vertices: NaN or infinite coordinates")
    index = (v - affine[:3, 3]) @ np.linalg.inv(affine[:3, :3]).T
    outside = np.any((index < -0.5) | (index > np.asarray(shape) - 0.5), axis=1)
    if outside.any():
        first = int(np.argmax(outside))
        raise ValueError(
            f"ed_vertices: {int(outside.sum())} of {len(v)} points lie outside the image's "
            f"field of view (e.g. vertex {first} at {v[first].round(2).tolist()} mm, voxel "
            f"index {index[first].round(2).tolist()}, image shape {tuple(shape)})"
        )
    return v


def _check_es_frame(es_frame, n: int):
    if es_frame is None:
        return None
    ok = isinstance(es_frame, (int, np.integer)) and not isinstance(es_frame, bool)
    if not ok or not 1 <= es_frame <= n - 1:
        raise ValueError(
            f"es_frame: expected None or a frame index in [1, {n - 1}], got {es_frame!r}"
        )
    return int(es_frame)


def _forward_weights(n: int, es_frame: int | None) -> np.ndarray:
    """Weight of the forward chain at each frame (the backward one has ``1 - w``)."""
    t = np.arange(n, dtype=float)
    if es_frame is None:
        return 1.0 - t / n
    # piecewise linear through 1/2 at ES: the chains count equally at end-systole
    return np.where(t <= es_frame, 1.0 - 0.5 * t / es_frame, 0.5 * (n - t) / (n - es_frame))


def _register_pair(fixed, moving, affine, settings):
    return _register(image_from_array(fixed, affine), image_from_array(moving, affine), settings)


def _registrations(series, affine, pairs, settings: CineTrackingSettings) -> list:
    """The transforms of the frame pairs ``(fixed, moving)``, ``settings.jobs`` at a time."""
    if settings.jobs == 1 or len(pairs) < 2:
        images = [image_from_array(frame, affine) for frame in series]
        return [_register(images[i], images[j], settings) for i, j in pairs]
    from joblib import Parallel, delayed

    return Parallel(n_jobs=min(settings.jobs, len(pairs)))(
        delayed(_register_pair)(series[i], series[j], affine, settings) for i, j in pairs
    )


def _ed_chain(frames, affine, settings: CineTrackingSettings, mask=None) -> list:
    """Transforms from ``frames[0]`` (ED) to each later frame, each started from the last."""
    ed = image_from_array(frames[0], affine)
    mask_image = None if mask is None else _mask_image(mask, ed)  # one for the whole chain
    out, previous = [], None
    for frame in frames[1:]:
        previous = _register(ed, image_from_array(frame, affine), settings, previous, mask_image)
        out.append(previous)
    return out


def _ed_chains(series, affine, chains, settings: CineTrackingSettings, mask=None) -> dict:
    """``{t: transform ED -> t}`` over the frame chains, ``settings.jobs`` chains at a time."""
    if settings.jobs == 1 or len(chains) < 2:
        fitted = [_ed_chain(series[[0, *chain]], affine, settings, mask) for chain in chains]
    else:
        from joblib import Parallel, delayed

        fitted = Parallel(n_jobs=min(settings.jobs, len(chains)))(
            delayed(_ed_chain)(series[[0, *chain]], affine, settings, mask) for chain in chains
        )
    return {t: T for chain, ts in zip(chains, fitted) for t, T in zip(chain, ts)}


def _move(transform, points: np.ndarray) -> np.ndarray:
    return np.array([transform.TransformPoint(tuple(map(float, p))) for p in points])


def track_cine(
    series,
    affine,
    ed_vertices,
    settings: CineTrackingSettings | None = None,
    es_frame: int | None = None,
    mask=None,
) -> np.ndarray:
    """Move the ED mesh through every frame of a cine series by FFD registration.

    Each frame registered to ED, or consecutive frames composed
    (``settings.reference``; see the module's description).

    Parameters
    ----------
    series : array (n_frames, X, Y, Z)
        Intensities of one cardiac cycle, frame 0 at end-diastole (ED); the cycle is
        periodic (the frame after the last is frame 0).
    affine : array (4, 4)
        Voxel indices ``(i, j, k)`` to world mm, shared by the frames.
    ed_vertices : array (k, 3)
        The mesh at ED, world mm, inside the image's field of view.
    settings : CineTrackingSettings, optional
    es_frame : int, optional
        The end-systolic frame. With ``reference="ed"``: where the forward chain stops
        and the backward one starts (default: frame ``n // 2``). With
        ``reference="consecutive"``: None (default) gives the UK Biobank weights
        ``w_forward = 1 - t / n``; given, piecewise-linear weights from 1 at ED through
        1/2 at ``es_frame`` to 0 at the next ED, so that both chains count equally at
        ES. Ignored with ``combine="forward"``.
    mask : array (X, Y, Z) of 0 and 1, optional
        With ``reference="ed"``: the voxels of the ED frame the metric samples, in place
        of :func:`wall_mask` of ``ed_vertices`` within ``settings.mask_distance`` (e.g.
        to track more points than the wall's while sampling the wall).

    Returns
    -------
    ndarray of float64, shape (n_frames, k, 3)
        The vertices at every frame, world mm (frame 0 is ``ed_vertices``).

    Raises
    ------
    ValueError
        Naming ``series``, ``affine``, ``ed_vertices``, ``settings``, ``es_frame`` or
        ``mask``.
    """
    settings = _check_settings(settings)
    s = _check_series(series)
    a = _check_affine(affine)
    n = s.shape[0]
    v = _check_vertices(ed_vertices, a, s.shape[1:])
    es = _check_es_frame(es_frame, n)
    if mask is not None:
        if settings.reference != "ed":
            raise ValueError("mask: used with reference='ed' only (the fixed frame is ED)")
        mask = _check_mask(mask, s.shape[1:], "the series' frames")
    if settings.reference == "ed":
        if mask is None and settings.mask_distance is not None:  # around ED's wall
            mask = wall_mask(s.shape[1:], a, v, settings.mask_distance)
            if not mask.any():
                raise ValueError(
                    f"settings.mask_distance: no voxel centre lies within "
                    f"{settings.mask_distance:g} mm of an ED vertex; give a larger distance "
                    "or None (the whole image)"
                )
        if settings.combine == "forward":
            chains = [list(range(1, n))]
        else:  # forward to the middle (or ES), backward from the last frame over the rest
            middle = n // 2 if es is None else es
            chains = [list(range(1, middle + 1)), list(range(n - 1, middle, -1))]
        transforms = _ed_chains(s, a, [c for c in chains if c], settings, mask)
        out = np.empty((n, len(v), 3))
        out[0] = v
        for t in range(1, n):
            out[t] = _move(transforms[t], v)
        return out
    # fixed frame t - 1, moving frame t: points move t - 1 -> t (forward, t = 1 .. n - 1);
    # fixed frame t + 1 (mod n), moving frame t: t + 1 -> t (backward, t = n - 1 .. 1)
    pairs = [(t - 1, t) for t in range(1, n)]
    if settings.combine == "both":
        pairs += [((t + 1) % n, t) for t in range(n - 1, 0, -1)]
    transforms = dict(zip(pairs, _registrations(s, a, pairs, settings)))

    forward = np.empty((n, len(v), 3))
    forward[0] = v
    for t in range(1, n):
        forward[t] = _move(transforms[(t - 1, t)], forward[t - 1])
    if settings.combine == "forward":
        return forward

    backward = np.empty_like(forward)
    backward[0] = v
    current = v
    for t in range(n - 1, 0, -1):
        current = _move(transforms[((t + 1) % n, t)], current)
        backward[t] = current
    w = _forward_weights(n, es)[:, None, None]
    return w * forward + (1.0 - w) * backward
