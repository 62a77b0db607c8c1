"""Cohorts in one unit: checked against a reference, converted, before any registration.

:func:`check_cohort_units` checks a :class:`~ladders.study.cohort.Cohort` in
correspondence against its atlas, taken to be in mm (the unit of the study's
lengths), and converts its subjects into it; ``symladders study`` runs it
before any registration.

:func:`read_atlas_inputs` reads the ED mesh of every subject of a folder in the
study's layout (``<name>_ed.<ext>``, or ``<name>/ed.<ext>``; the ES meshes and an
``atlas.<ext>`` are not needed), records the meshes it cannot read with their
reason instead of stopping, and checks the sizes against the mesh of median size
(:func:`~ladders.study.preparation.units.check_units_and_pose`), which is taken
to be in ``unit``: a minority of subjects in another unit is then named, or
converted with ``units``. Poses are not checked (the atlas aligns every mesh).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..cohort import Cohort
from ..meshes.mesh_io import read_mesh
from .cohort_correspondence import scan_segmentations
from .units import UnitsReport, check_units_and_pose, mesh_size

__all__ = ["AtlasInputs", "check_cohort_units", "read_atlas_inputs"]


@dataclass
class AtlasInputs:
    """Outcome of :func:`read_atlas_inputs`.

    Attributes
    ----------
    names : list of str
        The subjects read, in natural order.
    meshes : list of ``(vertices, faces)``
        Their ED meshes, in ``units.atlas_unit``.
    files : list of Path
        The files read.
    skipped : dict
        ``{subject: reason}`` of the meshes that could not be read.
    units : UnitsReport
        The size check against the reference (``units.atlas_size``), per subject the
        unit assumed.
    reference : str
        The subject of median size, the unit's reference.
    """

    names: list = field(default_factory=list)
    meshes: list = field(default_factory=list)
    files: list = field(default_factory=list)
    skipped: dict = field(default_factory=dict)
    units: UnitsReport | None = None
    reference: str = ""


def read_atlas_inputs(
    folder, *, units=None, allow_scale: bool = False, unit: str = "mm"
) -> AtlasInputs:
    """Read the ED meshes of ``folder`` in one unit (see the module).

    Parameters
    ----------
    folder : str or Path
        A folder in the study's layout; any vertex count and format.
    units : str or dict, optional
        The meshes' unit, as in :func:`check_units_and_pose` (``"auto"``: each
        subject's detected from its size).
    allow_scale : bool, default False
        Accept sizes that disagree with the reference's.
    unit : str, default "mm"
        The unit of the reference, the mesh of median size (of the two middle
        sizes, the larger).

    Returns
    -------
    AtlasInputs

    Raises
    ------
    ValueError
        No subject in the folder, or none of their ED meshes can be read.
    UnitsError
        Sizes that disagree with the reference's, unless ``units`` or ``allow_scale``.
    """
    entries = scan_segmentations(folder, phases=("ed",))
    out = AtlasInputs()
    read = {}
    for name, slot in entries.items():
        try:
            read[name] = read_mesh(slot["ed"])
        except (ValueError, OSError) as exc:
            out.skipped[name] = f"{type(exc).__name__}: {exc}"
    if not read:
        raise ValueError(f"meshes: none of the {len(entries)} ED mesh(es) in {folder} can be read")
    sizes = {n: mesh_size(*m) for n, m in read.items()}
    order = sorted(sizes, key=sizes.get)
    out.reference = order[len(order) // 2]
    out.units = check_units_and_pose(
        *read[out.reference], {n: {"ed": m} for n, m in read.items()}, atlas_unit=unit,
        units=units, allow_scale=allow_scale, allow_pose=True,
        reference=f"{out.reference}, the mesh of median size",
    )  # fmt: skip
    for name, (v, f) in read.items():
        out.names.append(name)
        out.meshes.append((np.asarray(v) * out.units.factors[name], f))
        out.files.append(Path(entries[name]["ed"]))
    return out


def check_cohort_units(
    cohort, *, units=None, allow_scale: bool = False, allow_pose: bool = False
) -> tuple[Cohort, UnitsReport]:
    """Check a cohort in correspondence against its atlas (in mm) and convert it.

    Parameters
    ----------
    cohort : Cohort
        The atlas is taken to be in mm, the unit of the study's lengths.
    units, allow_scale, allow_pose
        As in :func:`check_units_and_pose`.

    Returns
    -------
    cohort : Cohort
        The same cohort when nothing is converted, else a copy whose subjects'
        coordinates are multiplied by their factors (into the atlas's unit).
    report : UnitsReport

    Raises
    ------
    UnitsError
        As :func:`check_units_and_pose`.
    """
    meshes = {s.name: {"ed": (s.ed, cohort.faces), "es": (s.es, cohort.faces)}
              for s in cohort.subjects}  # fmt: skip
    report = check_units_and_pose(
        cohort.atlas, cohort.faces, meshes, units=units, allow_scale=allow_scale,
        allow_pose=allow_pose,
    )  # fmt: skip
    if all(f == 1.0 for f in report.factors.values()):
        return cohort, report
    subjects = [
        dataclasses.replace(s, ed=s.ed * report.factors[s.name], es=s.es * report.factors[s.name])
        for s in cohort.subjects
    ]
    converted = Cohort(cohort.atlas, cohort.faces, subjects, cohort.source, cohort.atlas_file)
    return converted, report
