"""What the cycle's tests are run on: every vertex's curve, its peak, time to peak and trajectory.

:func:`cycle_responses` turns a :class:`~.cycle_analysis.CycleMotion` into the
responses of the per-vertex tests (:mod:`.cycle_model`), on the vertices tested:

* ``per_frame``: the curve at every frame, ``(n, n_frames, m)`` (the normal motion
  ``n_t`` in mm, or the rotation about the long axis in degrees);
* ``peak`` and ``time_to_peak``: the peak inward motion and its time in the cycle
  (:func:`~.peaks.curve_peaks`; for the rotation the peak in the sense the cohort
  turns, see :mod:`.cycle_analysis`), ``(n, m)``;
* ``trajectory``: the scores of each vertex's curve on its first principal components
  over the cycle, ``(n, m, d)`` (:func:`trajectory_components`), what the
  multivariate test of the whole trajectory (Pillai's trace) is run on.

The principal components are those of the pooled subjects (every subject of the
design, without its labels, so that the permutations stay exact): at each vertex the
curves are centred on their mean over the subjects and decomposed by the singular
value decomposition. The number ``d`` of components is the same at every vertex: the
fewest whose variance, summed over the tested vertices, reaches ``variance`` (0.9 by
default) of the curves' total variance, at least ``min_components`` (2) and at most
``max_components`` (5) and ``n - 3``. At least two, because a change of timing is
orthogonal to the curve it changes: a curve ``g`` shifted by ``delta`` in time is
``g - delta g'`` to first order, and over a periodic cycle ``g'`` is orthogonal to ``g``.
Curves that differ between subjects mostly by their amplitude put nearly all of their
variance in one component (the synthetic cohort's, with a tracking-like error: 90 to 96
%, ``benchmarks/bench_cycle_model.py``), where a delayed contraction is not: with one
component the trajectory test finds none of a delay of a tenth of the cycle, with two
most of it (the table ``cycle_model_power`` in ``docs/statistics.md``). The vertices' own components
differ (each vertex keeps the shape of its own curves); the test of their scores is the
test of the curves projected on them, and Pillai's trace does not depend on the basis
chosen within that space.

:func:`spatiotemporal_adjacency` links every tested vertex to its neighbours on the
atlas at the same frame and to itself at the neighbouring frames: the graph on which
threshold-free cluster enhancement of the per-frame maps rewards an effect extended
over the wall and over the cycle (MNE-Python's spatio-temporal clustering links time
points the same way).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ...statistics.tfce import mesh_adjacency
from .cycle_analysis import MEASURES, CycleMotion, axis_points
from .peaks import curve_peaks

__all__ = [
    "TRAJECTORY_VARIANCE",
    "TRAJECTORY_MIN_COMPONENTS",
    "TRAJECTORY_MAX_COMPONENTS",
    "CycleResponses",
    "TrajectoryComponents",
    "cycle_responses",
    "signed_peaks",
    "spatiotemporal_adjacency",
    "trajectory_components",
]

#: The fraction of the curves' variance the trajectory's components hold (the rule of ``d``).
TRAJECTORY_VARIANCE = 0.9
#: At least this many components per vertex (a curve's amplitude and its timing).
TRAJECTORY_MIN_COMPONENTS = 2
#: At most this many components per vertex.
TRAJECTORY_MAX_COMPONENTS = 5


@dataclass(frozen=True)
class TrajectoryComponents:
    """Every vertex's curves on their first principal components (:func:`trajectory_components`).

    Attributes
    ----------
    scores : ndarray, shape (n, m, d)
        Each subject's scores at each vertex.
    basis : ndarray, shape (m, n_frames, d)
        Each vertex's principal curves (orthonormal columns).
    mean : ndarray, shape (m, n_frames)
        Each vertex's mean curve over the subjects.
    explained : float
        The fraction of the total variance (summed over the vertices) the ``d``
        components hold.
    """

    scores: np.ndarray
    basis: np.ndarray
    mean: np.ndarray
    explained: float

    @property
    def n_components(self) -> int:
        """``d``."""
        return self.scores.shape[-1]


def trajectory_components(
    curves,
    variance: float = TRAJECTORY_VARIANCE,
    max_components: int = TRAJECTORY_MAX_COMPONENTS,
    n_components: int | None = None,
    min_components: int = TRAJECTORY_MIN_COMPONENTS,
) -> TrajectoryComponents:
    """The first principal components of every vertex's curves over the cycle (module rule).

    Parameters
    ----------
    curves : array, shape (n, n_frames, m)
        Every subject's curve at every vertex (finite).
    variance : float, default 0.9
        ``d`` is the fewest components holding this fraction of the variance summed
        over the vertices (in ``(0, 1]``).
    max_components : int, default 5
        At most this many (and at most ``n - 3`` and ``n_frames``).
    n_components : int, optional
        ``d`` itself (e.g. the vertices' for the segments' curves), instead of the rule.
    min_components : int, default 2
        At least this many (within the cap).

    Returns
    -------
    TrajectoryComponents
    """
    y = np.asarray(curves, dtype=np.float64)
    if y.ndim != 3 or not np.isfinite(y).all():
        raise ValueError(f"curves: expected finite curves (n, n_frames, m), got {y.shape}")
    if not 0.0 < float(variance) <= 1.0:
        raise ValueError(f"variance: expected a fraction in (0, 1], got {variance!r}")
    n, n_frames, _ = y.shape
    cap = min(int(max_components), n - 3, n_frames)
    if cap < 1:
        raise ValueError(f"curves: {n} subjects leave no principal component to test (need 4)")
    mean = y.mean(axis=0)  # (n_frames, m)
    centred = np.moveaxis(y - mean, -1, 0)  # (m, n, n_frames)
    u, s, vt = np.linalg.svd(centred, full_matrices=False)
    eigen = (s**2).sum(axis=0)  # variance per component, summed over the vertices
    total = eigen.sum()
    if n_components is None:
        reached = np.cumsum(eigen) >= float(variance) * total * (1.0 - 1e-12)
        d = int(np.argmax(reached)) + 1 if total > 0 else 1
        d = min(max(d, int(min_components)), cap)
    else:
        d = int(n_components)
        if not 1 <= d <= cap:
            raise ValueError(f"n_components: expected 1..{cap}, got {n_components!r}")
    scores = np.moveaxis(u[..., :d] * s[:, None, :d], 0, 1)  # (n, m, d)
    explained = float(eigen[:d].sum() / total) if total > 0 else 1.0
    return TrajectoryComponents(scores, np.transpose(vt[:, :d], (0, 2, 1)), mean.T, explained)


def signed_peaks(curves, measure: str = "normal") -> tuple[np.ndarray, np.ndarray]:
    """Peaks and times (:func:`~.peaks.curve_peaks`) of curves ``(n, n_frames, m)``: of the
    inward motion, or of the rotation in the sense the pooled subjects turn (the sign of
    the mean curve at its largest absolute value), signed degrees."""
    curves = np.asarray(curves, dtype=np.float64)
    if measure == "normal":
        return curve_peaks(curves)
    mean = curves.mean(axis=0)  # (n_frames, m), over every subject
    at = np.argmax(np.abs(mean), axis=0)
    sense = np.where(mean[at, np.arange(mean.shape[1])] < 0, -1.0, 1.0)
    peak, time = curve_peaks(-sense * curves)
    return sense * peak, time


def spatiotemporal_adjacency(faces, m: int, n_frames: int) -> sp.csr_matrix:
    """The adjacency of ``n_frames`` copies of a mesh of ``m`` vertices (frame-major
    index ``t m + v``): the mesh's edges within each frame, and every vertex linked to
    itself at the previous and the next frame."""
    spatial = mesh_adjacency(faces, m)
    path = sp.diags([np.ones(n_frames - 1), np.ones(n_frames - 1)], [-1, 1], (n_frames, n_frames))
    return sp.csr_matrix(sp.kron(sp.identity(n_frames), spatial) + sp.kron(path, sp.identity(m)))


def sub_faces(faces: np.ndarray, tested: np.ndarray) -> np.ndarray:
    """The triangles between tested vertices, indexed among them."""
    index = np.cumsum(tested) - 1
    return index[faces[tested[faces].all(axis=1)]]


@dataclass(frozen=True)
class CycleResponses:
    """The responses of the cycle's tests (:func:`cycle_responses`).

    Attributes
    ----------
    subjects : tuple of str
    curves : ndarray, shape (n, n_frames, k)
        The curves on every atlas vertex (``NaN`` for the rotation near the axis).
    tested : ndarray of bool, shape (k,)
    peaks, times : ndarray, shape (n, k)
        ``NaN`` where the curve is not finite.
    trajectory : TrajectoryComponents
        On the tested vertices.
    faces : ndarray of int, shape (f, 3)
        The triangles between tested vertices, indexed among them (``m`` vertices).
    measure : str
    axis : ndarray, shape (2, 3), or None
    min_radius : float
    fwhm : float or None
    """

    subjects: tuple
    curves: np.ndarray
    tested: np.ndarray
    peaks: np.ndarray
    times: np.ndarray
    trajectory: TrajectoryComponents
    faces: np.ndarray
    measure: str = "normal"
    axis: np.ndarray | None = None
    min_radius: float = 5.0
    fwhm: float | None = None

    def maps(self) -> dict:
        """``{summary: responses on the tested vertices}``: ``per_frame`` ``(n, n_frames * m)``
        (frame-major), ``peak`` and ``time_to_peak`` ``(n, m)``, ``trajectory`` ``(n, m, d)``."""
        n, n_frames, _ = self.curves.shape
        on = self.tested
        return {
            "per_frame": self.curves[..., on].reshape(n, n_frames * int(on.sum())),
            "peak": self.peaks[:, on],
            "time_to_peak": self.times[:, on],
            "trajectory": self.trajectory.scores,
        }


def tested_vertices(vertices, k: int) -> np.ndarray:
    """The mask of tested vertices: every vertex, or ``vertices`` checked."""
    if vertices is None:
        return np.ones(k, dtype=bool)
    mask = np.asarray(vertices)
    if mask.shape != (k,) or mask.dtype != bool:
        raise ValueError(f"vertices: expected {k} booleans (one per atlas vertex), got an array "
                         f"of shape {mask.shape} and type {mask.dtype}")  # fmt: skip
    if mask.sum() < 2:
        raise ValueError(f"vertices: expected at least 2 vertices tested, got {int(mask.sum())}")
    return mask


def cycle_responses(
    motion: CycleMotion,
    measure: str = "normal",
    axis=None,
    min_radius: float = 5.0,
    fwhm: float | None = None,
    vertices=None,
    variance: float = TRAJECTORY_VARIANCE,
    max_components: int = TRAJECTORY_MAX_COMPONENTS,
    min_components: int = TRAJECTORY_MIN_COMPONENTS,
) -> CycleResponses:
    """The responses of the cycle's tests on ``motion`` (see the module).

    Parameters
    ----------
    motion : CycleMotion
    measure : {"normal", "rotation"}
    axis : array (2, 3) or Landmarks, optional
        The atlas's apex and base-plane centre: required for the rotation.
    min_radius : float, default 5.0
        For the rotation: vertices closer to the axis (mm) are not tested.
    fwhm : float, optional
        Every map smoothed on the atlas first (mm, full width at half maximum).
    vertices : array of bool, shape (k,), optional
        The vertices tested (default all).
    variance, max_components, min_components : the rule of the trajectory's components.

    Returns
    -------
    CycleResponses
    """
    if measure not in MEASURES:
        raise ValueError(f"measure: expected one of {sorted(MEASURES)}, got {measure!r}")
    fwhm = None if fwhm is None else float(fwhm)  # checked by the smoother
    curves = motion.curves(measure, axis, min_radius, fwhm)
    n, _, k = curves.shape
    tested = tested_vertices(vertices, k)
    finite = np.isfinite(curves).all(axis=(0, 1))  # the rotation's vertices off the axis
    if measure == "rotation":
        tested = tested & finite
        if tested.sum() < 2:
            raise ValueError(f"min_radius: fewer than 2 vertices tested are {min_radius} mm "
                             "or more from the long axis")  # fmt: skip
        axis = axis_points(axis)
    else:
        axis = None
    peaks, times = np.full((n, k), np.nan), np.full((n, k), np.nan)
    peaks[:, finite], times[:, finite] = signed_peaks(curves[..., finite], measure)
    trajectory = trajectory_components(curves[..., tested], variance, max_components,
                                       min_components=min_components)  # fmt: skip
    faces = sub_faces(np.asarray(motion.faces), tested)
    return CycleResponses(tuple(motion.subjects), curves, tested, peaks, times, trajectory, faces,
                          measure, axis, float(min_radius), fwhm)  # fmt: skip
