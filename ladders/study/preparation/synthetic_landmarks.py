"""Anatomical landmarks of the synthetic left ventricle: the truth a landmark table holds.

On the synthetic cohort's grid (:func:`~ladders.study.cohort.synthetic_lv.lv_grid`)
the apex is vertex 0, the base plane's centre is the point of the model's long
axis (``+z`` through the apex) at the height of the last ring (the open base; the
ring's own centroid lies off the axis by up to a degree and a half for a
subject whose wall has a first azimuthal harmonic) and the septum is at longitude 180 degrees (``-x``, the AHA
convention of :mod:`~ladders.study.cohort.aha_segments`); the septal point is
the vertex of that longitude on the ring nearest mid-height (``u = 0.55``, the
mid-cavity ring). The same vertices give the landmarks of the atlas and of
every subject, so a subject's landmarks are the material points of the atlas's.
"""

from __future__ import annotations

import numpy as np

from ..cohort.synthetic_lv import grid_shape, lv_grid
from ..errors import CohortError
from .landmarks import Landmarks

__all__ = ["SEPTAL_HEIGHT", "landmark_vertices", "synthetic_landmarks"]

#: Normalised height ``u`` (0 apex, 1 base) of the septal point.
SEPTAL_HEIGHT = 0.55


def landmark_vertices(n_vertices: int) -> tuple[int, np.ndarray, int]:
    """``(apex, base ring, septum)`` vertex indices of the synthetic grid of ``n_vertices``."""
    n_lon, n_lat = grid_shape(n_vertices)
    if 1 + n_lon * n_lat != n_vertices:
        raise CohortError(
            f"landmarks: {n_vertices} vertices is not a synthetic grid (1 + n_lon n_lat)"
        )
    theta, phi, _ = lv_grid(n_lon, n_lat)
    u = 1.0 - np.cos(theta)
    ring = 1 + np.arange(n_lat) * n_lon
    j = int(np.argmin(np.abs(u[ring] - SEPTAL_HEIGHT)))
    members = ring[j] + np.arange(n_lon)
    gap = np.abs(np.angle(np.exp(1j * (phi[members] - np.pi))))
    septum = int(members[np.argmin(gap)])
    base = 1 + (n_lat - 1) * n_lon + np.arange(n_lon)
    return 0, base, septum


def synthetic_landmarks(vertices) -> Landmarks:
    """The landmarks of a synthetic mesh ``(k, 3)`` (atlas or subject) in the generator's
    frame (long axis ``+z``; move them with the mesh afterwards)."""
    v = np.asarray(vertices, dtype=float)
    apex, base, septum = landmark_vertices(len(v))
    centre = v[apex] + np.array([0.0, 0.0, v[base, 2].mean() - v[apex, 2]])
    return Landmarks(v[apex], centre, v[septum])
