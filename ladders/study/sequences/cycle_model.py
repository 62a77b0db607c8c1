"""The linear model on whole cycles: per frame, peak, time to peak and the whole trajectory.

:func:`cycle_model` tests one contrast of a linear model (covariates, several groups:
:func:`ladders.statistics.design_matrix`, :func:`ladders.statistics.contrast_matrix`)
on every summary of the cycle's curves (:mod:`.cycle_responses`), at every tested
vertex, by :func:`~ladders.study.population.model_comparison.model_tests` (the
per-vertex tests of ``symladders analyze --design``: Freedman-Lane permutations,
family-wise error by the maximum statistic, one permutation stream):

* ``per_frame``: ``t`` (one-row contrast) or ``F`` at every vertex and frame, FWER
  over the vertices and the frames together;
* ``peak`` and ``time_to_peak``: ``t`` or ``F`` per vertex, FWER over the vertices;
* ``trajectory``: Pillai's trace of the multivariate linear model of each vertex's
  scores on its first principal components over the cycle (the whole curve, its
  amplitude and its timing at once), FWER over the vertices.

With ``tfce=True`` every summary is also enhanced (threshold-free cluster enhancement,
``H = 2``, ``E = 1``, both tails of a ``t``) on the atlas's triangles between tested
vertices, the per-frame maps on the spatio-temporal graph
(:func:`~.cycle_responses.spatiotemporal_adjacency`), each with its own family-wise
p-values. With ``segments`` (the AHA segment of every vertex) the same tests run on
each segment's mean curve over its tested vertices, corrected over the segments.

:func:`compare_cycles` is the two-group case: the model ``group`` and the contrast of
the two groups (for which ``t`` is the two-sample ``t`` and the Freedman-Lane
permutations of the residuals are permutations of the labels).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ...statistics import Design, check_groups, contrast_matrix, design_matrix
from ...statistics.permutation_glm import GLMTest
from ...statistics.tfce import mesh_adjacency
from ..errors import CohortError
from ..population.model_comparison import model_tests
from .cycle_analysis import MEASURES, CycleMotion
from .cycle_responses import (
    CycleResponses,
    cycle_responses,
    signed_peaks,
    spatiotemporal_adjacency,
    trajectory_components,
)

__all__ = ["SUMMARIES", "CycleTests", "compare_cycles", "cycle_model", "segment_curves"]

#: The summaries of the cycle tested per vertex, in the order of the outputs.
SUMMARIES = ("per_frame", "peak", "time_to_peak", "trajectory")

#: The per-vertex maps of a GLMTest.
_MAPS = ("statistic", "p_uncorrected", "p_fwer", "enhanced", "p_fwer_enhanced")


@dataclass(frozen=True)
class CycleTests:
    """One contrast tested on the cycle (:func:`cycle_model`, :func:`compare_cycles`).

    Attributes
    ----------
    per_frame : GLMTest or None
        Maps of shape ``(n_frames, k)`` (``statistic``, ``p_fwer``: FWER over vertices
        and frames, and the TFCE maps); frame 0 (ED, no motion) has statistic 0.
    peak, time_to_peak : GLMTest or None
        Per vertex, FWER over the vertices (None: a summary not tested).
    peaks, times : ndarray, shape (n_subjects, k)
        Every subject's peak (inward motion in mm, or signed rotation in degrees) and
        time to peak (fraction of the cycle).
    labels : ndarray of bool, shape (n_subjects,), or None
        Two groups compared (:func:`compare_cycles`): True for the first.
    trajectory : GLMTest or None
        Pillai's trace per vertex on the first ``components`` principal components.
    tested : ndarray of bool, shape (k,)
        The vertices tested (the others have ``NaN`` maps).
    measure : str
        ``"normal"`` or ``"rotation"``.
    axis : ndarray, shape (2, 3), or None
        The apex and base-plane centre of the rotation.
    min_radius : float
    fwhm : float or None
        The smoothing of every map before the tests (mm); None: not smoothed.
    contrast : str
    design : Design or None
    components : int
        The trajectory's principal components per vertex.
    explained : float
        The fraction of the curves' variance they hold.
    segments : ndarray of int, shape (k,), or None
        The AHA segment of every vertex.
    segment_tests : dict or None
        ``{summary: GLMTest}`` on the segments' mean curves (``per_frame``: maps
        ``(n_frames, 17)``), ``NaN`` for a segment without a tested vertex.
    """

    per_frame: GLMTest | None
    peak: GLMTest | None
    time_to_peak: GLMTest | None
    peaks: np.ndarray
    times: np.ndarray
    labels: np.ndarray | None = None
    trajectory: GLMTest | None = None
    tested: np.ndarray | None = None
    measure: str = "normal"
    axis: np.ndarray | None = None
    min_radius: float = 5.0
    fwhm: float | None = None
    contrast: str = ""
    design: Design | None = None
    components: int = 0
    explained: float = float("nan")
    segments: np.ndarray | None = None
    segment_tests: dict | None = None

    @property
    def unit(self) -> str:
        """The peaks' unit: ``"mm"`` or ``"deg"``."""
        return MEASURES[self.measure]

    @property
    def peak_tfce(self) -> GLMTest | None:
        """The peak's test when it carries its TFCE maps (``tfce=True``), else None."""
        return self.peak if self.peak is not None and self.peak.enhanced is not None else None

    def tests(self) -> dict:
        """``{summary: GLMTest}`` in the order of :data:`SUMMARIES` (those tested)."""
        out = {"per_frame": self.per_frame, "peak": self.peak, "time_to_peak": self.time_to_peak,
               "trajectory": self.trajectory}  # fmt: skip
        return {s: t for s, t in out.items() if t is not None}

    @property
    def tfce(self) -> bool:
        """Whether the tests carry their TFCE maps."""
        return any(t.enhanced is not None for t in self.tests().values())

    def detected(self, summary: str = "peak", alpha: float = 0.05, tfce: bool = False):
        """Vertices whose family-wise p (of the TFCE maps if ``tfce``) is below ``alpha``;
        for ``per_frame``, at some frame. Shape ``(k,)``."""
        tests = self.tests()
        if summary not in tests:
            raise ValueError(f"summary: expected one of {tuple(tests)}, got {summary!r}")
        r = tests[summary]
        if tfce and r.p_fwer_enhanced is None:
            raise ValueError("tfce: these tests were run without TFCE")
        found = (r.p_fwer_enhanced if tfce else r.p_fwer) < alpha
        return found.any(axis=0) if summary == "per_frame" else found

    def curves(self, motion: CycleMotion) -> np.ndarray:
        """The curves these tests were computed on, ``(n_subjects, n_frames, k)``."""
        return motion.curves(self.measure, self.axis, self.min_radius, self.fwhm)


def _spread(values, tested: np.ndarray, axis: int):
    """A map over the tested vertices (along ``axis``), on every vertex (``NaN`` elsewhere)."""
    if values is None:
        return None
    values = np.moveaxis(np.asarray(values, dtype=np.float64), axis, -1)
    out = np.full(values.shape[:-1] + tested.shape, np.nan)
    out[..., tested] = values
    return np.moveaxis(out, -1, axis)


def _on_atlas(test: GLMTest, tested: np.ndarray, n_frames: int | None = None) -> GLMTest:
    """``test``'s maps on every atlas vertex; per frame ``(n_frames, k)``."""
    m = int(tested.sum())
    fields = {}
    for name in _MAPS:
        value = getattr(test, name)
        if value is not None:
            value = value.reshape(n_frames, m) if n_frames else value
            fields[name] = _spread(value, tested, -1)
    effect = test.effect
    if effect is not None:
        if n_frames:
            fields["effect"] = _spread(effect.reshape(effect.shape[0], n_frames, m), tested, -1)
        else:
            fields["effect"] = _spread(effect, tested, 1)
    return replace(test, **fields)


def segment_curves(curves, segments, tested) -> tuple[np.ndarray, np.ndarray]:
    """Each segment's mean curve over its tested vertices, ``(n, n_frames, 17)``, and the
    mask of the segments with a tested vertex."""
    labels = np.asarray(segments)
    members = (labels[None, :] == np.arange(1, 18)[:, None]) & np.asarray(tested)[None, :]
    present = members.any(axis=1)
    weights = members[present] / members[present].sum(axis=1, keepdims=True)
    means = np.full(curves.shape[:2] + (17,), np.nan)
    means[..., present] = np.einsum("sk,ntk->nts", weights, np.nan_to_num(curves))
    return means, present


def _check_summaries(summaries) -> tuple:
    summaries = tuple(summaries)
    bad = [s for s in summaries if s not in SUMMARIES]
    if bad or not summaries:
        raise ValueError(f"summaries: expected some of {SUMMARIES}, got {summaries!r}")
    return summaries


def _segment_tests(responses: CycleResponses, segments, design, c, n_permutations, rng,
                   options, summaries) -> dict:  # fmt: skip
    means, present = segment_curves(responses.curves, segments, responses.tested)
    curves = means[..., present]
    n, n_frames, s = curves.shape
    peaks, times = signed_peaks(curves, responses.measure)
    maps = {"per_frame": curves.reshape(n, n_frames * s), "peak": peaks, "time_to_peak": times}
    if "trajectory" in summaries:
        d = responses.trajectory.n_components
        maps["trajectory"] = trajectory_components(curves, n_components=d).scores
    maps = {name: maps[name] for name in summaries}
    tests = model_tests(maps, design, c, n_permutations, rng, **options)
    return {name: _on_atlas(t, present, n_frames if name == "per_frame" else None)
            for name, t in tests.items()}  # fmt: skip


def cycle_model(
    responses: CycleResponses,
    design: Design,
    contrast,
    n_permutations: int = 5000,
    rng: np.random.Generator | None = None,
    *,
    tfce: bool = False,
    blocks=None,
    segments=None,
    method: str = "freedman_lane",
    progress: bool = False,
    summaries=SUMMARIES,
) -> CycleTests:
    """Test one contrast of a linear model on every summary of the cycle (see the module).

    Parameters
    ----------
    responses : CycleResponses
        From :func:`~.cycle_responses.cycle_responses`, its subjects those of the design
        in its order.
    design : Design
    contrast : str or array, shape (q, p)
        :func:`ladders.statistics.contrast_matrix`.
    n_permutations : int, default 5000
    rng : numpy.random.Generator
        Draws the permutations (required); the tests use one stream.
    tfce : bool
        Also threshold-free cluster enhancement of every summary's maps.
    blocks : array, shape (n,), optional
        Exchangeability blocks: permutations within blocks only.
    segments : int array, shape (k,), optional
        The AHA segment (1-17) of every atlas vertex: also the segments' tests.
    method : {"freedman_lane", "manly", "draper_stoneman"}
    progress : bool
    summaries : sequence of str, default :data:`SUMMARIES`
        The summaries tested (in this order, one permutation stream); the others are None.

    Returns
    -------
    CycleTests
    """
    summaries = _check_summaries(summaries)
    if list(design.subjects) != list(responses.subjects):
        raise CohortError("design: its subjects are not the cycle's, in the cycle's order")
    name, c = contrast_matrix(design, contrast)
    tested = responses.tested
    n_frames, m = responses.curves.shape[1], int(tested.sum())
    graphs = None
    if tfce:
        spatial = mesh_adjacency(responses.faces, m)
        graphs = {"per_frame": spatiotemporal_adjacency(responses.faces, m, n_frames),
                  "peak": spatial, "time_to_peak": spatial, "trajectory": spatial}  # fmt: skip
    options = {"method": method, "blocks": blocks, "progress": progress}
    maps = responses.maps()
    tests = model_tests({s: maps[s] for s in summaries}, design, c, n_permutations, rng,
                        adjacency=graphs, **options)  # fmt: skip
    on_atlas = {s: _on_atlas(t, tested, n_frames if s == "per_frame" else None)
                for s, t in tests.items()}  # fmt: skip
    segment_tests = None
    if segments is not None:
        segments = np.asarray(segments)
        segment_tests = _segment_tests(responses, segments, design, c, n_permutations, rng,
                                       options, summaries)  # fmt: skip
    r = responses
    return CycleTests(
        on_atlas.get("per_frame"), on_atlas.get("peak"), on_atlas.get("time_to_peak"), r.peaks,
        r.times, None, on_atlas.get("trajectory"), tested, r.measure, r.axis, r.min_radius, r.fwhm, name,
        design, r.trajectory.n_components, r.trajectory.explained, segments, segment_tests,
    )  # fmt: skip


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
    summaries=SUMMARIES,
) -> CycleTests:
    """Test two groups' cycles: :func:`cycle_model` with the model ``group`` (see the module).

    Parameters
    ----------
    motion : CycleMotion
    groups : array of bool, shape (n_subjects,), or dict ``{subject: bool}``
        True for the first group (e.g. the patients); at least 3 subjects per group.
    n_permutations : int, default 5000
    rng : numpy.random.Generator
        Draws the permutations (required); the tests use one stream.
    tfce : bool, default False
        Also threshold-free cluster enhancement of every summary on the atlas's mesh.
    vertices : array of bool, shape (k,), optional
        The atlas's vertices tested (default all); TFCE runs on the triangles between
        them.
    measure : {"normal", "rotation"}, default "normal"
    axis : array (2, 3) or Landmarks, optional
        The atlas's apex and base-plane centre: required for the rotation.
    min_radius : float, default 5.0
        For the rotation: vertices closer to the axis than this (mm) are not tested.
    fwhm : float, optional
        Smooth every subject's map at every frame on the atlas first (mm, full width at
        half maximum; :mod:`.cycle_analysis`).
    summaries : sequence of str, default :data:`SUMMARIES`
        The summaries tested.

    Returns
    -------
    CycleTests
        With ``labels``.
    """
    if isinstance(groups, dict):
        missing = [s for s in motion.subjects if s not in groups]
        if missing:
            raise CohortError(f"groups: no group for subject(s) {missing}")
        groups = [bool(groups[s]) for s in motion.subjects]
    labels = np.asarray(groups, dtype=bool)
    if labels.shape != (len(motion.subjects),):
        raise ValueError(f"groups: expected {len(motion.subjects)} labels, got {labels.shape}")
    labels = check_groups(labels, len(labels))
    table = {"subject": list(motion.subjects),
             "group": ["first" if x else "second" for x in labels]}  # fmt: skip
    design = design_matrix(table, "group")
    responses = cycle_responses(motion, measure, axis, min_radius, fwhm, vertices)
    tests = cycle_model(responses, design, "group[first] - group[second]", n_permutations, rng,
                        tfce=tfce, summaries=summaries)  # fmt: skip
    return replace(tests, labels=labels)
