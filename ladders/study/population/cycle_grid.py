"""The short-axis stack a whole-cycle cohort is rendered on.

One grid per subject, placed around its ED surface: ``in_plane`` mm in the short-axis plane,
``thickness`` mm between slices, a margin around the ventricle and room above the base for
the valve planes' motion.
"""

from __future__ import annotations

import numpy as np

from ..errors import CohortError
from ..imaging.voxelize import short_axis_affine

__all__ = ["cycle_grid"]

_MARGIN, _ABOVE_BASE = 15.0, 8.0  # mm around the ventricle, and above its base


def cycle_grid(ed, in_plane: float = 1.5, thickness: float = 8.0) -> tuple[np.ndarray, tuple]:
    """The affine ``(4, 4)`` and shape of a short-axis stack over an ED surface ``(k, 3)``."""
    for name, value in (("in_plane", in_plane), ("thickness", thickness)):
        if not (np.isfinite(value) and value > 0):
            raise CohortError(f"{name}: expected a voxel size > 0 mm, got {value!r}")
    ed = np.asarray(ed, dtype=float)
    low = ed.min(axis=0) - _MARGIN
    high = ed.max(axis=0) + np.array([_MARGIN, _MARGIN, _ABOVE_BASE])
    spacing = np.array([in_plane, in_plane, thickness])
    shape = tuple(int(n) for n in np.ceil((high - low) / spacing))
    return short_axis_affine(low, in_plane, thickness), shape
