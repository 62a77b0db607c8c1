"""The synthetic ventricle's true wall maps: the generator's own thickness and strains.

The synthetic label images (:func:`~ladders.study.imaging.render_labels`) put a
myocardium of radial thickness ``w`` (9 mm by default) around the cavity: at ED its
outer surface, the epicardium, is the endocardium moved outward by ``w`` along the
direction away from the long axis, ``rho = rho_e(u, phi) + w`` for ``0 <= z <= c``,
closed below the apex by the cap ``rho^2 / w^2 + z^2 / w_apex^2 = 1``; the motion
(:func:`~ladders.study.cohort.motion_forward`) moves it, the wall incompressible.

:func:`true_epicardium` is that surface at any fraction ``f`` of the motion,
triangulated finely (rings every half millimetre or so along the meridian and around):
its vertices lie on the true surface, and its distance to a point exceeds the true one
by at most the sagitta of its triangles, ``h^2 / (8 R)``, about 1e-3 mm here (``R``
the smallest radius of curvature, ``w_apex`` at the cap).

:func:`true_wall_maps` gives a subject's :class:`~.maps.WallMaps` of the truth, with
the definitions of :mod:`.thickness` and :mod:`.strain` applied to the generator's
exact surfaces instead of meshes:

* the thickness at every vertex and frame: the distance from the vertex's true position
  (the ED endocardium of :func:`~ladders.study.cohort.synthetic_lv.lv_shapes` moved by
  the motion) to :func:`true_epicardium` at that frame;
* the circumferential and longitudinal strain: the stretch of the ED directions of
  :mod:`.strain` through the exact surface map ``(theta, phi) -> x_f(theta, phi)``, its
  tangent map from central differences in ``theta`` and ``phi`` (second-order one-sided
  at the base, where the motion's fields stop), with ``e_c`` along ``dx/dphi`` (which
  is orthogonal to the long axis ``+z``: the circumferential direction exactly) and
  ``e_l = n x e_c``. At the apex point (``theta = 0``) the motion is not differentiable
  (its radial contraction depends on the direction of approach): its strains are NaN.
"""

from __future__ import annotations

import numpy as np

from ..cohort.cardiac_cycle import motion_forward
from ..cohort.planted_effect import MotionAbnormality
from ..cohort.synthetic_lv import SubjectParameters, lv_grid, lv_shapes
from ..surface_queries import closest_points
from .maps import WallMaps

__all__ = ["true_epicardium", "true_endocardium", "true_wall_maps"]

_STEP = 1e-5  # radians: the central differences of the surface map


def _check(params, wall_thickness, apex_thickness) -> tuple[float, float]:
    if not isinstance(params, SubjectParameters):
        raise ValueError(f"params: expected SubjectParameters, got {type(params).__name__}")
    w = float(wall_thickness)
    w_apex = w if apex_thickness is None else float(apex_thickness)
    if not (np.isfinite(w) and w > 0 and np.isfinite(w_apex) and w_apex > 0):
        raise ValueError(f"wall_thickness, apex_thickness: expected lengths > 0 mm, got "
                         f"{wall_thickness!r}, {apex_thickness!r}")  # fmt: skip
    return w, w_apex


def _moved(params, points, f, abnormality):
    return points if f == 0 else motion_forward(params, points, f, abnormality)


def true_endocardium(params: SubjectParameters, theta, phi, f: float = 0.0,
                     abnormality: MotionAbnormality | None = None) -> np.ndarray:  # fmt: skip
    """The endocardial points ``(theta, phi)`` (shape ``(k,)`` each) at fraction ``f``,
    shape ``(k, 3)``: :func:`lv_shapes`'s ED surface moved by the motion."""
    ed, _ = lv_shapes(params, np.asarray(theta, float), np.asarray(phi, float))
    return _moved(params, ed, float(f), abnormality)


def true_epicardium(
    params: SubjectParameters,
    f: float = 0.0,
    abnormality: MotionAbnormality | None = None,
    wall_thickness: float = 9.0,
    apex_thickness: float | None = None,
    n_around: int = 480,
    n_rings: int = 240,
) -> tuple[np.ndarray, np.ndarray]:
    """The true epicardium at fraction ``f`` of the motion, finely triangulated (see the module).

    Parameters
    ----------
    params : SubjectParameters
    f : float, default 0
        Fraction of the end-systolic motion in ``[0, 1]``.
    abnormality : MotionAbnormality, optional
        A patient's planted abnormality.
    wall_thickness, apex_thickness : float
        As :func:`~ladders.study.imaging.render_labels` (``apex_thickness`` defaults
        to ``wall_thickness``).
    n_around, n_rings : int
        Vertices per ring and rings along the meridian (from the cap's lowest point to
        the base), shared between the cap and the wall in proportion to their lengths.

    Returns
    -------
    vertices : ndarray, shape (1 + n_around n_rings, 3)
    faces : ndarray of int, shape (f, 3)
        Open at the base (the valve plane), outward normals.
    """
    w, w_apex = _check(params, wall_thickness, apex_thickness)
    n_around, n_rings = int(n_around), int(n_rings)
    if n_around < 3 or n_rings < 4:
        raise ValueError(f"n_around, n_rings: expected >= 3 and >= 4, got {n_around}, {n_rings}")
    cap_length = 0.5 * np.pi * np.sqrt(0.5 * (w**2 + w_apex**2))
    fine = np.linspace(0.0, 0.5 * np.pi, 2001)
    wall_length = np.sum(np.hypot(np.diff(params.radius * np.sin(fine)),
                                  np.diff(params.long_axis * np.cos(fine))))  # fmt: skip
    n_cap = int(np.clip(round(n_rings * cap_length / (cap_length + wall_length)), 1, n_rings - 2))
    _, _, faces = lv_grid(n_around, n_rings)
    phi = -2.0 * np.pi * np.arange(n_around) / n_around
    alpha = 0.5 * np.pi * np.arange(1, n_cap + 1) / (n_cap + 1)  # the cap, below z = 0
    theta = 0.5 * np.pi * np.arange(n_rings - n_cap) / (n_rings - n_cap - 1)  # the wall
    cap = np.stack([np.outer(w * np.sin(alpha), np.cos(phi)),
                    np.outer(w * np.sin(alpha), np.sin(phi)),
                    np.outer(-w_apex * np.cos(alpha), np.ones(n_around))], axis=-1)  # fmt: skip
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    endo, _ = lv_shapes(params, tt.ravel(), pp.ravel())
    rho = np.hypot(endo[:, 0], endo[:, 1]) + w
    wall = np.stack([rho * np.cos(pp.ravel()), rho * np.sin(pp.ravel()), endo[:, 2]], axis=-1)
    ed = np.concatenate([[[0.0, 0.0, -w_apex]], cap.reshape(-1, 3), wall])
    return _moved(params, ed, float(f), abnormality), faces


def _derivatives(params, theta, phi, f, abnormality):
    """``x``, ``dx/dtheta`` and ``dx/dphi`` of the endocardium at fraction ``f``, each (k, 3)."""
    h = _STEP
    at = lambda t, p: true_endocardium(params, t, p, f, abnormality)  # noqa: E731
    x = at(theta, phi)
    central = theta + h <= 0.5 * np.pi
    d_theta = np.empty_like(x)
    c = central
    d_theta[c] = (at(theta[c] + h, phi[c]) - at(theta[c] - h, phi[c])) / (2 * h)
    b = ~central  # the base: second-order backward differences
    if b.any():
        back1, back2 = at(theta[b] - h, phi[b]), at(theta[b] - 2 * h, phi[b])
        d_theta[b] = (3 * x[b] - 4 * back1 + back2) / (2 * h)
    d_phi = (at(theta, phi + h) - at(theta, phi - h)) / (2 * h)
    return x, d_theta, d_phi


def true_wall_maps(
    params: SubjectParameters,
    theta,
    phi,
    fractions,
    abnormality: MotionAbnormality | None = None,
    wall_thickness: float = 9.0,
    apex_thickness: float | None = None,
    n_around: int = 480,
    n_rings: int = 240,
) -> WallMaps:
    """A subject's true wall maps at the vertices ``(theta, phi)`` (see the module).

    Parameters
    ----------
    params : SubjectParameters
    theta, phi : array, shape (k,)
        The vertices' parametric coordinates (:func:`lv_grid`).
    fractions : array, shape (n_frames,)
        The motion's fraction at every frame (frame 0 the reference; 0 at ED).
    abnormality : MotionAbnormality, optional
    wall_thickness, apex_thickness : float
        The myocardium of the images (:func:`~ladders.study.imaging.render_labels`).
    n_around, n_rings : int
        The resolution of :func:`true_epicardium`.

    Returns
    -------
    WallMaps
        Thickness (mm), strains (NaN at the apex point ``theta = 0``), ``on_rim`` all
        False, ``epicardium`` the closest points on the true epicardium.
    """
    _check(params, wall_thickness, apex_thickness)
    theta = np.asarray(theta, dtype=np.float64)
    phi = np.asarray(phi, dtype=np.float64)
    if theta.ndim != 1 or theta.shape != phi.shape:
        raise ValueError(f"theta, phi: expected two arrays of shape (k,), got {theta.shape}, "
                         f"{phi.shape}")  # fmt: skip
    fractions = np.asarray(fractions, dtype=np.float64).ravel()
    x0, t0, p0 = _derivatives(params, theta, phi, fractions[0], abnormality)
    apex = theta == 0.0  # dx/dphi = 0 there: no direction (NaN strains)
    safe = np.where(apex[:, None], 1.0, p0)
    normal = np.cross(t0, safe)
    e_c = safe / np.linalg.norm(safe, axis=1, keepdims=True)
    e_l = np.cross(normal / np.linalg.norm(normal, axis=1, keepdims=True), e_c)
    g11, g12, g22 = (np.einsum("ij,ij->i", a, b) for a, b in ((t0, t0), (t0, p0), (p0, p0)))
    det = np.where(apex, 1.0, g11 * g22 - g12**2)

    def coefficients(e):
        r1, r2 = np.einsum("ij,ij->i", t0, e), np.einsum("ij,ij->i", p0, e)
        return (g22 * r1 - g12 * r2) / det, (g11 * r2 - g12 * r1) / det

    (ac, bc), (al, bl) = coefficients(e_c), coefficients(e_l)
    n = len(fractions)
    thick, circ, lon = (np.empty((n, len(theta))) for _ in range(3))
    points = np.empty((n, len(theta), 3))
    for i, f in enumerate(fractions):
        x, dt, dp = _derivatives(params, theta, phi, f, abnormality)
        ev, ef = true_epicardium(params, f, abnormality, wall_thickness, apex_thickness, n_around,
                                 n_rings)  # fmt: skip
        points[i], thick[i], _ = closest_points(x, ev, ef)
        circ[i] = np.linalg.norm(ac[:, None] * dt + bc[:, None] * dp, axis=1) - 1.0
        lon[i] = np.linalg.norm(al[:, None] * dt + bl[:, None] * dp, axis=1) - 1.0
    circ[:, apex], lon[:, apex] = np.nan, np.nan
    return WallMaps(thick, circ, lon, np.zeros(thick.shape, dtype=bool), points)
