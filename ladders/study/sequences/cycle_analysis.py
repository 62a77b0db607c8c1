"""Group tests on whole cycles: per frame, and on the peak and time to peak of the normal motion.

From a cycle study (:func:`~.cycle_study.run_cycle_study`) every subject's motion at
every frame is a displacement field on the atlas, ``T'_t - T``. Its normal component on
the atlas's outward vertex normals, ``n_t = <T'_t - T, nu>`` (mm, negative inward),
is the wall-motion curve of each vertex. Tests (two groups, permutation, family-wise
error by the maximum statistic):

* per frame: the ``t`` statistic of ``n_t`` at every vertex and frame, FWER over the
  vertices and the frames together (the maximum is taken over both);
* the peak inward motion ``max_t (-n_t)`` per vertex, FWER over the vertices;
* the time to that peak, as a fraction of the cycle, refined between frames by the
  parabola through the peak frame and its two neighbours, FWER over the vertices.

With ``measure="rotation"`` the curve of a vertex is instead its rotation about the
long axis, ``r_t`` (degrees, positive counter-clockwise seen from the apex,
:func:`~ladders.study.wall_rotation.rotation_about_axis`, the axis through the
atlas's apex and base-plane centre), the motion a twist changes and the normal motion
does not show. A vertex's peak is taken in the sense its cohort turns: with ``m_t``
the mean curve over every subject (both groups, so the choice does not depend on the
labels and the permutations stay exact), ``s = sign(m_t*)`` at the frame of largest
``|m_t|``, and the peak is ``s max_t (s r_t)`` (signed degrees) with its time. Vertices
closer to the axis than ``min_radius`` (the apical cap) are not tested.

With a wall measure (``thickness``, ``thickening``, ``radial``, ``circumferential``,
``longitudinal``) the curves are a cohort's wall maps
(:class:`~ladders.study.wall.WallCycles`, from ``symladders wall``) instead of its
transported motion, and their peaks are taken in the sense the cohort moves, as the
rotation's.

With ``vertices`` only part of the atlas is tested (e.g. without the apical cap, AHA
segment 17, which thick short-axis slices resolve poorly): the FWER is over those
vertices, and the others have ``NaN`` statistics and p-values.

With ``fwhm`` every subject's curve map at every frame is first smoothed on the
atlas by the heat kernel of that full width at half maximum (mm,
:class:`~ladders.statistics.SurfaceSmoother`), as vertex-wise surface analyses
smooth their data (FreeSurfer's ``mri_glmfit --fwhm``): the tracking's errors, which
vary from vertex to vertex, average out, while a regional effect of several
centimetres stays; the permutations stay exact (every subject is smoothed alike).
The rotation is smoothed over its vertices off the axis.

With ``tfce=True`` the peak is also tested with threshold-free cluster enhancement
on the atlas's mesh (:func:`~ladders.statistics.glm_test`, ``H = 2``, ``E = 1``, FWER
over the vertices of the enhanced maps): a regional effect measured through noisy
tracking keeps its spatial extent while the tracking's errors, rougher across the
wall, do not (``docs/tracking.md``).
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ...statistics import SurfaceSmoother, glm_test, vertexwise_test
from ...statistics.group_tests import VertexwiseTest
from ...statistics.permutation_glm import GLMTest
from ...statistics.tfce import mesh_adjacency
from ..errors import CohortError
from ..meshes.mesh_io import read_mesh
from ..wall_motion import outward_vertex_normals
from ..wall_rotation import rotation_about_axis
from .peaks import curve_peaks

__all__ = ["CycleMotion", "CycleTests", "compare_cycles", "load_cycle_motion"]

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
            apex, base = _axis_points(axis)
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


def _axis_points(axis) -> np.ndarray:
    """The apex and base-plane centre, rows of ``(2, 3)``, from landmarks or an array."""
    points = np.stack([axis.apex, axis.base]) if hasattr(axis, "apex") else axis
    return np.asarray(points, dtype=np.float64)


def load_cycle_motion(folder) -> CycleMotion:
    """The subjects stored by a cycle study (``cycle_study.json``), in its order.

    Raises
    ------
    CohortError
        Not a cycle study's folder, no subject stored, or subjects with different
        numbers of frames.
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
        with np.load(folder / f"{name}.npz") as data:
            stacks.append(data["transported"] - atlas)
        names.append(name)
    if not names:
        raise CohortError(f"study: {folder} stores no transported subject")
    counts = {len(s) for s in stacks}
    if len(counts) > 1:
        per = {n: len(s) for n, s in zip(names, stacks)}
        raise CohortError(f"study: the subjects have different numbers of frames: {per}")
    return CycleMotion(tuple(names), np.stack(stacks), atlas, faces)


@dataclass(frozen=True)
class CycleTests:
    """The tests of :func:`compare_cycles`.

    Attributes
    ----------
    per_frame : VertexwiseTest
        ``t`` maps of shape ``(n_frames, k)`` (``statistic``, ``p_fwer``: FWER over
        vertices and frames); frame 0 (ED, no motion) has statistic 0 and ``p`` 1.
    peak, time_to_peak : VertexwiseTest
        Per vertex, FWER over the vertices.
    peaks, times : ndarray, shape (n_subjects, k)
        Every subject's peak inward motion (mm) and time to peak (fraction of the cycle).
    labels : ndarray of bool, shape (n_subjects,)
    peak_tfce : GLMTest or None
        With ``tfce=True``: the peak's ``t`` (first group minus second) and its
        threshold-free cluster enhancement, ``p_fwer_enhanced`` per vertex.
    tested : ndarray of bool, shape (k,), or None
        The vertices tested (the others have ``NaN`` maps); None: all.
    measure : str
        ``"normal"`` (peaks in mm, inward positive) or ``"rotation"`` (signed degrees).
    axis : ndarray, shape (2, 3), or None
        The apex and base-plane centre of the rotation; None for the normal motion.
    min_radius : float
        The rotation's distance to the axis below which vertices are not tested.
    fwhm : float or None
        The full width at half maximum (mm) of the smoothing of every map before the
        tests; None: not smoothed.
    """

    per_frame: VertexwiseTest
    peak: VertexwiseTest
    time_to_peak: VertexwiseTest
    peaks: np.ndarray
    times: np.ndarray
    labels: np.ndarray
    peak_tfce: GLMTest | None = None
    tested: np.ndarray | None = None
    measure: str = "normal"
    axis: np.ndarray | None = None
    min_radius: float = 5.0
    fwhm: float | None = None

    @property
    def unit(self) -> str:
        """The peaks' unit: ``"mm"`` or ``"deg"``."""
        return MEASURES[self.measure]

    def curves(self, motion: CycleMotion) -> np.ndarray:
        """The curves these tests were computed on, ``(n_subjects, n_frames, k)``."""
        return motion.curves(self.measure, self.axis, self.min_radius, self.fwhm)


#: The per-vertex maps of a VertexwiseTest, and those a GLMTest adds.
_MAPS = ("statistic", "p_uncorrected", "p_fwer")
_GLM_MAPS = (*_MAPS, "enhanced", "p_fwer_enhanced")


def _tested(vertices, k: int) -> np.ndarray:
    if vertices is None:
        return np.ones(k, dtype=bool)
    mask = np.asarray(vertices)
    if mask.shape != (k,) or mask.dtype != bool:
        raise ValueError(f"vertices: expected {k} booleans (one per atlas vertex), got an array "
                         f"of shape {mask.shape} and type {mask.dtype}")  # fmt: skip
    if mask.sum() < 2:
        raise ValueError(f"vertices: expected at least 2 vertices tested, got {int(mask.sum())}")
    return mask


def _sub_faces(faces: np.ndarray, tested: np.ndarray) -> np.ndarray:
    """The triangles between tested vertices, indexed among them."""
    index = np.cumsum(tested) - 1
    return index[faces[tested[faces].all(axis=1)]]


def _spread(values, tested: np.ndarray):
    """A map over the tested vertices, on every vertex (``NaN`` where not tested)."""
    if values is None:
        return None
    values = np.asarray(values, dtype=np.float64)
    out = np.full(values.shape[:-1] + tested.shape, np.nan)
    out[..., tested] = values
    return out


def _spread_maps(result, tested: np.ndarray, fields=_MAPS):
    """``result`` (a VertexwiseTest or GLMTest) with its maps spread onto every vertex."""
    return replace(result, **{f: _spread(getattr(result, f), tested) for f in fields})


def _reshaped(test: VertexwiseTest, shape) -> VertexwiseTest:
    return VertexwiseTest(test.statistic.reshape(shape), test.p_uncorrected.reshape(shape),
                          test.p_fwer.reshape(shape), test.max_null, test.n_permutations,
                          test.kind, test.dim, test.group_sizes)  # fmt: skip


def _signed_peaks(curves: np.ndarray, measure: str) -> tuple[np.ndarray, np.ndarray]:
    """Peaks and times: of the inward motion, or of the rotation in the cohort's sense."""
    if measure == "normal":
        return curve_peaks(curves)
    mean = curves.mean(axis=0)  # (n_frames, k), over both groups
    at = np.argmax(np.abs(mean), axis=0)
    sense = np.where(mean[at, np.arange(mean.shape[1])] < 0, -1.0, 1.0)
    peak, time = curve_peaks(-sense * curves)
    return sense * peak, time


def compare_cycles(
    motion: CycleMotion,
    groups,
    n_permutations: int = 5000,
    rng: np.random.Generator | None = None,
    tfce: bool = False,
    vertices=None,
    measure: str = "normal",
    axis=None,
    min_radius: float = 5.0,
    fwhm: float | None = None,
) -> CycleTests:
    """Test two groups' cycles per frame and on the peak and time to peak (see the module).

    Parameters
    ----------
    motion : CycleMotion or WallCycles
        The curves tested (a wall measure needs the wall maps,
        :func:`~ladders.study.wall.load_wall_cycles`).
    groups : array of bool, shape (n_subjects,), or dict ``{subject: bool}``
        True for the first group (e.g. the patients).
    n_permutations : int, default 5000
    rng : numpy.random.Generator
        Draws the permutations (required); the tests use one stream.
    tfce : bool, default False
        Also test the peak with threshold-free cluster enhancement on the atlas's mesh.
    vertices : array of bool, shape (k,), optional
        The atlas's vertices tested (default all); TFCE runs on the triangles between
        them.
    measure : str, default "normal"
        One of :data:`MEASURES`: of a :class:`CycleMotion`, the normal motion (mm) or the
        rotation about the long axis (degrees); of a :class:`~ladders.study.wall.WallCycles`
        (``motion``), a wall measure (thickness, thickening, strains), whose peak is taken
        in the sense its cohort moves, as the rotation's.
    axis : array (2, 3) or Landmarks, optional
        The atlas's apex and base-plane centre (rows), or its landmarks: required for
        the rotation.
    min_radius : float, default 5.0
        For the rotation: vertices closer to the axis than this (mm) are not tested.
    fwhm : float, optional
        Smooth every subject's map at every frame on the atlas before the tests, by
        the heat kernel of this full width at half maximum (mm; see the module).

    Returns
    -------
    CycleTests
    """
    if isinstance(groups, dict):
        missing = [s for s in motion.subjects if s not in groups]
        if missing:
            raise CohortError(f"groups: no group for subject(s) {missing}")
        groups = [bool(groups[s]) for s in motion.subjects]
    labels = np.asarray(groups, dtype=bool)
    if labels.shape != (len(motion.subjects),):
        raise ValueError(f"groups: expected {len(motion.subjects)} labels, got {labels.shape}")
    fwhm = None if fwhm is None else float(fwhm)  # checked by the smoother
    curves = motion.curves(measure, axis, min_radius, fwhm)
    n, n_frames, k = curves.shape
    tested = _tested(vertices, k)
    finite = np.isfinite(curves).all(axis=(0, 1))  # the rotation's vertices off the axis
    if measure == "rotation":
        tested = tested & finite
        if tested.sum() < 2:
            raise ValueError(f"min_radius: fewer than 2 vertices tested are {min_radius} mm "
                             "or more from the long axis")  # fmt: skip
        axis = _axis_points(axis)
    else:
        axis = None
    m = int(tested.sum())
    peaks, times = np.full((n, k), np.nan), np.full((n, k), np.nan)
    peaks[:, finite], times[:, finite] = _signed_peaks(curves[..., finite], measure)
    per_frame = vertexwise_test(curves[..., tested].reshape(n, n_frames * m), labels,
                                n_permutations, rng)  # fmt: skip
    peak = vertexwise_test(peaks[:, tested], labels, n_permutations, rng)
    timing = vertexwise_test(times[:, tested], labels, n_permutations, rng)
    enhanced = None
    if tfce:
        design = np.c_[labels.astype(float), (~labels).astype(float)]  # the two group means
        faces = _sub_faces(motion.faces, tested)
        enhanced = glm_test(peaks[:, tested], design, np.array([[1.0, -1.0]]), n_permutations,
                            rng, method="manly", tfce=mesh_adjacency(faces, m))  # fmt: skip
        if m < k:
            enhanced = _spread_maps(enhanced, tested, _GLM_MAPS)
    per_frame = _reshaped(per_frame, (n_frames, m))
    if m < k:
        per_frame, peak, timing = (_spread_maps(t, tested) for t in (per_frame, peak, timing))
    return CycleTests(per_frame, peak, timing, peaks, times, labels, enhanced, tested, measure,
                      axis, float(min_radius), fwhm)  # fmt: skip
