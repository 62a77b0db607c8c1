"""The peak inward motion of a wall-motion curve and its time, refined between frames.

:func:`curve_peaks` summarises every vertex's curve over one cycle, as
:func:`~.cycle_analysis.compare_cycles` tests it: the largest inward motion, refined
by the parabola through the peak frame and its two neighbours (the cycle is periodic),
and the parabola's vertex as the time to peak.
"""

from __future__ import annotations

import numpy as np

__all__ = ["curve_peaks"]


def curve_peaks(curves, fractions=None) -> tuple[np.ndarray, np.ndarray]:
    """Peak inward motion and its time, per curve.

    Parameters
    ----------
    curves : array, shape (..., n_frames, k)
        Normal motion ``n_t`` (negative inward) over one cycle (periodic).
    fractions : array, shape (n_frames,), optional
        The frames' times as fractions of the cycle (default ``t / n_frames``, evenly spaced).

    Returns
    -------
    peak : ndarray, shape (..., k)
        ``max_t (-n_t)`` refined by the parabola through the peak frame and its two
        neighbours (cyclically).
    time_to_peak : ndarray, shape (..., k)
        The parabola's vertex as a fraction of the cycle.
    """
    y = -np.asarray(curves, dtype=np.float64)
    n = y.shape[-2]
    if n < 3:
        raise ValueError(f"curves: expected at least 3 frames, got {n}")
    step = 1.0 / n
    if fractions is not None:
        fractions = np.asarray(fractions, dtype=np.float64)
        if fractions.shape != (n,) or not np.allclose(np.diff(fractions), step):
            raise ValueError(f"fractions: expected {n} evenly spaced times t / {n}")
    i = np.argmax(y, axis=-2)[..., None, :]
    centre = np.take_along_axis(y, i, axis=-2)[..., 0, :]
    before = np.take_along_axis(y, (i - 1) % n, axis=-2)[..., 0, :]
    after = np.take_along_axis(y, (i + 1) % n, axis=-2)[..., 0, :]
    curvature = before - 2.0 * centre + after
    safe = np.where(curvature < 0, curvature, -1.0)
    shift = np.where(curvature < 0, 0.5 * (before - after) / safe, 0.0)
    shift = np.clip(shift, -0.5, 0.5)
    peak = centre - 0.25 * (before - after) * shift
    time = ((i[..., 0, :] + shift) * step) % 1.0
    return peak, time
