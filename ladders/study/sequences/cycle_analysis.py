"""Every subject's motion through the cycle on the atlas, and the curve each vertex follows.

From a cycle study (:func:`~.cycle_study.run_cycle_study`) every subject's motion at
every frame is a displacement field on the atlas, ``T'_t - T`` (:class:`CycleMotion`,
:func:`load_cycle_motion`). Its normal component on the atlas's outward vertex normals,
``n_t = <T'_t - T, nu>`` (mm, negative inward), is the wall-motion curve of each vertex
(:meth:`CycleMotion.normal`), what the tests of :mod:`.cycle_model` summarise per frame,
by its peak and time to peak and as a whole trajectory (:mod:`.cycle_responses`).

With ``measure="rotation"`` the curve of a vertex is instead its rotation about the
long axis, ``r_t`` (degrees, positive counter-clockwise seen from the apex,
:func:`~ladders.study.wall_rotation.rotation_about_axis`, the axis through the
atlas's apex and base-plane centre), the motion a twist changes and the normal motion
does not show. A vertex's peak is then taken in the sense its cohort turns: with
``m_t`` the mean curve over every subject (all groups, so that the choice does not
depend on the labels and the permutations stay exact), ``s = sign(m_t*)`` at the frame
of largest ``|m_t|``, and the peak is ``s max_t (s r_t)`` (signed degrees) with its
time. Vertices closer to the axis than ``min_radius`` (the apical cap) are not tested.

With a wall measure (``thickness``, ``thickening``, ``radial``, ``circumferential``,
``longitudinal``) the curves are a cohort's wall maps
(:class:`~ladders.study.wall.WallCycles`, from ``symladders wall``) instead of its
transported motion, and their peaks are taken in the sense the cohort moves, as the
rotation's.

With ``fwhm`` every subject's curve map at every frame is first smoothed on the
atlas by the heat kernel of that full width at half maximum (mm,
:class:`~ladders.statistics.SurfaceSmoother`), as vertex-wise surface analyses
smooth their data (FreeSurfer's ``mri_glmfit --fwhm``): the tracking's errors, which
vary from vertex to vertex, average out, while a regional effect of several
centimetres stays; the permutations stay exact (every subject is smoothed alike).
The rotation is smoothed over its vertices off the axis.
"""

from __future__ import annotations

import functools
import json
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...statistics import SurfaceSmoother
from ..errors import CohortError
from ..meshes.mesh_io import read_mesh
from ..wall_motion import outward_vertex_normals
from ..wall_rotation import rotation_about_axis

__all__ = ["MEASURES", "MOTION_MEASURES", "CycleMotion", "axis_points", "load_cycle_motion"]

#: What a cycle test measures at each vertex and frame, and its unit: the motion's, from a
#: cycle study (:class:`CycleMotion`), and the wall's, from the wall maps of ``symladders
#: wall`` (:class:`~ladders.study.wall.WallCycles`: thickness and thickening in mm, the
#: radial, circumferential and longitudinal strain in percent).
MEASURES = {"normal": "mm", "rotation": "deg", "thickness": "mm", "thickening": "mm",
            "radial": "percent", "circumferential": "percent", "longitudinal": "percent"}  # fmt: skip
#: The measures of a cycle study's transported motion (the others are the wall maps').
MOTION_MEASURES = ("normal", "rotation")


@dataclass(frozen=True)
class CycleMotion:
    """Every subject's transported motion through the cycle, on the atlas.

    Attributes
    ----------
    subjects : tuple of str
    displacement : ndarray, shape (n_subjects, n_frames, k, 3)
        ``T'_t - T`` (mm).
    atlas : ndarray, shape (k, 3)
    faces : ndarray of int, shape (f, 3)
    """

    subjects: tuple
    displacement: np.ndarray
    atlas: np.ndarray
    faces: np.ndarray

    def subset(self, subjects) -> CycleMotion:
        """The motion of ``subjects`` (names of this motion's), in their order."""
        index = {s: i for i, s in enumerate(self.subjects)}
        missing = [s for s in subjects if s not in index]
        if missing:
            raise CohortError(f"subjects: {missing[0]!r} not in the cycle study")
        rows = [index[s] for s in subjects]
        return CycleMotion(tuple(subjects), self.displacement[rows], self.atlas, self.faces)

    @property
    def fractions(self) -> np.ndarray:
        """The frames' times as fractions of the cycle, ``t / n_frames``."""
        n = self.displacement.shape[1]
        return np.arange(n) / n

    def normal(self) -> np.ndarray:
        """``n_t`` on the atlas's outward normals, shape ``(n_subjects, n_frames, k)``."""
        nu = outward_vertex_normals(self.atlas, self.faces)
        return np.einsum("stkd,kd->stk", self.displacement, nu)

    def rotation(self, apex, base, min_radius: float = 5.0) -> np.ndarray:
        """``r_t``: every vertex's rotation about the long axis, degrees, shape
        ``(n_subjects, n_frames, k)``; ``NaN`` at vertices closer to the axis than
        ``min_radius`` (see :func:`~ladders.study.wall_rotation.rotation_about_axis`).

        Parameters
        ----------
        apex, base : array, shape (3,)
            The atlas's apex and base-plane centre.
        min_radius : float, default 5.0
        """
        return rotation_about_axis(self.atlas, self.atlas + self.displacement, apex, base,
                                   min_radius)  # fmt: skip

    def curves(self, measure: str = "normal", axis=None, min_radius: float = 5.0,
               fwhm: float | None = None) -> np.ndarray:  # fmt: skip
        """The curve tested per vertex: :meth:`normal` or :meth:`rotation` about ``axis``
        (the apex and base-plane centre, shape ``(2, 3)``, or landmarks with ``apex``
        and ``base``); shape ``(n_subjects, n_frames, k)``. With ``fwhm`` (mm), every
        subject's map at every frame is smoothed on the atlas by the heat kernel of that
        full width at half maximum (:class:`~ladders.statistics.SurfaceSmoother`; the
        rotation over its vertices off the axis)."""
        if measure not in MOTION_MEASURES:
            raise ValueError(f"measure: expected one of {list(MOTION_MEASURES)} of a cycle study, "
                             f"got {measure!r}" + (" (a wall measure: test the maps of "
                             "'symladders wall')" if measure in MEASURES else ""))  # fmt: skip
        if measure == "normal":
            curves = self.normal()
        else:
            if axis is None:
                raise ValueError("axis: the rotation needs the atlas's apex and base-plane centre")
            apex, base = axis_points(axis)
            curves = self.rotation(apex, base, min_radius)
        if fwhm is None:
            return curves
        finite = np.isfinite(curves).all(axis=(0, 1))
        return _smoother(self.atlas, self.faces, fwhm, finite)(curves)


@functools.lru_cache(maxsize=8)
def _cached_smoother(atlas: bytes, faces: bytes, fwhm: float, mask: bytes) -> SurfaceSmoother:
    return SurfaceSmoother(np.frombuffer(atlas).reshape(-1, 3),
                           np.frombuffer(faces, dtype=np.int64).reshape(-1, 3), fwhm,
                           mask=np.frombuffer(mask, dtype=bool))  # fmt: skip


def _smoother(atlas, faces, fwhm: float, mask) -> SurfaceSmoother:
    """The atlas's smoother, built once for the calls on the same atlas, width and mask
    (a permutation null over random splits smooths every split on the same atlas)."""
    return _cached_smoother(np.asarray(atlas, dtype=np.float64).tobytes(),
                            np.asarray(faces, dtype=np.int64).tobytes(), float(fwhm),
                            np.asarray(mask, dtype=bool).tobytes())  # fmt: skip


def axis_points(axis) -> np.ndarray:
    """The apex and base-plane centre, rows of ``(2, 3)``, from landmarks or an array."""
    points = np.stack([axis.apex, axis.base]) if hasattr(axis, "apex") else axis
    return np.asarray(points, dtype=np.float64)


def load_cycle_motion(folder) -> CycleMotion:
    """The subjects stored by a cycle study (``cycle_study.json``), in its order.

    Raises
    ------
    CohortError
        Not a cycle study's folder, no subject stored, a subject's file unreadable or not
        of the atlas's vertices, or subjects with different numbers of frames (the
        first subject that differs from the most common count is named, with its file).
    """
    folder = Path(folder)
    try:
        record = json.loads((folder / "cycle_study.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        raise CohortError(f"study: {folder} has no readable cycle_study.json "
                          "(the output of 'symladders cycle-study')") from None  # fmt: skip
    atlas, faces = read_mesh(folder / "atlas.vtk")
    names, stacks = [], []
    for name, status in record.get("subjects", {}).items():
        if status not in ("computed", "reused"):
            continue
        path = folder / f"{name}.npz"
        try:
            with np.load(path) as data:
                frames = np.asarray(data["transported"], dtype=np.float64)
        except (OSError, KeyError, ValueError) as exc:
            raise CohortError(f"study: {path}: cannot be read ({exc})") from None
        if frames.ndim != 3 or frames.shape[1:] != atlas.shape:
            raise CohortError(f"study: {path}: expected frames of the atlas's {len(atlas)} "
                              f"vertices (n_frames, {len(atlas)}, 3), got {frames.shape}")  # fmt: skip
        stacks.append(frames - atlas)
        names.append(name)
    if not names:
        raise CohortError(f"study: {folder} stores no transported subject")
    counts = Counter(len(s) for s in stacks)
    if len(counts) > 1:  # name the first subject whose frames differ from the most common
        usual = counts.most_common(1)[0][0]
        odd = next(i for i, s in enumerate(stacks) if len(s) != usual)
        raise CohortError(
            f"study: subject {names[odd]!r} ({folder / (names[odd] + '.npz')}) has "
            f"{len(stacks[odd])} frames, {counts[usual]} of the {len(names)} subjects have "
            f"{usual}: every subject's cycle needs the same frames"
        )
    return CycleMotion(tuple(names), np.stack(stacks), atlas, faces)
