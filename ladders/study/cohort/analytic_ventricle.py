"""An analytic left-ventricular cavity of known motion, independent of the synthetic model.

A ground truth for label-series tracking and for the valve planes, with nothing in
common with :mod:`.synthetic_lv` but the orientation (apex at the origin, long axis
``+z``). At end-diastole the cavity is the part of the prolate spheroid

    ``(x^2 + y^2) / a^2 + (z - L)^2 / L^2 <= 1``

below its valve plane, the plane through ``(0, 0, L)`` turned by ``tilt`` degrees about
the ``x`` axis (normal ``(0, -sin tilt, cos tilt)``). Its motion keeps the apex fixed:

    ``z' = (1 - s f_l(t)) z``,   ``(x', y') = (1 - r f_r(t) (1 + g (1 - 2 z / L))) (x, y)``

a uniform longitudinal shortening ``s`` and a radial contraction ``r`` that grows by
``g`` towards the apex, with time courses ``f_r`` (:meth:`AnalyticVentricle.fraction`:
a raised cosine to end-systole at ``es_time``, a rapid filling over ``filling`` of the
cycle, then rest) and ``f_l``, the same delayed by ``delay`` of the cycle (the base's
descent lagging the contraction). The motion and its inverse are in closed form, so a
label image is exact at every voxel centre (:meth:`AnalyticVentricle.labels`), a mesh
of the ED cavity's wall (:meth:`AnalyticVentricle.mesh`, open at the valve plane) moves
with the material, and the valve plane of every frame is the least-squares plane of the
moved rim (:func:`~ladders.study.tracking.base_planes.rim_plane`, as the synthetic
cohort's ``valve_planes.csv``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import CohortError

__all__ = ["AnalyticVentricle"]


@dataclass(frozen=True)
class AnalyticVentricle:
    """The analytic cavity and its motion (see the module); lengths in mm, angles in degrees.

    Attributes
    ----------
    radius, length : float
        ``a`` and ``L``: the spheroid's equatorial radius and half axis (apex to centre).
    tilt : float
        The valve plane's turn about ``x``.
    radial, radial_gradient, shortening : float
        ``r``, ``g`` and ``s`` at end-systole.
    es_time, filling, delay : float
        Fractions of the cycle: end-systole, the rapid filling's length, the lag of the
        longitudinal time course behind the radial one.
    """

    radius: float = 27.0
    length: float = 80.0
    tilt: float = 12.0
    radial: float = 0.3
    radial_gradient: float = 0.3
    shortening: float = 0.15
    es_time: float = 0.35
    filling: float = 0.3
    delay: float = 0.0

    def __post_init__(self):
        for name in ("radius", "length"):
            if not getattr(self, name) > 0:
                raise CohortError(f"AnalyticVentricle: {name}: expected > 0 mm")
        if not 0 < self.es_time < 1 or not 0 < self.filling <= 1 - self.es_time:
            raise CohortError("AnalyticVentricle: es_time, filling: expected 0 < es_time < 1 and "
                              "0 < filling <= 1 - es_time")  # fmt: skip
        lowest = 1 - self.radial * (1 + abs(self.radial_gradient))
        if not (0 <= self.shortening < 1 and 0 <= self.radial and lowest > 0):
            raise CohortError("AnalyticVentricle: radial, radial_gradient, shortening: the "
                              "motion must keep every length positive")  # fmt: skip

    @property
    def plane_normal(self) -> np.ndarray:
        """The ED valve plane's unit normal, away from the apex."""
        t = np.radians(self.tilt)
        return np.array([0.0, -np.sin(t), np.cos(t)])

    def fraction(self, t, delay: float = 0.0) -> np.ndarray:
        """``f(t - delay)``: 0 at ED, 1 at end-systole, back to 0 after the rapid filling."""
        t = np.mod(np.asarray(t, dtype=float) - delay, 1.0)
        rise = 0.5 * (1 - np.cos(np.pi * np.clip(t / self.es_time, 0, 1)))
        fall = 0.5 * (1 + np.cos(np.pi * np.clip((t - self.es_time) / self.filling, 0, 1)))
        return np.where(t <= self.es_time, rise, fall)

    def _factors(self, t) -> tuple[float, float]:
        return (float(self.radial * self.fraction(t)),
                float(self.shortening * self.fraction(t, self.delay)))  # fmt: skip

    def motion(self, points, t: float) -> np.ndarray:
        """ED points ``(..., 3)`` moved to time ``t`` (a fraction of the cycle)."""
        x = np.asarray(points, dtype=float)
        r, s = self._factors(t)
        k = 1 - r * (1 + self.radial_gradient * (1 - 2 * x[..., 2] / self.length))
        return np.stack([k * x[..., 0], k * x[..., 1], (1 - s) * x[..., 2]], axis=-1)

    def pullback(self, points, t: float) -> np.ndarray:
        """Points ``(..., 3)`` at time ``t`` brought back to ED (the inverse of :meth:`motion`)."""
        y = np.asarray(points, dtype=float)
        r, s = self._factors(t)
        z = y[..., 2] / (1 - s)
        k = 1 - r * (1 + self.radial_gradient * (1 - 2 * z / self.length))
        return np.stack([y[..., 0] / k, y[..., 1] / k, z], axis=-1)

    def inside(self, points) -> np.ndarray:
        """Whether ED points ``(..., 3)`` lie in the cavity (below the valve plane)."""
        x = np.asarray(points, dtype=float)
        a, c = self.radius, self.length
        spheroid = (x[..., 0] ** 2 + x[..., 1] ** 2) / a**2 + (x[..., 2] - c) ** 2 / c**2 <= 1
        below = (x - np.array([0.0, 0.0, c])) @ self.plane_normal <= 0
        return spheroid & below

    def labels(self, affine, shape, t: float) -> np.ndarray:
        """The label image at time ``t`` (1 cavity, 0 elsewhere) on a grid ``affine`` (4 x 4), ``shape``."""
        a = np.asarray(affine, dtype=float)
        index = np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"), axis=-1)
        world = index @ a[:3, :3].T + a[:3, 3]
        return self.inside(self.pullback(world, t)).astype(np.int16)

    def mesh(self, rings: int = 24, segments: int = 48) -> tuple[np.ndarray, np.ndarray]:
        """The ED cavity's wall, open at the valve plane: vertices ``(k, 3)``, faces ``(f, 3)``.

        A vertex at the apex and ``rings`` rings of ``segments`` vertices, evenly spaced in
        the spheroid's polar angle from the apex up to the plane; the last ring is the rim.
        Outward normals.
        """
        a, c, tilt = self.radius, self.length, np.radians(self.tilt)
        phi = np.linspace(0, 2 * np.pi, segments, endpoint=False)
        top = np.arctan2(c * np.cos(tilt), -a * np.sin(tilt) * np.sin(phi))  # the plane's angle
        theta = np.outer(np.arange(1, rings + 1) / rings, top)
        ring = np.stack([a * np.sin(theta) * np.cos(phi), a * np.sin(theta) * np.sin(phi),
                         c * (1 - np.cos(theta))], axis=-1).reshape(-1, 3)  # fmt: skip
        vertices = np.r_[np.zeros((1, 3)), ring]
        j = np.arange(segments)
        nxt = (j + 1) % segments
        faces = [np.c_[np.zeros(segments, int), 1 + nxt, 1 + j]]
        for i in range(rings - 1):
            lo, hi = 1 + i * segments, 1 + (i + 1) * segments
            faces += [np.c_[lo + j, lo + nxt, hi + j], np.c_[lo + nxt, hi + nxt, hi + j]]
        return vertices, np.concatenate(faces).astype(np.int64)

    def times(self, n_frames: int) -> np.ndarray:
        """Frame ``k`` of ``n_frames`` at ``k / n_frames`` of the cycle (frame 0 at ED)."""
        return np.arange(n_frames) / n_frames
