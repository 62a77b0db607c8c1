"""The AHA 17-segment model of the left ventricle on the synthetic cohort's parametrisation.

The American Heart Association's standard (Cerqueira et al., Circulation 2002)
divides the left ventricle along its long axis into basal, mid-cavity and apical
thirds and an apical cap, and each ring into sectors: six of 60 degrees for the
basal (segments 1-6) and mid (7-12) rings, four of 90 degrees for the apical
ring (13-16), and the apex (17).

On the synthetic left ventricle (:mod:`ladders.study.cohort.synthetic_lv`) a
vertex has a normalised height ``u = 1 - cos(theta)`` (0 at the apex, 1 at the
base plane) and a longitude ``phi``. This module places the segments there:

=========  ===================  ==========================================
ring       height ``u``         sectors (centre longitude, degrees)
=========  ===================  ==========================================
basal      ``[0.70, 1]``         1 anterior (90), 2 anteroseptal (150),
                                 3 inferoseptal (210), 4 inferior (270),
                                 5 inferolateral (330), 6 anterolateral (30)
mid        ``[0.40, 0.70)``      7-12, the same sectors
apical     ``[0.10, 0.40)``      13 anterior (90), 14 septal (180),
                                 15 inferior (270), 16 lateral (0)
apex       ``[0, 0.10)``         17
=========  ===================  ==========================================

so that, seen from the base down the long axis (``-z``), the anterior wall is
at ``+y``, the septum at ``-x`` and the lateral wall at ``+x``. The model has no
right ventricle to anchor the septum: this orientation is a convention of the
synthetic cohort, stated so that a named segment means one region of its meshes.

:func:`segment_weights` gives a smooth indicator of a set of segments (1 inside,
0 outside, a raised-cosine transition across each boundary whose two sides add
up to 1, so that adjacent named segments join without a dip).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from ..errors import CohortError

__all__ = [
    "AHA_SEGMENTS",
    "RING_HEIGHTS",
    "segment_of",
    "segment_weights",
    "check_segments",
]

#: Height bounds ``(low, high)`` of each ring in ``u`` (0 apex, 1 base).
RING_HEIGHTS = {
    "apex": (0.0, 0.10),
    "apical": (0.10, 0.40),
    "mid": (0.40, 0.70),
    "basal": (0.70, 1.0),
}

_SIX = ("anterior", "anteroseptal", "inferoseptal", "inferior", "inferolateral", "anterolateral")
_SIX_CENTRES = (90.0, 150.0, 210.0, 270.0, 330.0, 30.0)
_FOUR = ("anterior", "septal", "inferior", "lateral")
_FOUR_CENTRES = (90.0, 180.0, 270.0, 0.0)


def _table() -> dict[int, tuple[str, str, float, float]]:
    """``segment -> (ring, name, centre longitude, width)`` in degrees."""
    table = {}
    for offset, ring in ((1, "basal"), (7, "mid")):
        for i, (name, centre) in enumerate(zip(_SIX, _SIX_CENTRES)):
            table[offset + i] = (ring, name, centre, 60.0)
    for i, (name, centre) in enumerate(zip(_FOUR, _FOUR_CENTRES)):
        table[13 + i] = ("apical", name, centre, 90.0)
    table[17] = ("apex", "apex", 0.0, 360.0)
    return table


#: ``segment number -> (ring, sector name, centre longitude in degrees, width in degrees)``.
AHA_SEGMENTS = _table()


def check_segments(segments: Iterable[int], name: str = "segments") -> tuple[int, ...]:
    """The segment numbers as a sorted tuple of distinct ints in 1..17, or raise naming ``name``."""
    try:
        values = [int(s) for s in segments]
    except (TypeError, ValueError):
        raise CohortError(f"{name}: expected AHA segment numbers 1..17, got {segments!r}") from None
    bad = [s for s in values if s not in AHA_SEGMENTS]
    if bad or not values:
        raise CohortError(f"{name}: expected AHA segment numbers 1..17, got {list(segments)!r}")
    return tuple(sorted(set(values)))


def _heights(theta) -> np.ndarray:
    return 1.0 - np.cos(np.asarray(theta, dtype=float))


def _angle_difference(phi_deg, centre_deg) -> np.ndarray:
    """Signed difference ``phi - centre`` wrapped to ``[-180, 180)`` degrees."""
    return (np.asarray(phi_deg) - centre_deg + 180.0) % 360.0 - 180.0


def segment_of(theta, phi) -> np.ndarray:
    """The AHA segment (1..17) of each vertex of parametric coordinates ``(theta, phi)``.

    Parameters
    ----------
    theta, phi : ndarray, shape (k,)
        Polar angle from the apex and longitude, in radians (:func:`lv_grid`).

    Returns
    -------
    ndarray of int, shape (k,)
    """
    u = _heights(theta)
    phi_deg = np.degrees(np.asarray(phi, dtype=float)) % 360.0
    out = np.full(u.shape, 17, dtype=np.int64)
    for number, (ring, _, centre, width) in AHA_SEGMENTS.items():
        if ring == "apex":
            continue
        low, high = RING_HEIGHTS[ring]
        in_ring = (u >= low) & ((u < high) if ring != "basal" else (u <= high))
        in_sector = np.abs(_angle_difference(phi_deg, centre)) <= 0.5 * width
        out[in_ring & in_sector] = number
    return out


def _ramp(x, half_width: float) -> np.ndarray:
    """Raised cosine from 0 (``x <= -h``) to 1 (``x >= h``), ``ramp(x) + ramp(-x) = 1``."""
    if half_width <= 0:
        return (np.asarray(x) >= 0).astype(float)
    with np.errstate(over="ignore"):  # a subnormal width: +-inf, clipped to the step
        t = np.clip((np.asarray(x, dtype=float) + half_width) / (2.0 * half_width), 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * t)


def _band(x, low: float, high: float, half_width: float) -> np.ndarray:
    return _ramp(x - low, half_width) * _ramp(high - x, half_width)


def segment_weights(
    theta,
    phi,
    segments: Iterable[int],
    transition_height: float = 0.05,
    transition_angle: float = 10.0,
) -> np.ndarray:
    """Smooth indicator of the union of AHA ``segments`` at every vertex, in ``[0, 1]``.

    Each segment is the product of a band in height and a band in longitude
    whose edges are raised-cosine ramps of half-width ``transition_height`` (in
    ``u``, a fraction of the long axis) and ``transition_angle`` (degrees),
    centred on the segment's boundary; the segments' indicators are summed and
    clipped to 1. A vertex on a boundary between a named and an unnamed segment
    has weight 0.5; between two named segments, 1. The apex's lower bound and the
    base's upper bound are the ends of the ventricle (no transition there).

    Parameters
    ----------
    theta, phi : ndarray, shape (k,)
        Parametric coordinates in radians (:func:`lv_grid`).
    segments : iterable of int
        AHA segment numbers, 1..17.
    transition_height : float, default 0.05
        Half-width of the transition across a ring boundary, in ``u`` (0 for sharp).
    transition_angle : float, default 10.0
        Half-width of the transition across a sector boundary, in degrees.

    Returns
    -------
    ndarray, shape (k,)
    """
    segments = check_segments(segments)
    if transition_height < 0 or transition_angle < 0:
        raise CohortError(
            "segment_weights: transition_height and transition_angle must be >= 0, got "
            f"{transition_height!r} and {transition_angle!r}"
        )
    u = _heights(theta)
    phi_deg = np.degrees(np.asarray(phi, dtype=float))
    total = np.zeros(u.shape)
    for number in segments:
        ring, _, centre, width = AHA_SEGMENTS[number]
        low, high = RING_HEIGHTS[ring]
        low = -np.inf if ring == "apex" else low
        high = np.inf if ring == "basal" else high
        height = _band(u, low, high, transition_height)
        if width >= 360.0:
            total += height
            continue
        offset = _angle_difference(phi_deg, centre)
        total += height * _band(offset, -0.5 * width, 0.5 * width, transition_angle)
    return np.clip(total, 0.0, 1.0)
