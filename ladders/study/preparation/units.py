"""Units and pose of a cohort's meshes against the atlas's, checked before any registration.

A mesh's size is the root-mean-square distance of its surface to its centroid
(area-weighted over the triangles: it depends neither on the triangulation nor
on the pose). A size ratio ``r = size(mesh) / size(atlas)`` more than
``10^0.5 ~ 3.2`` away from 1 is a scale disagreement; near a power of ten
(``|log10 r - round(log10 r)| < 0.3``) it names the likely unit: ``r ~ 0.001``
for an atlas in mm means the mesh is in metres. Its pose is far from the
atlas's when the centroids are further apart than ``max_offset`` atlas sizes
(default 0.6; a subject's ED mesh against the atlas, its other phases, whose centroid
moves with the contraction, against its ED) or it is turned by more than
``max_angle`` degrees (default 45) by
:func:`~.pose_angle.pose_angle`: the rotation of the least-squares rigid fit of its
vertices onto the atlas's when it has the atlas's triangulation (a cohort in
correspondence), else the misfit of the whole second-moment tensors as an angle. Both
are defined for a near-round mesh, whose principal axis (largest variance) is not: the
angle between principal axes is not used. On 10 synthetic cohorts of 45 subjects
(``benchmarks/bench_pose_check.py``) no unposed subject is refused, while every subject
turned by 90 degrees across its long axis (in correspondence) and every subject (or ES
mesh alone) moved by one atlas size, across the long axis or along it, is.

:func:`check_units_and_pose` raises a :class:`UnitsError` naming every such
mesh, its size, the atlas's and the likely unit, unless told what to do:

* ``units``: the meshes' unit (``"m"``, ``"cm"``, ``"mm"``, ``"um"``), one for
  all or one per subject, or ``"auto"`` to convert each mesh by the power of ten
  detected; the factors applied are returned, per subject;
* ``allow_scale``: accept the sizes as they are;
* ``allow_pose``: accept meshes far from the atlas's pose (e.g. when they will be
  aligned rigidly first, as the correspondence does).

The report says what was assumed (:meth:`UnitsReport.describe`, :meth:`UnitsReport.as_dict`:
checked, given or detected; what was accepted). :mod:`.cohort_units` applies the
check to a cohort in correspondence and to the meshes an atlas is estimated from.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from manifolds.data_terms.mesh_geometry import check_mesh

from .alignment import second_moments
from .pose_angle import MEASURES, pose_angle

__all__ = [
    "UNITS_IN_MM",
    "UnitsError",
    "MeshSize",
    "UnitsReport",
    "check_units_and_pose",
    "mesh_size",
]

#: Length units and their size in millimetres.
UNITS_IN_MM = {"m": 1000.0, "cm": 10.0, "mm": 1.0, "um": 1e-3}
_SCALE_TOLERANCE = 0.5  # |log10 r| above this is a scale disagreement (factor 3.2)
_POWER_TOLERANCE = 0.3  # |log10 r - k| below this names the unit of 10^k


_HINTS = {  # how to proceed, in the Python API's words and in the command line's
    "scale": (
        "Give the meshes' unit (units='m', 'cm', 'mm' or 'auto') or accept the sizes "
        "(allow_scale=True).",
        "give the meshes' unit with --units (m, cm, mm, um, or auto: each mesh converted by "
        "the power of ten its size suggests) or accept the sizes with --allow-scale",
    ),
    "pose": (
        "Align them rigidly first (ladders.study.preparation.correspond_cohort does) or "
        "accept the poses (allow_pose=True).",
        "align them rigidly first (symladders correspond does) or accept the poses with "
        "--allow-pose",
    ),
}


class UnitsError(ValueError):
    """Meshes whose size or pose disagrees with the atlas's (the message lists them).

    Parameters
    ----------
    problem : str
        What disagrees, one line per mesh after the first.
    kind : {"scale", "pose"} or None
        The disagreement, which chooses the hint appended to the message.
    """

    def __init__(self, problem: str, kind: str | None = None):
        self.problem, self.kind = problem, kind
        hint = _HINTS[kind][0] if kind else ""
        super().__init__(f"{problem}\n{hint}" if hint else problem)

    def for_command_line(self) -> str:
        """The message in one line, with the command-line flags as the way out."""
        first, *rest = [line.strip() for line in self.problem.splitlines() if line.strip()]
        text = " ".join([first, "; ".join(rest)]) if rest else first
        return f"{text}; {_HINTS[self.kind][1]}" if self.kind else text


@dataclass
class MeshSize:
    """Size and pose of one mesh against the atlas.

    Attributes
    ----------
    name : str
    size : float
        RMS distance of the surface to its centroid, in the file's unit.
    ratio : float
        ``size / atlas size``.
    likely_unit : str or None
        The unit the ratio suggests, when it is near a power of ten other than 1.
    offset : float
        Distance between the centroids, in atlas sizes (the mesh in the unit assumed): to
        the atlas's, or for a mesh of another phase than ED whose subject has an ED mesh, to
        that ED mesh's (``offset_from``).
    angle : float
        How far it is turned from the atlas, in degrees (:func:`~.pose_angle.pose_angle`).
    measure : str
        How ``angle`` was measured: ``"correspondence"`` or ``"moments"``.
    """

    name: str
    size: float
    ratio: float
    likely_unit: str | None
    offset: float
    angle: float
    measure: str = "moments"
    offset_from: str = "atlas"


@dataclass
class UnitsReport:
    """Outcome of :func:`check_units_and_pose`.

    Attributes
    ----------
    atlas_size : float
    atlas_unit : str
    meshes : list of MeshSize
    factors : dict
        Per subject, the factor its coordinates are multiplied by to be in the atlas's unit.
    assumed_units : dict
        Per subject, the unit assumed for its files.
    requested : str, dict or None
        The ``units`` asked for (``None``: the atlas's, checked).
    accepted_scale, accepted_pose : list of str
        Meshes (``subject:phase``) whose size (pose) disagreed and was accepted.
    pose_checked : bool
        Whether a far pose would have been refused (``allow_pose=False``).
    """

    atlas_size: float
    atlas_unit: str
    meshes: list = field(default_factory=list)
    factors: dict = field(default_factory=dict)
    assumed_units: dict = field(default_factory=dict)
    requested: object = None
    accepted_scale: list = field(default_factory=list)
    accepted_pose: list = field(default_factory=list)
    pose_checked: bool = True

    @property
    def how(self) -> str:
        """``"checked"`` (no unit given), ``"detected"`` (``"auto"``) or ``"given"``."""
        if self.requested is None:
            return "checked"
        return "detected" if self.requested == "auto" else "given"

    def converted(self) -> dict:
        """``{subject: unit}`` of the subjects read in another unit than the atlas's."""
        return {n: u for n, u in self.assumed_units.items() if u != self.atlas_unit}

    def as_dict(self) -> dict:
        """JSON-ready: the unit, how it was obtained, the conversions and acceptances."""
        return {
            "unit": self.atlas_unit,
            "how": self.how,
            "requested": self.requested,
            "atlas_size": self.atlas_size,
            "subjects": dict(self.assumed_units),
            "factors": dict(self.factors),
            "accepted_scale": list(self.accepted_scale),
            "accepted_pose": list(self.accepted_pose),
            "pose_checked": self.pose_checked,
        }

    def describe(self) -> str:
        """One paragraph: the unit assumed, whether it was checked, given or detected."""
        unit = self.atlas_unit
        what = "size and pose were" if self.pose_checked else "size was"
        text = (
            f"Lengths in {unit}: the atlas is taken to be in {unit}, and "
            + {
                "checked": f"every mesh's {what} checked against the atlas's.",
                "detected": f"each subject's unit was detected from its size (every mesh's {what} "
                "then checked against the atlas's).",
                "given": f"the subjects' unit was given as {self.requested} (every mesh's {what} "
                "then checked against the atlas's).",
            }[self.how]
        )
        converted = ", ".join(f"{n} (from {u})" for n, u in self.converted().items())
        if converted:
            text += f" Converted to {unit}: {converted}."
        if self.accepted_scale:
            text += f" Sizes that disagree, accepted as they are: {', '.join(self.accepted_scale)}."
        if self.accepted_pose:
            text += f" Poses far from the atlas's, accepted: {', '.join(self.accepted_pose)}."
        return text


def _size_and_centroid(vertices, faces):
    centroid, moments = second_moments(vertices, faces)
    return float(np.sqrt(np.trace(moments))), centroid


def mesh_size(vertices, faces) -> float:
    """The RMS distance of a mesh's surface to its centroid (area-weighted over its triangles)."""
    v, f = check_mesh(vertices, faces, "mesh_size")
    return _size_and_centroid(v, f)[0]


def _unit_of_ratio(ratio: float, atlas_unit: str) -> str | None:
    k = np.log10(ratio)
    if abs(k) < _SCALE_TOLERANCE or abs(k - round(k)) >= _POWER_TOLERANCE:
        return None
    target = UNITS_IN_MM[atlas_unit] / 10.0 ** round(k)
    for unit, mm in UNITS_IN_MM.items():
        if np.isclose(mm, target):
            return unit
    return f"10^{-round(k)} {atlas_unit}"


def _factors(names, sizes: list[MeshSize], units, atlas_unit) -> dict:
    """Per subject, the unit its files are read in (None: as the atlas's) from ``units``."""
    if units is None:
        return {n: atlas_unit for n in names}
    if isinstance(units, dict):
        unknown = sorted(set(units) - set(names))
        if unknown:
            raise UnitsError(f"units: no mesh of the subject(s) {unknown}")
        chosen = {n: units.get(n, atlas_unit) for n in names}
    elif units == "auto":
        by_name = {}
        for s in sizes:
            by_name.setdefault(s.name.split(":")[0], s.likely_unit)
        chosen = {n: by_name.get(n) or atlas_unit for n in names}
    else:
        chosen = dict.fromkeys(names, units)
    for name, unit in chosen.items():
        if unit not in UNITS_IN_MM:
            raise UnitsError(
                f"units: subject {name!r}: expected one of {list(UNITS_IN_MM)} or 'auto', "
                f"got {unit!r}"
            )
    return chosen


def _measure(meshes: dict, atlas: tuple, atlas_size, atlas_unit):
    """Per mesh, its :class:`MeshSize` (offset still zero) and its centroid in its own unit."""
    sizes, centroids = [], []
    for name, phases in meshes.items():
        for phase, (v, f) in phases.items():
            v, f = check_mesh(v, f, f"check_units_and_pose: {name} {phase}")
            size, centroid = _size_and_centroid(v, f)
            ratio = size / atlas_size
            angle, measure = pose_angle(v, f, *atlas)
            unit = _unit_of_ratio(ratio, atlas_unit)
            sizes.append(MeshSize(f"{name}:{phase}", size, ratio, unit, 0.0, angle, measure))
            centroids.append(centroid)
    return sizes, centroids


def _message(bad: list[MeshSize], atlas_size, atlas_unit, what: str, reference: str) -> str:
    lines = [
        f"{len(bad)} mesh(es) {what} (size {atlas_size:.4g} {atlas_unit}: the RMS distance "
        "of the surface to its centroid):"
    ]
    for s in bad[:20]:
        unit = f"; likely in {s.likely_unit}" if s.likely_unit else ""
        lines.append(
            f"  {s.name}: size {s.size:.4g} (ratio {s.ratio:.3g}{unit}), centroid offset "
            f"{s.offset:.2f} atlas sizes{'' if s.offset_from == 'atlas' else ' from its ED'}, "
            f"turned {s.angle:.0f} degrees ({MEASURES[s.measure]})"
        )
    if len(bad) > 20:
        lines.append(f"  ... and {len(bad) - 20} more")
    return "\n".join(lines)


def _disagreements(report: UnitsReport, centroids, atlas_centroid, max_offset, max_angle):
    """Set the offsets (in the atlas's unit); the meshes of another scale, and those far away.

    A subject's ED mesh is placed against the atlas; its other phases (ES), whose centroid
    moves with the contraction, against its ED mesh: a subject moved as a whole is caught
    by its ED, a phase moved alone by its distance to its ED."""
    factor = {s.name: report.factors[s.name.split(":")[0]] for s in report.meshes}
    placed = {s.name: c * factor[s.name] for s, c in zip(report.meshes, centroids)}
    for s in report.meshes:
        subject, _, phase = s.name.partition(":")
        ed = placed.get(f"{subject}:ed")
        if phase != "ed" and ed is not None:
            s.offset = float(np.linalg.norm(placed[s.name] - ed) / report.atlas_size)
            s.offset_from = "ed"
        else:
            s.offset = float(np.linalg.norm(placed[s.name] - atlas_centroid) / report.atlas_size)
    scale = [
        s for s in report.meshes if abs(np.log10(s.ratio * factor[s.name])) >= _SCALE_TOLERANCE
    ]
    far = [  # a mesh of another scale (accepted) has no comparable pose
        s
        for s in report.meshes
        if s not in scale and (s.offset > max_offset or s.angle > max_angle)
    ]
    return scale, far


def check_units_and_pose(
    atlas_vertices,
    atlas_faces,
    meshes: dict,
    *,
    atlas_unit: str = "mm",
    units=None,
    allow_scale: bool = False,
    allow_pose: bool = False,
    max_offset: float = 0.6,
    max_angle: float = 45.0,
    reference: str = "the atlas",
) -> UnitsReport:
    """Check that every mesh has the atlas's unit and is near its pose (see the module).

    Parameters
    ----------
    atlas_vertices, atlas_faces : arrays ``(k, 3)``, ``(f, 3)``
    meshes : dict
        ``{subject: {phase: (vertices, faces)}}`` (e.g. phases ``"ed"``, ``"es"``).
        The phases of a subject share one unit.
    atlas_unit : str, default "mm"
    units : str or dict, optional
        The meshes' unit: one of :data:`UNITS_IN_MM` for all, ``{subject: unit}``,
        or ``"auto"`` (the detected unit of each subject).
    allow_scale, allow_pose : bool
        Accept size (pose) disagreements instead of raising.
    max_offset : float, default 0.6
        Centroid distance, in atlas sizes, beyond which a pose is far: an ED mesh's (or a
        mesh without an ED) from the atlas's, another phase's from its subject's ED.
    max_angle : float, default 45
        Turn from the atlas's orientation (:func:`~.pose_angle.pose_angle`), in degrees,
        beyond which a pose is far.
    reference : str, default "the atlas"
        What the atlas is called in the messages.

    Returns
    -------
    UnitsReport
        Sizes, poses and, per subject, the unit assumed and the factor to apply.

    Raises
    ------
    UnitsError
        A size disagreement (unless ``units`` or ``allow_scale``) or a far pose
        (unless ``allow_pose``), naming the meshes, their sizes and the likely unit.
    """
    if atlas_unit not in UNITS_IN_MM:
        raise UnitsError(f"atlas_unit: expected one of {list(UNITS_IN_MM)}, got {atlas_unit!r}")
    av, af = check_mesh(atlas_vertices, atlas_faces, "check_units_and_pose: atlas")
    atlas_size, atlas_centroid = _size_and_centroid(av, af)
    sizes, centroids = _measure(meshes, (av, af), atlas_size, atlas_unit)
    assumed = _factors(list(meshes), sizes, units, atlas_unit)
    report = UnitsReport(atlas_size, atlas_unit, sizes, assumed_units=assumed, requested=units)
    report.factors = {n: UNITS_IN_MM[u] / UNITS_IN_MM[atlas_unit] for n, u in assumed.items()}
    scale, far = _disagreements(report, centroids, atlas_centroid, max_offset, max_angle)
    for bad, allowed, what, kind in (
        (scale, allow_scale, f"disagree(s) in size with {reference}", "scale"),
        (far, allow_pose, f"lie(s) far from {reference}'s pose", "pose"),
    ):
        if bad and not allowed:
            raise UnitsError(_message(bad, atlas_size, atlas_unit, what, reference), kind)
    report.accepted_scale = [s.name for s in scale]
    report.accepted_pose = [s.name for s in far]
    report.pose_checked = not allow_pose
    return report
