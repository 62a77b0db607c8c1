"""The whole cardiac cycle of the synthetic ventricle: a time course and a motion of the volume.

:func:`~ladders.study.cohort.synthetic_lv.lv_shapes` gives a subject's end-diastole (ED)
and end-systole (ES). :func:`cycle_fraction` is the time course ``f(t)`` (0 at ED, 1 at
``t = es_phase``, 0 again at ``t = 1``); :func:`motion_forward` moves any point of the ED
volume to its place at fraction ``f`` and :func:`motion_inverse` brings it back;
:func:`check_invertible` refuses a motion that folds the volume; :func:`cycle_frames`
gives the surface at every frame (a cohort's: :mod:`ladders.study.population.cycle_cohort`).

The map of a point ``(rho, phi, z)`` (cylindrical, mm), ``u = clip(z / c, 0, 1)``, with the
fields ``r``, ``l``, ``psi`` of :func:`lv_shapes` (and the planted modulation, if any) and
the ED endocardial radius ``rho_e(u, phi)``, ``rho_e' = (1 - f r) rho_e``::

    z' = (1 - f l) z,    phi' = phi + f psi,
    rho' = (1 - f r) rho                          rho <= rho_e   (blood pool)
    rho'^2 = rho_e'^2 + (rho^2 - rho_e^2) / J     rho > rho_e    (wall and beyond)

``J = det d(z', phi')/d(z, phi)`` (``dz'/dz = 1 - f l`` without a modulation): outside
the endocardium the volume is kept, the wall is incompressible and thickens; ``f = 1``
moves the ED endocardium onto the ES surface. Below the apex and above the base the
fields are those of ``u = 0`` and ``u = 1``, ``rho_e = 0`` below the apex (the cap widens
as it shortens). See ``docs/evidence/synthetic_cohort.md`` ("The whole cycle").
"""

from __future__ import annotations

from dataclasses import replace
from functools import lru_cache

import numpy as np

from ..errors import CohortError
from .planted_effect import SCALED, MotionAbnormality, frame_abnormality, planted_modulation
from .synthetic_lv import SubjectParameters, lv_shapes
from .time_course import check_n_frames, cycle_fraction, frame_times, number

__all__ = [
    "cycle_fraction",
    "frame_abnormality",
    "frame_times",
    "motion_forward",
    "motion_inverse",
    "check_invertible",
    "cycle_frames",
]

_NEWTON_TOL = 1e-14  # residual of the inverse, in units of the long axis and in radians
_NEWTON_ITERATIONS = 60
_FD_STEP = 1e-7
_ON_SURFACE = 1e-13  # rho^2 - rho_e^2 below this (relative) is on the endocardium
_SLOPE_STEP = 1e-4  # central differences of the modulation, in u and in radians


def _check_f(f) -> float:
    return number(f, "f", lambda x: 0 <= x <= 1, "a fraction of the end-systolic motion in [0, 1]")


def _check_inputs(params, abnormality) -> None:
    if not isinstance(params, SubjectParameters):
        raise CohortError(f"params: expected SubjectParameters, got {type(params).__name__}")
    if not (np.isfinite(params.long_axis) and params.long_axis > 0):
        raise CohortError(f"params: long_axis must be > 0 mm, got {params.long_axis!r}")
    if abnormality is not None and not isinstance(abnormality, MotionAbnormality):
        raise CohortError(
            f"abnormality: expected a MotionAbnormality or None, got {type(abnormality).__name__}"
        )
    if abnormality is not None and abnormality.kind == "delay":
        raise CohortError(
            "abnormality: a delay depends on the time of the cycle, not on the fraction f of "
            "the motion: give frame_abnormality(abnormality, t, es_phase)"
        )


def _check_points(points) -> np.ndarray:
    try:
        x = np.asarray(points, dtype=float)
    except (TypeError, ValueError):
        raise CohortError("points: expected an array of 3-D points, shape (..., 3)") from None
    if x.ndim < 1 or x.shape[-1] != 3 or not np.isfinite(x).all():
        raise CohortError(f"points: expected finite coordinates of shape (..., 3), got {x.shape}")
    return x


def _fields(params: SubjectParameters, u, phi, abnormality):
    """``r``, ``l`` and ``psi`` (radians) at heights ``u`` and longitudes ``phi`` (as lv_shapes)."""
    r = (
        params.radial_contraction
        * (1.0 + params.contraction_heterogeneity * np.cos(phi - params.heterogeneity_phase))
        * (1.0 + params.contraction_gradient * (1.0 - 2.0 * u))
    )
    shortening = np.full_like(u, params.longitudinal_shortening)
    psi_deg = params.apex_rotation * (1.0 - u) - params.base_rotation * u
    if abnormality is not None:
        modulation = planted_modulation(abnormality, np.arccos(1.0 - u), phi)
        r = r * modulation.radial
        shortening = shortening * modulation.longitudinal
        if modulation.rotation is not None:
            psi_deg = psi_deg * modulation.rotation
        psi_deg = psi_deg + modulation.twist
    return r, shortening, np.deg2rad(psi_deg)


def _endocardium(params: SubjectParameters, u, phi):
    """The ED endocardial radius ``rho_e(u, phi)`` of :func:`lv_shapes`, 0 at the apex."""
    s = np.sqrt(u * (2.0 - u))  # sin(theta), cos(theta) = 1 - u
    m = np.arange(1, len(params.harmonics) + 1)[:, None]
    h = np.asarray(params.harmonics)
    wave = (h[:, :1] * np.cos(m * phi) + h[:, 1:] * np.sin(m * phi)).sum(axis=0)
    return params.radius * s * (1.0 + 2.0 * params.bulge * s * (1.0 - u) + s * wave)


def _coupled(abnormality) -> bool:
    """Whether the shortening or the rotation depends on the longitude (no closed-form inverse)."""
    return abnormality is not None and abnormality.kind != "radial"


def _slopes(abnormality: MotionAbnormality, u, phi):
    """The modulation's rotation factor, and the derivatives in ``u`` and ``phi`` of its
    longitudinal factor, twist (deg) and rotation factor."""

    def mod(uu, pp):
        m = planted_modulation(abnormality, np.arccos(1.0 - uu), pp)
        rotation = np.ones_like(m.twist) if m.rotation is None else m.rotation
        return m.longitudinal, m.twist, rotation

    e = _SLOPE_STEP
    up, um = np.minimum(u + e, 1.0), np.maximum(u - e, 0.0)
    (lo_p, tw_p, ro_p), (lo_m, tw_m, ro_m) = mod(up, phi), mod(um, phi)
    (lo_q, tw_q, ro_q), (lo_n, tw_n, ro_n) = mod(u, phi + e), mod(u, phi - e)
    du, dphi = up - um, 2 * e
    rotation = mod(u, phi)[2]
    return ((lo_p - lo_m) / du, (lo_q - lo_n) / dphi, (tw_p - tw_m) / du, (tw_q - tw_n) / dphi,
            rotation, (ro_p - ro_m) / du, (ro_q - ro_n) / dphi)  # fmt: skip


def _jacobian(params, f, s, chi, shortening, slopes):
    """``J = det d(z'/c, phi')/d(z/c, phi)`` and ``d phi'/d phi`` (``chi``: u is not clipped)."""
    lon_u, lon_phi, tw_u, tw_phi, rot, rot_u, rot_phi = slopes
    l0, a, b = params.longitudinal_shortening, params.apex_rotation, params.base_rotation
    u = np.clip(s, 0.0, 1.0)
    psi0 = a * (1.0 - u) - b * u  # degrees, before the modulation's factor
    psi_u = np.deg2rad(tw_u + rot_u * psi0 - rot * (a + b))
    turn = 1.0 + f * np.deg2rad(tw_phi + rot_phi * psi0)
    stretch = 1.0 - f * shortening - f * s * l0 * lon_u * chi
    return stretch * turn + f * f * s * l0 * lon_phi * psi_u * chi, turn


def _area_factor(params, s, phi, f, shortening, abnormality):
    """``J`` at heights ``s = z / c`` and longitudes ``phi`` (``1 - f l`` unless coupled)."""
    if not _coupled(abnormality):
        return 1.0 - f * shortening
    slopes = _slopes(abnormality, np.clip(s, 0.0, 1.0), phi)
    return _jacobian(params, f, s, (s > 0.0) & (s < 1.0), shortening, slopes)[0]


@lru_cache(maxsize=64)
def _modulation_grid(abnormality: MotionAbnormality):
    """The modulation's longitudinal factor and its and the twist's slopes on a fine grid."""
    if abnormality.kind == SCALED and abnormality.magnitude != 1.0:
        # linear in the magnitude: the grid of the unit scaling, rescaled (a delay's frames)
        u, phi, unit, slopes = _modulation_grid(replace(abnormality, magnitude=1.0))
        m = abnormality.magnitude
        lon = 1.0 - m * (1.0 - unit)
        lon_u, lon_phi, tw_u, tw_phi, _, rot_u, rot_phi = slopes
        return u, phi, lon, (m * lon_u, m * lon_phi, tw_u, tw_phi, lon, m * rot_u, m * rot_phi)
    h, a = abnormality.transition_height, abnormality.transition_angle
    n_u = int(min(4001, max(201, np.ceil(8.0 / h) + 1)))
    n_phi = int(min(7200, max(360, np.ceil(8.0 * 360.0 / a))))
    u, phi = np.meshgrid(
        np.linspace(0.0, 1.0, n_u), np.linspace(-np.pi, np.pi, n_phi, endpoint=False), indexing="ij"
    )
    u, phi = u.ravel(), phi.ravel()
    lon = planted_modulation(abnormality, np.arccos(1.0 - u), phi).longitudinal
    return u, phi, lon, _slopes(abnormality, u, phi)


def check_invertible(
    params: SubjectParameters, f: float = 1.0, abnormality: MotionAbnormality | None = None
) -> float:
    """Refuse a motion at fraction ``f`` that is not a bijection of space; return its margin.

    The map is triangular: ``(z, phi) -> (z', phi')`` does not involve ``rho``, and the
    radius is mapped monotonically when ``1 - f r > 0`` and ``J > 0``. Checked: the
    largest radial contraction ``r0 (1 + |delta|)(1 + |gamma|)`` (a planted reduction
    only lowers it) and the shortening satisfy ``f r < 1`` and ``f l < 1``; when the
    abnormality makes ``l`` or ``psi`` depend on the longitude, ``J`` and
    ``d phi' / d phi`` are positive on a grid of heights and longitudes finer than
    its transitions (a sharp transition, width 0, is refused: it tears the volume).
    Returns the smallest of ``1 - f r``, ``1 - f l`` and ``J`` (positive); raises
    :class:`CohortError` naming ``params`` or ``abnormality``, with where it folds.
    """
    _check_inputs(params, abnormality)
    f = _check_f(f)
    p = params
    gain = 1.0  # the largest factor of the motion a modulation applies (a scaling above 1)
    if abnormality is not None and abnormality.kind == SCALED:
        gain = max(1.0, 1.0 - abnormality.magnitude)
    r_max = gain * max(
        p.radial_contraction * (1.0 + s1 * abs(p.contraction_heterogeneity))
        * (1.0 + s2 * abs(p.contraction_gradient))
        for s1 in (-1, 1) for s2 in (-1, 1)
    )  # fmt: skip
    if f * r_max >= 1.0:
        raise CohortError(
            f"params: the radial contraction reaches r = {r_max:.3g} at f = {f:g}: the radial "
            "map rho -> (1 - f r) rho is not invertible (1 - f r <= 0)"
        )
    if f * gain * p.longitudinal_shortening >= 1.0:
        raise CohortError(
            f"params: longitudinal_shortening {gain * p.longitudinal_shortening:g} at f = {f:g} "
            "collapses the long axis (1 - f l <= 0): the motion is not invertible"
        )
    margin = min(1.0 - f * max(r_max, 0.0), 1.0 - f * gain * max(p.longitudinal_shortening, 0.0))
    if not _coupled(abnormality) or f == 0.0:
        return margin
    if abnormality.transition_height == 0.0 or abnormality.transition_angle == 0.0:
        raise CohortError(
            "abnormality: a sharp transition (transition_height or transition_angle 0) of the "
            f"{abnormality.kind!r} motion tears the volume; give transitions of width > 0"
        )
    u, phi, lon, slopes = _modulation_grid(abnormality)
    det, turn = _jacobian(p, f, u, 1.0, p.longitudinal_shortening * lon, slopes)
    det = np.minimum(det, turn)
    worst = int(np.argmin(det))
    if det[worst] <= 0.0:
        raise CohortError(
            f"abnormality: {abnormality.describe()} at f = {f:g} folds the volume (Jacobian "
            f"{det[worst]:.3g} at u = {u[worst]:.3f}, phi = {np.degrees(phi[worst]):.1f} deg): "
            "the motion is not invertible; use a smaller magnitude or wider transitions"
        )
    return min(margin, float(det[worst]))


def _prepare(params, points, f, abnormality, fold_check: bool):
    _check_inputs(params, abnormality)
    f, x = _check_f(f), _check_points(points)
    check_invertible(params, f, abnormality if fold_check else None)
    return f, x


def motion_forward(
    params: SubjectParameters, points, f: float, abnormality: MotionAbnormality | None = None
) -> np.ndarray:
    """Move points of the subject's ED frame to their place at fraction ``f`` of the motion.

    ``points`` (array ``(..., 3)``, mm, apex at the origin, long axis ``+z``) are moved
    to fraction ``f`` in ``[0, 1]`` (:func:`cycle_fraction`) of the motion, with the
    planted ``abnormality`` (optional) evaluated at each point's ``(theta, phi)``;
    returns an array of their shape (a copy at ``f = 0``). Raises :class:`CohortError`
    for ``f`` outside ``[0, 1]``, ``1 - f r <= 0`` or ``1 - f l <= 0``, or points of the
    wall where a planted abnormality's steep transition folds the volume (``J <= 0``):
    the surfaces and the blood pool of such a motion are moved, not its wall.
    """
    f, x = _prepare(params, points, f, abnormality, fold_check=False)
    if f == 0.0:
        return x.copy()
    shape, x = x.shape, x.reshape(-1, 3)
    rho = np.hypot(x[:, 0], x[:, 1])
    phi = np.where(rho > 0.0, np.arctan2(x[:, 1], x[:, 0]), 0.0)
    s = x[:, 2] / params.long_axis
    r, shortening, psi = _fields(params, np.clip(s, 0.0, 1.0), phi, abnormality)
    k, rho_e = 1.0 - f * r, _endocardium(params, np.clip(s, 0.0, 1.0), phi)
    excess = rho**2 - rho_e**2
    rho2, phi2 = k * rho, phi + f * psi
    wall = excess > _ON_SURFACE * (1.0 + rho_e**2)  # else on the endocardium, to rounding
    if wall.any():
        jac = _area_factor(params, s[wall], phi[wall], f, shortening[wall], abnormality)
        if np.any(jac <= 0.0):
            raise CohortError(
                f"abnormality: {abnormality.describe()} at f = {f:g} folds the volume at "
                f"{int(np.sum(jac <= 0.0))} points of the wall; see check_invertible"
            )
        rho2[wall] = np.sqrt((k * rho_e)[wall] ** 2 + excess[wall] / jac)
    out = np.stack([rho2 * np.cos(phi2), rho2 * np.sin(phi2), (1.0 - f * shortening) * x[:, 2]], -1)
    return out.reshape(shape)


def _wrap(angle):
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


def _solve_coupled(params, s, phi, zc, phi_t, axis, f, abnormality):
    """Newton's method on ``(s, phi)`` (``s = z / c``) for ``z' / c`` and ``phi'``, in place."""

    def residual(s_, phi_, idx):
        _, shortening, psi = _fields(params, np.clip(s_, 0.0, 1.0), phi_, abnormality)
        r1 = (1.0 - f * shortening) * s_ - zc[idx]
        r2 = np.where(axis[idx], phi_, _wrap(phi_ + f * psi - phi_t[idx]))
        return r1, r2

    active = np.arange(s.size)
    for _ in range(_NEWTON_ITERATIONS):
        r1, r2 = residual(s[active], phi[active], active)
        done = (np.abs(r1) <= _NEWTON_TOL * (1.0 + np.abs(s[active]))) & (np.abs(r2) <= _NEWTON_TOL)
        active, r1, r2 = active[~done], r1[~done], r2[~done]
        if active.size == 0:
            return
        sa, pa = s[active], phi[active]
        a1, a2 = residual(sa + _FD_STEP, pa, active)
        b1, b2 = residual(sa, pa + _FD_STEP, active)
        j11, j21 = (a1 - r1) / _FD_STEP, (a2 - r2) / _FD_STEP
        j12, j22 = (b1 - r1) / _FD_STEP, (b2 - r2) / _FD_STEP
        det = j11 * j22 - j12 * j21
        s[active] = sa - np.clip((j22 * r1 - j12 * r2) / det, -0.25, 0.25)
        phi[active] = pa - np.clip((j11 * r2 - j21 * r1) / det, -0.5, 0.5)
    raise CohortError(
        f"points: the inverse motion did not converge at {active.size} points "
        f"(abnormality {abnormality.describe()})"
    )


def motion_inverse(
    params: SubjectParameters, points, f: float, abnormality: MotionAbnormality | None = None
) -> np.ndarray:
    """Bring points at fraction ``f`` of the motion back to the subject's ED frame.

    The exact inverse of :func:`motion_forward`, in the map's triangular order: the
    height first (``z = z' / (1 - f l)``), then the rotation (``phi = phi' - f psi(u)``),
    then the radius: ``rho = rho' / (1 - f r)`` inside the moved endocardium
    (``rho' <= rho_e'``), ``rho = sqrt(rho_e^2 + J (rho'^2 - rho_e'^2))`` outside. When
    the planted abnormality makes ``l`` or ``psi`` depend on the longitude (all kinds
    but ``"radial"``), the height and longitude are found together by Newton's method
    from that closed form, to 1e-14 of the long axis and 1e-14 rad.

    ``points`` (array ``(..., 3)``, mm) at fraction ``f``; returns their ED positions.
    Raises :class:`CohortError` for ``f`` outside ``[0, 1]`` or a motion that is not
    invertible (:func:`check_invertible`).
    """
    f, y = _prepare(params, points, f, abnormality, fold_check=True)
    if f == 0.0:
        return y.copy()
    shape, y = y.shape, y.reshape(-1, 3)
    c = params.long_axis
    rho_t = np.hypot(y[:, 0], y[:, 1])
    axis = rho_t == 0.0
    phi_t = np.where(axis, 0.0, np.arctan2(y[:, 1], y[:, 0]))
    zc = y[:, 2] / c
    s = zc / (1.0 - f * params.longitudinal_shortening)
    u = np.clip(s, 0.0, 1.0)  # the height is exact without a coupled modulation
    psi0 = np.deg2rad(params.apex_rotation * (1.0 - u) - params.base_rotation * u)
    phi = np.where(axis, 0.0, phi_t - f * psi0)
    if _coupled(abnormality):
        _solve_coupled(params, s, phi, zc, phi_t, axis, f, abnormality)
    r, shortening, _ = _fields(params, np.clip(s, 0.0, 1.0), phi, abnormality)
    k, rho_e = 1.0 - f * r, _endocardium(params, np.clip(s, 0.0, 1.0), phi)
    rho = rho_t / k
    excess = rho_t**2 - (k * rho_e) ** 2
    wall = excess > _ON_SURFACE * k**2 * (1.0 + rho_e**2)
    if wall.any():
        jac = _area_factor(params, s[wall], phi[wall], f, shortening[wall], abnormality)
        rho[wall] = np.sqrt(rho_e[wall] ** 2 + jac * excess[wall])
    out = np.stack([rho * np.cos(phi), rho * np.sin(phi), s * c], axis=-1)
    return out.reshape(shape)


def cycle_frames(
    params: SubjectParameters,
    theta,
    phi,
    n_frames: int = 25,
    es_phase: float = 0.35,
    abnormality: MotionAbnormality | None = None,
) -> np.ndarray:
    """The subject's surface at every frame of the cycle, in vertex correspondence.

    Frame ``k`` is the ED surface of :func:`lv_shapes` moved by :func:`motion_forward`
    at ``f = cycle_fraction(k / n_frames, es_phase)`` with the abnormality acting at
    that time (:func:`frame_abnormality`): frame 0 is the ED surface, and the ES surface
    is frame ``es_phase * n_frames`` when that is an integer.

    ``theta, phi`` (shape ``(k,)``) are parametric coordinates (:func:`lv_grid`); returns
    an array ``(n_frames, k, 3)``.
    """
    n = check_n_frames(n_frames)
    times = frame_times(n)
    fractions = cycle_fraction(times, es_phase)
    theta, phi = np.asarray(theta, dtype=float), np.asarray(phi, dtype=float)
    if theta.ndim != 1 or theta.shape != phi.shape:
        raise CohortError(
            f"theta, phi: expected two arrays of shape (k,), got {theta.shape}, {phi.shape}"
        )
    ed, _ = lv_shapes(params, theta, phi)
    return np.stack([motion_forward(params, ed, f, frame_abnormality(abnormality, t, es_phase))
                     for t, f in zip(times, fractions)])  # fmt: skip
