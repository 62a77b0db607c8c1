"""A regional motion abnormality planted in chosen subjects of the synthetic cohort.

:class:`MotionAbnormality` describes a change of the end-systolic motion in named
AHA segments (:mod:`ladders.study.cohort.aha_segments`): a reduced radial
contraction and longitudinal shortening (hypokinesia, which a surface shows), a
change of twist (a rotation about the long axis, tangential to the wall of a
ventricle of revolution, which a surface without material landmarks cannot
show), or a delayed contraction (the segments reach their end-systole later in the
cycle, with the same amplitude: a change of timing only the whole cycle shows, see
:func:`frame_abnormality`). :func:`planted_modulation` turns it into the per-vertex
:class:`~ladders.study.cohort.synthetic_lv.MotionModulation` of
:func:`~ladders.study.cohort.synthetic_lv.lv_shapes`, and
:func:`planted_region` into the ground truth on the atlas: the weight of the
abnormality at every vertex and the affected vertices (weight >= 0.5, i.e. inside
the named segments' boundaries).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import CohortError
from .aha_segments import AHA_SEGMENTS, check_segments, segment_weights
from .synthetic_lv import MotionModulation
from .time_course import cycle_fraction

__all__ = [
    "EFFECT_KINDS",
    "DEFAULT_MAGNITUDE",
    "ES_PHASE",
    "SCALED",
    "frame_abnormality",
    "MotionAbnormality",
    "PlantedRegion",
    "planted_modulation",
    "planted_region",
]

#: The kinds of abnormality: what each changes and whether a surface shows it.
EFFECT_KINDS = {
    "hypokinesia": "radial contraction and longitudinal shortening reduced (a surface shows it)",
    "radial": "radial contraction reduced (a surface shows it)",
    "longitudinal": "longitudinal shortening reduced (a surface shows it)",
    "twist": "rotation about the long axis changed (tangential: a surface does not show it)",
    "delay": "contraction delayed: end-systole later by a fraction of the cycle, the amplitude "
    "unchanged (a change of timing: through the whole cycle; at end-systole, less motion)",
}

#: Magnitude of each kind when none is given: half the motion, 5 degrees of twist, or a
#: delay of a tenth of the cycle.
DEFAULT_MAGNITUDE = {"hypokinesia": 0.5, "radial": 0.5, "longitudinal": 0.5, "twist": 5.0,
                     "delay": 0.1}  # fmt: skip

#: A delay at one time of the cycle (:func:`frame_abnormality`): the
#: radial contraction, the shortening and the rotation scaled by ``1 - magnitude w`` in
#: the segments (``magnitude`` may be negative: more motion than the others at that time).
SCALED = "scaled"
#: The end-systole of the cycle at which a delay is planted in an end-systolic shape.
ES_PHASE = 0.35


@dataclass(frozen=True)
class MotionAbnormality:
    """A regional change of the end-systolic motion, of controllable magnitude and extent.

    Attributes
    ----------
    kind : str
        One of :data:`EFFECT_KINDS`: ``"hypokinesia"`` (default: radial contraction
        and longitudinal shortening both reduced), ``"radial"``, ``"longitudinal"``,
        ``"twist"`` or ``"delay"``; or :data:`SCALED`, a delay at one time of the cycle.
    segments : tuple of int
        The AHA segments affected (1..17); default the mid and apical anterior and
        (antero)septal segments 7, 8, 13 and 14, a mid-to-distal left anterior
        descending artery territory.
    magnitude : float
        For ``"hypokinesia"``, ``"radial"`` and ``"longitudinal"``: the fraction by
        which the motion is reduced inside the segments (dimensionless, 0 to 1; 1
        is akinetic); default 0.5. For ``"twist"``: the rotation added about the
        long axis, in degrees (counterclockwise seen from the base is negative,
        the model's convention for ``psi``); default 5. For ``"delay"``: how much
        later the segments reach their end-systole, a fraction of the cycle in
        ``[0, 1)``; default 0.1. For :data:`SCALED`: in ``[-1, 1]``.
    transition_height : float
        Half-width of the smooth transition across ring boundaries, as a fraction
        of the long axis (default 0.05).
    transition_angle : float
        Half-width of the transition across sector boundaries, in degrees (default 10).
    """

    kind: str = "hypokinesia"
    segments: tuple = (7, 8, 13, 14)
    magnitude: float | None = None
    transition_height: float = 0.05
    transition_angle: float = 10.0

    def __post_init__(self):
        if self.kind not in EFFECT_KINDS and self.kind != SCALED:
            raise CohortError(
                f"MotionAbnormality.kind: expected one of {sorted(EFFECT_KINDS)}, got {self.kind!r}"
            )
        object.__setattr__(
            self, "segments", check_segments(self.segments, "MotionAbnormality.segments")
        )
        magnitude = self.magnitude
        if magnitude is None:
            magnitude = DEFAULT_MAGNITUDE.get(self.kind, 0.5)
        magnitude = float(magnitude)
        if not np.isfinite(magnitude):
            raise CohortError(
                f"MotionAbnormality.magnitude: expected a finite number, got {magnitude}"
            )
        if self.kind == "delay" and not 0.0 <= magnitude < 1.0:
            raise CohortError(
                f"MotionAbnormality.magnitude: a delay is a fraction of the cycle in [0, 1), "
                f"got {magnitude}"
            )
        if self.kind == SCALED and not -1.0 <= magnitude <= 1.0:
            raise CohortError(f"MotionAbnormality.magnitude: expected [-1, 1], got {magnitude}")
        if self.kind not in ("twist", "delay", SCALED) and not 0.0 <= magnitude <= 1.0:
            raise CohortError(
                f"MotionAbnormality.magnitude: a fraction of the motion in [0, 1] for {self.kind!r}, "
                f"got {magnitude}"
            )
        object.__setattr__(self, "magnitude", magnitude)
        for name in ("transition_height", "transition_angle"):
            value = float(getattr(self, name))
            if not np.isfinite(value) or value < 0:
                raise CohortError(f"MotionAbnormality.{name}: expected a number >= 0, got {value}")
            object.__setattr__(self, name, value)

    @property
    def unit(self) -> str:
        """Unit of :attr:`magnitude`."""
        if self.kind == "delay":
            return "fraction of the cycle"
        return "degrees" if self.kind == "twist" else "fraction of the motion"

    @property
    def surface_visible(self) -> bool:
        """Whether a surface without material landmarks shows the change (not for a twist)."""
        return self.kind != "twist"

    def describe(self) -> str:
        """One line: the kind, the magnitude with its unit and the segments by name."""
        names = ", ".join(f"{n} ({AHA_SEGMENTS[n][0]} {AHA_SEGMENTS[n][1]})" for n in self.segments)
        return f"{self.kind}, magnitude {self.magnitude:g} {self.unit}, segments {names}"

    def as_dict(self) -> dict:
        """JSON-ready fields."""
        out = asdict(self)
        out["segments"] = list(self.segments)
        out["unit"] = self.unit
        out["surface_visible"] = self.surface_visible
        return out


@dataclass(frozen=True)
class PlantedRegion:
    """The ground truth of an abnormality on the atlas.

    Attributes
    ----------
    weight : ndarray, shape (k,)
        The abnormality's weight at every atlas vertex, in ``[0, 1]``.
    affected : ndarray of bool, shape (k,)
        The affected vertices: ``weight >= 0.5``.
    abnormality : MotionAbnormality
    """

    weight: np.ndarray
    affected: np.ndarray
    abnormality: MotionAbnormality

    def as_dict(self) -> dict:
        """JSON-ready: the abnormality, the weights and the indices of the affected vertices."""
        return {
            "abnormality": self.abnormality.as_dict(),
            "n_vertices": int(self.weight.size),
            "affected_vertices": np.flatnonzero(self.affected).tolist(),
            "weight": self.weight.tolist(),
        }

    @classmethod
    def from_dict(cls, data: dict) -> PlantedRegion:
        """Read back :meth:`as_dict` (raises :class:`CohortError` on a malformed record)."""
        try:
            fields = dict(data["abnormality"])
            abnormality = MotionAbnormality(
                kind=fields["kind"],
                segments=tuple(fields["segments"]),
                magnitude=fields["magnitude"],
                transition_height=fields["transition_height"],
                transition_angle=fields["transition_angle"],
            )
            weight = np.asarray(data["weight"], dtype=float)
            n = int(data["n_vertices"])
        except (KeyError, TypeError, ValueError) as exc:
            raise CohortError(f"planted region: malformed record ({exc})") from None
        if weight.shape != (n,) or not np.isfinite(weight).all():
            raise CohortError(f"planted region: expected {n} finite weights, got {weight.shape}")
        return cls(weight, weight >= 0.5, abnormality)


def planted_modulation(
    abnormality: MotionAbnormality, theta: np.ndarray, phi: np.ndarray
) -> MotionModulation:
    """The per-vertex change of motion of ``abnormality`` on the grid ``(theta, phi)``.

    A delay is planted in the end-systolic shape at :data:`ES_PHASE`: the segments have
    then reached only part of their motion (:func:`frame_abnormality`).
    """
    w = segment_weights(
        theta,
        phi,
        abnormality.segments,
        abnormality.transition_height,
        abnormality.transition_angle,
    )
    one = np.ones_like(w)
    kind = abnormality.kind
    if kind == "delay":  # at end-systole, the delayed segments' share of their motion
        return planted_modulation(frame_abnormality(abnormality, ES_PHASE, ES_PHASE), theta, phi)
    reduce = 1.0 - abnormality.magnitude * w
    radial = reduce if kind in ("hypokinesia", "radial", SCALED) else one
    longitudinal = reduce if kind in ("hypokinesia", "longitudinal", SCALED) else one
    twist = abnormality.magnitude * w if kind == "twist" else np.zeros_like(w)
    rotation = reduce if kind == SCALED else None
    return MotionModulation(radial=radial, longitudinal=longitudinal, twist=twist,
                            rotation=rotation)  # fmt: skip


def planted_region(
    abnormality: MotionAbnormality, theta: np.ndarray, phi: np.ndarray
) -> PlantedRegion:
    """The ground truth of ``abnormality`` at the vertices ``(theta, phi)`` (the atlas's grid)."""
    w = segment_weights(
        theta,
        phi,
        abnormality.segments,
        abnormality.transition_height,
        abnormality.transition_angle,
    )
    return PlantedRegion(weight=w, affected=w >= 0.5, abnormality=abnormality)


def frame_abnormality(
    abnormality: MotionAbnormality | None, t: float, es_phase: float = 0.35
) -> MotionAbnormality | None:
    """The abnormality acting at time ``t`` of the cycle (the others are the same at every time).

    A ``"delay"`` of ``d`` (a fraction of the cycle) gives its segments the time course
    of a cycle whose end-systole is at ``es_phase + d``: at time ``t`` they have reached
    ``g = cycle_fraction(t, es_phase + d)`` of their motion where the rest has reached
    ``f = cycle_fraction(t, es_phase)``. That is the motion at fraction ``f`` with the
    radial contraction, the shortening and the rotation scaled by ``g / f`` in the
    segments (by ``1 + w (g / f - 1)`` across their transitions, ``w`` the segments'
    weight): a :data:`SCALED` abnormality of magnitude ``1 - g / f``.
    Inside the segments the peak comes ``d`` later and the amplitude is unchanged; ED
    (``t = 0``) is unchanged (``g / f`` there is its limit ``(es_phase / (es_phase +
    d))^2``). Raises :class:`CohortError` when ``es_phase + d >= 1``.
    """
    if abnormality is None or abnormality.kind != "delay":
        return abnormality
    late = float(es_phase) + abnormality.magnitude
    if not late < 1.0:
        raise CohortError(
            f"abnormality: a delay of {abnormality.magnitude:g} after end-systole at "
            f"{es_phase:g} of the cycle ends the contraction after the cycle (es_phase + delay "
            "must be < 1)"
        )
    f, g = cycle_fraction(t, es_phase), cycle_fraction(t, late)
    ratio = g / f if f > 0 else (es_phase / late) ** 2
    return MotionAbnormality(SCALED, abnormality.segments, 1.0 - ratio,
                             abnormality.transition_height, abnormality.transition_angle)  # fmt: skip
