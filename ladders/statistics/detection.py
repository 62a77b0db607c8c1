"""Scores of a detected region against a known one, and the binomial interval of a rate."""

from __future__ import annotations

import numpy as np
from scipy import stats

__all__ = ["detection_power", "dice", "binomial_interval"]


def _masks(detected, truth) -> tuple[np.ndarray, np.ndarray]:
    a, b = np.asarray(detected, dtype=bool), np.asarray(truth, dtype=bool)
    if a.shape != b.shape:
        raise ValueError(f"detected, truth: shapes {a.shape} and {b.shape} differ")
    return a, b


def detection_power(detected, truth) -> float:
    """The fraction of the true vertices that are detected (sensitivity)."""
    a, b = _masks(detected, truth)
    if not b.any():
        raise ValueError("truth: no true vertex, the detection power is undefined")
    return float((a & b).sum() / b.sum())


def dice(detected, truth) -> float:
    """Dice coefficient ``2 |A and B| / (|A| + |B|)`` (1 when both are empty)."""
    a, b = _masks(detected, truth)
    total = a.sum() + b.sum()
    return 1.0 if total == 0 else float(2.0 * (a & b).sum() / total)


def binomial_interval(successes: int, trials: int, confidence: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper-Pearson) interval of a proportion (``scipy.stats.binomtest``)."""
    if int(trials) < 1 or not 0 <= int(successes) <= int(trials):
        raise ValueError(f"successes, trials: expected 0 <= {successes} <= {trials}, trials >= 1")
    ci = stats.binomtest(int(successes), int(trials)).proportion_ci(confidence, method="exact")
    return float(ci.low), float(ci.high)
