"""The time course of the synthetic cycle: the frames' times and the fraction of the motion reached.

:func:`cycle_fraction` is the raised-cosine course ``f(t)`` of the whole cycle (0 at ED,
1 at ``t = es_phase``, 0 again at ``t = 1``), :func:`frame_times` the times of a cycle's
frames; :mod:`.cardiac_cycle` moves the volume by them and
:func:`~.planted_effect.frame_abnormality` delays a region's course.
"""

from __future__ import annotations

import numpy as np

from ..errors import CohortError

__all__ = ["check_n_frames", "cycle_fraction", "frame_times", "number"]


def number(value, name: str, accept, what: str) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = np.nan
    if isinstance(value, bool) or not (np.isfinite(x) and accept(x)):
        raise CohortError(f"{name}: expected {what}, got {value!r}")
    return x


def check_n_frames(n_frames) -> int:
    ok = isinstance(n_frames, (int, np.integer)) and not isinstance(n_frames, bool)
    if not ok or n_frames < 2:
        raise CohortError(f"n_frames: expected an integer >= 2, got {n_frames!r}")
    return int(n_frames)


def frame_times(n_frames: int) -> np.ndarray:
    """Times of the frames of a cycle, ``t_k = k / n_frames``, shape ``(n_frames,)``."""
    n = check_n_frames(n_frames)
    return np.arange(n) / n


def cycle_fraction(t, es_phase: float = 0.35):
    """Fraction of the end-systolic motion reached at time ``t`` of the cycle.

    Raised-cosine contraction from ED to ES, then raised-cosine relaxation back to ED::

        f(t) = (1 - cos(pi t / t_es)) / 2                      0 <= t <= t_es
        f(t) = (1 + cos(pi (t - t_es) / (1 - t_es))) / 2       t_es < t <= 1

    ``f`` is continuously differentiable and periodic (``f' = 0`` at ED and at ES). ``t``
    (float or array) is a fraction of the cycle in ``[0, 1]`` (frame ``k`` of ``n`` is at
    ``k / n``), ``es_phase`` the time of end-systole in ``(0, 1)``; returns ``f(t)`` in
    ``[0, 1]``, the shape of ``t``.
    """
    es = number(es_phase, "es_phase", lambda x: 0 < x < 1, "a fraction of the cycle in (0, 1)")
    try:
        tt = np.asarray(t, dtype=float)
    except (TypeError, ValueError):
        raise CohortError(f"t: expected times in [0, 1], got {t!r}") from None
    if not np.isfinite(tt).all() or np.any(tt < 0.0) or np.any(tt > 1.0):
        raise CohortError(f"t: expected times in [0, 1] (fractions of the cycle), got {t!r}")
    contraction = 0.5 * (1.0 - np.cos(np.pi * tt / es))
    relaxation = 0.5 * (1.0 + np.cos(np.pi * (tt - es) / (1.0 - es)))
    out = np.where(tt <= es, contraction, relaxation)
    return float(out) if out.ndim == 0 else out
