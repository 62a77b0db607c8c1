"""The wall maps of a cohort through the cycle, as the whole-cycle tests take a measure.

:func:`load_wall_cycles` reads the folder :func:`~.cohort_wall.run_wall_maps` wrote
(``symladders wall``) into a :class:`WallCycles`: every subject's maps at every frame on
the atlas's vertices (the tracked meshes' correspondence; a scalar per vertex needs no
transport). It answers the questions the cycle's group tests ask of a
:class:`~ladders.study.sequences.CycleMotion` (``subjects``, ``atlas``, ``faces``,
``fractions``, :meth:`WallCycles.subset`, :meth:`WallCycles.curves`), so that
``symladders cycle-analyze`` tests a wall measure as it tests the normal motion: per
frame, on every vertex's peak (in the sense the cohort moves: the largest thickness,
thickening and radial strain, the most negative circumferential and longitudinal
strain) and on the time of that peak.

The curves are in :data:`WALL_UNITS`: thickness and thickening in mm, the strains in
percent (``-20`` is 20 % shortening), as cardiac MR reports them.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...statistics import SurfaceSmoother
from ..errors import CohortError
from ..meshes.mesh_io import read_mesh
from ..sequences.cycle_analysis import MEASURES
from .maps import WALL_MEASURES, WallMaps

__all__ = ["WALL_UNITS", "WallCycles", "load_wall_cycles"]

#: The unit of each wall measure's curves in the group tests (those of the cycle's tests).
WALL_UNITS = {name: MEASURES[name] for name in WALL_MEASURES}


@dataclass(frozen=True)
class WallCycles:
    """Every subject's wall maps through the cycle, on the atlas.

    Attributes
    ----------
    subjects : tuple of str
    maps : dict
        ``{measure: array (n_subjects, n_frames, k)}`` for every measure of
        :data:`WALL_UNITS`, in its unit.
    atlas : ndarray, shape (k, 3)
    faces : ndarray of int, shape (f, 3)
    """

    subjects: tuple
    maps: dict
    atlas: np.ndarray
    faces: np.ndarray

    @property
    def fractions(self) -> np.ndarray:
        """The frames' times as fractions of the cycle, ``t / n_frames``."""
        n = next(iter(self.maps.values())).shape[1]
        return np.arange(n) / n

    def subset(self, subjects) -> WallCycles:
        """The maps of ``subjects`` (names of these cycles'), in their order."""
        index = {s: i for i, s in enumerate(self.subjects)}
        missing = [s for s in subjects if s not in index]
        if missing:
            raise CohortError(f"subjects: {missing[0]!r} has no wall maps")
        rows = [index[s] for s in subjects]
        return WallCycles(tuple(subjects), {m: v[rows] for m, v in self.maps.items()},
                          self.atlas, self.faces)  # fmt: skip

    def curves(self, measure: str = "thickening", axis=None, min_radius: float = 5.0,
               fwhm: float | None = None) -> np.ndarray:  # fmt: skip
        """A measure's curves ``(n_subjects, n_frames, k)`` (``axis`` and ``min_radius``
        are not used: the maps carry their directions). With ``fwhm`` (mm), every
        subject's map at every frame is smoothed on the atlas by the heat kernel of that
        full width at half maximum (:class:`~ladders.statistics.SurfaceSmoother`)."""
        if measure not in WALL_UNITS:
            raise ValueError(f"measure: the wall maps have {sorted(WALL_UNITS)}, not "
                             f"{measure!r} (the motion's measures need a cycle study)")  # fmt: skip
        curves = self.maps[measure]
        if fwhm is None:
            return curves
        return SurfaceSmoother(self.atlas, self.faces, float(fwhm))(curves)


def load_wall_cycles(folder) -> WallCycles:
    """The subjects whose maps :func:`~.cohort_wall.run_wall_maps` stored, in its order.

    Raises
    ------
    CohortError
        Not a wall folder, no subject stored, a subject's file unreadable or not of the
        atlas's vertices, or subjects with different numbers of frames.
    """
    folder = Path(folder)
    try:
        record = json.loads((folder / "wall.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        raise CohortError(f"study: {folder} has no readable wall.json (the output of "
                          "'symladders wall')") from None  # fmt: skip
    atlas, faces = read_mesh(folder / "atlas.vtk")
    names, stacks = [], {m: [] for m in WALL_UNITS}
    for name, status in record.get("subjects", {}).items():
        if status not in ("computed", "reused"):
            continue
        path = folder / f"{name}.npz"
        try:
            with np.load(path) as data:
                maps = WallMaps.from_arrays({k: data[k] for k in data.files})
        except (OSError, KeyError, ValueError) as exc:
            raise CohortError(f"study: {path}: cannot be read ({exc})") from None
        if maps.thickness.ndim != 2 or maps.thickness.shape[1] != len(atlas):
            raise CohortError(f"study: {path}: expected maps of the atlas's {len(atlas)} "
                              f"vertices, got shape {maps.thickness.shape}")  # fmt: skip
        if names and maps.n_frames != stacks["thickness"][0].shape[0]:
            raise CohortError(f"study: {path}: {maps.n_frames} frames, "
                              f"{names[0]} has {stacks['thickness'][0].shape[0]}")  # fmt: skip
        for m, unit in WALL_UNITS.items():
            stacks[m].append(maps.measure(m) * (100.0 if unit == "percent" else 1.0))
        names.append(name)
    if not names:
        raise CohortError(f"study: {folder} stores no subject's wall maps")
    return WallCycles(tuple(names), {m: np.stack(v) for m, v in stacks.items()}, atlas, faces)
