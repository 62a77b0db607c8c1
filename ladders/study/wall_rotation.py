"""Rotation about the long axis: the circumferential motion a twist changes, in degrees.

Tagged MRI and speckle tracking report the left ventricle's rotation per short-axis
level, and its twist (apical minus basal rotation). For points ``x`` that move to
``y``, :func:`rotation_about_axis` gives the signed angle between their offsets from
the long axis, both projected onto the short-axis plane:

* the axis runs through the apex and the base-plane centre; ``u`` is the unit
  vector from the base-plane centre to the apex;
* ``r_x = P (x - apex)`` and ``r_y = P (y - apex)`` with ``P = I - u u^T``;
* the angle is ``atan2(u . (r_x x r_y), r_x . r_y)``, in degrees, in ``(-180, 180]``:
  positive counter-clockwise as seen from the apex (right-handed about ``u``), the
  convention of the tagging literature, in which a normal apex turns counter-clockwise
  and a normal base clockwise during systole (Taber et al., 1996; Russel et al., 2009).
  The sense of turning is physical in any right-handed frame (scanner or patient
  coordinates); a mirrored mesh reverses it.

:func:`twist_angle` is the twist of the tagging literature: the mean rotation of the
apical points (normalised height from the apex ``h < 0.3``) minus that of the basal
ones (``h > 0.7``), ``h = (x - apex) . (base - apex) / |base - apex|^2``.

The angle of a point near the axis is ill-conditioned (a displacement ``e`` across
the axis turns it by about ``e / r`` radians), and undefined on it: points whose
distance to the axis is below ``min_radius`` get ``NaN``. The group tests leave such
vertices out (:func:`~ladders.study.sequences.compare_cycles`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["rotation_about_axis", "twist_angle"]


def _point(value, name: str) -> np.ndarray:
    p = np.asarray(value, dtype=np.float64)
    if p.shape != (3,) or not np.isfinite(p).all():
        raise ValueError(f"rotation_about_axis: {name}: expected 3 finite coordinates, got {p!r}")
    return p


def rotation_about_axis(start, moved, apex, base, min_radius: float = 5.0) -> np.ndarray:
    """Signed rotation of every point about the long axis (see the module), degrees.

    Parameters
    ----------
    start : array, shape (..., k, 3)
        The points before the motion (e.g. the atlas's vertices).
    moved : array, shape (..., k, 3)
        The same points after it; broadcast against ``start``.
    apex, base : array, shape (3,)
        The apex and the base-plane centre, which place the axis.
    min_radius : float, default 5.0
        Points of ``start`` closer to the axis than this (same unit, e.g. mm) get ``NaN``.

    Returns
    -------
    ndarray, shape: the broadcast shape of ``start`` and ``moved`` without its last axis
        Degrees in ``(-180, 180]``, positive counter-clockwise seen from the apex.

    Raises
    ------
    ValueError
        Points not of shape ``(..., 3)`` or not finite, landmarks not 3 finite
        coordinates or equal, a negative ``min_radius``.
    """
    apex, base = _point(apex, "apex"), _point(base, "base")
    length = np.linalg.norm(apex - base)
    if length == 0:
        raise ValueError("rotation_about_axis: apex and base: the same point, no axis")
    if not (np.isfinite(min_radius) and min_radius >= 0):
        raise ValueError(f"rotation_about_axis: min_radius: expected >= 0, got {min_radius}")
    arrays = []
    for name, value in (("start", start), ("moved", moved)):
        a = np.asarray(value, dtype=np.float64)
        if a.ndim < 1 or a.shape[-1] != 3:
            raise ValueError(f"rotation_about_axis: {name}: expected points (..., 3), got "
                             f"an array of shape {a.shape}")  # fmt: skip
        if not np.isfinite(a).all():
            raise ValueError(f"rotation_about_axis: {name}: not finite (NaN or inf)")
        arrays.append(a)
    u = (apex - base) / length
    off = [a - apex for a in arrays]
    rx, ry = (o - (o @ u)[..., None] * u for o in off)
    rx, ry = np.broadcast_arrays(rx, ry)
    angle = np.degrees(np.arctan2(np.cross(rx, ry) @ u, np.einsum("...d,...d->...", rx, ry)))
    return np.where(np.linalg.norm(rx, axis=-1) < min_radius, np.nan, angle)


def twist_angle(start, moved, apex, base, min_radius: float = 5.0, apical: float = 0.3,
                basal: float = 0.7):  # fmt: skip
    """Apical minus basal mean rotation about the long axis (see the module), degrees.

    Parameters
    ----------
    start : array, shape (k, 3)
        The points before the motion (e.g. a ventricle's end-diastolic vertices).
    moved : array, shape (..., k, 3)
        The same points after it (e.g. at end-systole); leading axes are batches.
    apex, base : array, shape (3,)
        The apex and the base-plane centre.
    min_radius : float, default 5.0
        Points closer to the axis than this are left out of the means.
    apical, basal : float, default 0.3 and 0.7
        The apical points have a normalised height below ``apical``, the basal ones
        above ``basal``.

    Returns
    -------
    float or ndarray, shape (...)
        Degrees; positive when the apex turns counter-clockwise (seen from the apex)
        relative to the base, as in a normal systole.

    Raises
    ------
    ValueError
        Bad points or landmarks (as :func:`rotation_about_axis`), ``start`` not
        ``(k, 3)``, or no point off the axis in the apical or the basal part.
    """
    rotation = rotation_about_axis(start, moved, apex, base, min_radius)
    start = np.asarray(start, dtype=np.float64)
    if start.ndim != 2:
        raise ValueError(f"twist_angle: start: expected points (k, 3), got {start.shape}")
    apex, base = np.asarray(apex, dtype=np.float64), np.asarray(base, dtype=np.float64)
    height = (start - apex) @ (base - apex) / np.sum((base - apex) ** 2)
    off = np.isfinite(rotation.reshape(-1, len(start))[0])
    parts = []
    for name, mask in (("apical", (height < apical) & off), ("basal", (height > basal) & off)):
        if not mask.any():
            raise ValueError(f"twist_angle: no {name} point {min_radius} or more from the axis")
        parts.append(rotation[..., mask].mean(axis=-1))
    out = parts[0] - parts[1]
    return float(out) if np.ndim(out) == 0 else out
