"""Distances between points in correspondence, in the units of the paper's Table 1.

A point of shape ``point_shape`` is read as a set of *vertices*: its last axis
holds the coordinates of one vertex and its leading axes index the vertices,
so a landmark shape ``(k, d)`` has ``k`` vertices (its rows), a point of shape
``(a, b, d)`` has ``a * b`` vertices, and a 1-D point ``(d,)`` is a single vertex.
With ``D_i`` the Euclidean distance between corresponding vertices ``i`` of
``A`` and ``B`` (``k`` vertices):

* ``"rms"`` (the paper's unit, e.g. mm): ``sqrt(mean_i D_i^2) = ||A - B||_F / sqrt(k)``;
* ``"frobenius"``: ``||A - B||_F = sqrt(sum_i D_i^2)``;
* ``"mean"``: ``mean_i D_i``, the mean per-vertex distance.

For a 1-D point the three agree. Leading axes beyond ``point_shape`` are batch
axes: the distance broadcasts over them.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["DISTANCES", "point_distance"]

DISTANCES = ("rms", "frobenius", "mean")

Distance = Callable[[np.ndarray, np.ndarray], np.ndarray]


def point_distance(distance, point_shape) -> Distance:
    """The distance function ``(a, b) -> d(a, b)`` named by ``distance``.

    Parameters
    ----------
    distance : {"rms", "frobenius", "mean"} or callable
        A callable is returned unchanged.
    point_shape : tuple of int
        Shape of one point (e.g. ``(k, d)`` for landmark shapes).

    Returns
    -------
    callable
        ``(a, b) -> array`` over the batch axes of ``a - b`` (a float for single points).
    """
    if callable(distance):
        return distance
    if not isinstance(distance, str):
        raise TypeError(f"distance: expected one of {DISTANCES} or a callable, got {distance!r}")
    if distance not in DISTANCES:
        raise ValueError(f"distance: expected one of {DISTANCES} or a callable, got {distance!r}")
    nd = len(tuple(point_shape))
    if nd == 0:
        raise ValueError(f"point_shape: expected at least one axis, got {point_shape!r}")

    def per_vertex(a, b):
        """Distances ``D_i``, the vertex axes flattened into the last axis."""
        diff = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
        if diff.ndim < nd:
            raise ValueError(
                f"distance: points must have at least {nd} axes (point_shape "
                f"{tuple(point_shape)}), got shape {diff.shape}"
            )
        sq = (diff * diff).sum(axis=-1)
        return sq.reshape(sq.shape[: sq.ndim - (nd - 1)] + (-1,))

    def rms(a, b):
        return np.sqrt(per_vertex(a, b).mean(axis=-1))

    def frobenius(a, b):
        return np.sqrt(per_vertex(a, b).sum(axis=-1))

    def mean(a, b):
        return np.sqrt(per_vertex(a, b)).mean(axis=-1)

    return {"rms": rms, "frobenius": frobenius, "mean": mean}[distance]
