"""Units and pose of a cohort's meshes against the atlas's, checked before any registration.

A mesh's size is the root-mean-square distance of its surface to its centroid
(area-weighted over the triangles: it depends neither on the triangulation nor
on the pose). A size ratio ``r = size(mesh) / size(atlas)`` more than
``10^0.5 ~ 3.2`` away from 1 is a scale disagreement; near a power of ten
(``|log10 r - round(log10 r)| < 0.3``) it names the likely unit: ``r ~ 0.001``
for an atlas in mm means the mesh is in metres. Its pose is far from the
atlas's when the centroids are further apart than ``max_offset`` atlas sizes
or the principal axes (largest variance) make more than ``max_angle`` degrees.

:func:`check_units_and_pose` raises a :class:`UnitsError` naming every such
mesh, its size, the atlas's and the likely unit, unless told what to do:

* ``units``: the meshes' unit (``"m"``, ``"cm"``, ``"mm"``, ``"um"``), one for
  all or one per subject, or ``"auto"`` to convert each mesh by the power of ten
  detected; the factors applied are returned, per subject;
* ``allow_scale``: accept the sizes as they are;
* ``allow_pose``: accept meshes far from the atlas's pose (e.g. when they will be
  aligned rigidly first, as the correspondence does).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from manifolds.data_terms.mesh_geometry import check_mesh

from .alignment import principal_frame

__all__ = ["UNITS_IN_MM", "UnitsError", "MeshSize", "UnitsReport", "check_units_and_pose"]

#: Length units and their size in millimetres.
UNITS_IN_MM = {"m": 1000.0, "cm": 10.0, "mm": 1.0, "um": 1e-3}
_SCALE_TOLERANCE = 0.5  # |log10 r| above this is a scale disagreement (factor 3.2)
_POWER_TOLERANCE = 0.3  # |log10 r - k| below this names the unit of 10^k


class UnitsError(ValueError):
    """Meshes whose size or pose disagrees with the atlas's (the message lists them)."""


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
        Distance between the centroids, in atlas sizes (the mesh in the unit assumed).
    angle : float
        Angle between the principal axes, in degrees.
    """

    name: str
    size: float
    ratio: float
    likely_unit: str | None
    offset: float
    angle: float


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
    """

    atlas_size: float
    atlas_unit: str
    meshes: list = field(default_factory=list)
    factors: dict = field(default_factory=dict)
    assumed_units: dict = field(default_factory=dict)


def _size_and_frame(vertices, faces):
    centroid, axes = principal_frame(vertices, faces)
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    d2 = (((a + b + c) / 3.0 - centroid) ** 2).sum(1)
    return float(np.sqrt(area @ d2 / area.sum())), centroid, axes[:, 0]


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


def _measure(meshes: dict, atlas_size, atlas_axis, atlas_unit):
    """Per mesh, its :class:`MeshSize` (offset still zero) and its centroid in its own unit."""
    sizes, centroids = [], []
    for name, phases in meshes.items():
        for phase, (v, f) in phases.items():
            v, f = check_mesh(v, f, f"check_units_and_pose: {name} {phase}")
            size, centroid, axis = _size_and_frame(v, f)
            ratio = size / atlas_size
            angle = float(np.degrees(np.arccos(min(1.0, abs(axis @ atlas_axis)))))
            unit = _unit_of_ratio(ratio, atlas_unit)
            sizes.append(MeshSize(f"{name}:{phase}", size, ratio, unit, 0.0, angle))
            centroids.append(centroid)
    return sizes, centroids


def _message(bad: list[MeshSize], atlas_size, atlas_unit, what: str) -> str:
    lines = [
        f"{len(bad)} mesh(es) {what} (atlas size {atlas_size:.4g} {atlas_unit}, the RMS "
        "distance of its surface to its centroid):"
    ]
    for s in bad[:20]:
        unit = f"; likely in {s.likely_unit}" if s.likely_unit else ""
        lines.append(
            f"  {s.name}: size {s.size:.4g} (ratio {s.ratio:.3g}{unit}), centroid offset "
            f"{s.offset:.2f} atlas sizes, principal axis at {s.angle:.0f} degrees"
        )
    if len(bad) > 20:
        lines.append(f"  ... and {len(bad) - 20} more")
    return "\n".join(lines)


def check_units_and_pose(
    atlas_vertices,
    atlas_faces,
    meshes: dict,
    *,
    atlas_unit: str = "mm",
    units=None,
    allow_scale: bool = False,
    allow_pose: bool = False,
    max_offset: float = 1.0,
    max_angle: float = 45.0,
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
    max_offset : float
        Centroid distance, in atlas sizes, beyond which a pose is far.
    max_angle : float
        Angle between principal axes, in degrees, beyond which a pose is far.

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
    atlas_size, atlas_centroid, atlas_axis = _size_and_frame(av, af)
    sizes, centroids = _measure(meshes, atlas_size, atlas_axis, atlas_unit)
    assumed = _factors(list(meshes), sizes, units, atlas_unit)
    report = UnitsReport(atlas_size, atlas_unit, sizes, assumed_units=assumed)
    report.factors = {n: UNITS_IN_MM[u] / UNITS_IN_MM[atlas_unit] for n, u in assumed.items()}
    factor = {s.name: report.factors[s.name.split(":")[0]] for s in sizes}
    for s, centroid in zip(sizes, centroids):  # offsets in the atlas's unit
        s.offset = float(np.linalg.norm(centroid * factor[s.name] - atlas_centroid) / atlas_size)
    bad_scale = [s for s in sizes if abs(np.log10(s.ratio * factor[s.name])) >= _SCALE_TOLERANCE]
    if bad_scale and not allow_scale:
        raise UnitsError(
            _message(bad_scale, atlas_size, atlas_unit, "disagree(s) in size with the atlas")
            + "\nGive the meshes' unit (units='m', 'cm', 'mm' or 'auto'; --units) or accept the "
            "sizes (allow_scale=True; --allow-scale)."
        )
    far = [  # a mesh of another scale (accepted) has no comparable pose
        s for s in sizes if s not in bad_scale and (s.offset > max_offset or s.angle > max_angle)
    ]
    if far and not allow_pose:
        raise UnitsError(
            _message(far, atlas_size, atlas_unit, "lie(s) far from the atlas's pose")
            + "\nAlign them rigidly first (ladders.study.preparation.correspond_cohort does) "
            "or accept the poses (allow_pose=True)."
        )
    return report
