"""The linear-model analysis of a cycle study's folder, as ``symladders cycle-analyze`` runs it.

:func:`analyze_cycle_model` reads a cycle study (:func:`~.cycle_analysis.load_cycle_motion`)
and a design table, checks them against each other before any computation
(:func:`~ladders.study.population.model_design`, as ``symladders analyze --design``
does), tests every contrast on every summary of the cycle (:func:`~.cycle_model.cycle_model`:
per frame, peak, time to peak, trajectory; with TFCE and AHA segments) and writes the
analysis folder (:func:`~.cycle_outputs.write_cycle_tests`). :func:`analyze_cycle_outcome`
predicts a survival outcome from the cycle's curves
(:func:`~ladders.study.population.predict_outcome`, the Cox model of ``symladders
analyze --outcome``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from manifolds.validation import check_int

from ..errors import CohortError
from ..population.aha_model import aha_segments
from ..population.model_design import ModelDesign, check_design_table, model_design
from ..population.outcome_analysis import OutcomeOutcome, predict_outcome
from .cycle_analysis import CycleMotion, load_cycle_motion
from .cycle_model import SUMMARIES, cycle_model
from .cycle_outputs import write_cycle_tests
from .cycle_responses import cycle_responses

__all__ = ["CycleLabel", "CycleModelOutcome", "analyze_cycle_model", "analyze_cycle_outcome"]

_STUDY = "the cycle study"


@dataclass(frozen=True)
class CycleLabel:
    """The cycle study's motion, named as a study's motions are (in the outcome tables)."""

    name: str = "cycle"
    label: str = "whole cycle"
    deformation: str = ""
    method: str = "pole_ladder_residual"
    alpha2: float | None = None

    @classmethod
    def of(cls, folder, measure: str = "normal") -> CycleLabel:
        """The label of a cycle study's folder (its deformation and alpha^2, if recorded)."""
        try:
            record = json.loads((Path(folder) / "cycle_study.json").read_text(encoding="utf-8"))
            settings = record.get("settings", {})
            alpha2 = settings.get("alpha2")
            alpha2 = float(alpha2[0] if isinstance(alpha2, list) else alpha2)
        except (OSError, ValueError, TypeError, IndexError, AttributeError):
            settings, alpha2 = {}, None
        curve = {"normal": "normal motion", "rotation": "rotation about the long axis"}.get(
            measure, measure
        )
        return cls(f"cycle_{measure}", f"whole cycle, {curve}",
                   str(settings.get("deformation", "")), alpha2=alpha2)  # fmt: skip


@dataclass
class CycleModelOutcome:
    """What :func:`analyze_cycle_model` returns: one CycleTests per contrast, and the files."""

    tests: list
    motion: CycleMotion
    model: ModelDesign
    paths: list = field(default_factory=list)

    @property
    def left_out(self) -> list:
        """The study's subjects the design table does not list."""
        return self.model.left_out


def _segments(motion: CycleMotion, landmarks, exclude) -> tuple:
    """The AHA segment of every atlas vertex (None without landmarks) and the tested mask."""
    if landmarks is None:
        if exclude:
            raise CohortError("exclude_segments: needs the atlas's landmarks (--aha)")
        return None, None
    lm = landmarks
    segments = aha_segments(motion.atlas, lm.apex, lm.base, lm.septum, motion.faces)
    if not exclude:
        return segments, None
    tested = ~np.isin(segments, list(exclude))
    if tested.sum() < 2:
        raise CohortError("exclude_segments: no vertex left to test")
    return segments, tested


def analyze_cycle_model(
    study,
    table: dict,
    formula: str,
    contrasts: list,
    output=None,
    *,
    n_permutations: int = 5000,
    seed: int = 0,
    tfce: bool = False,
    landmarks=None,
    exclude_segments=None,
    blocks: str | None = None,
    measure: str = "normal",
    min_radius: float = 5.0,
    fwhm: float | None = None,
    alpha: float = 0.05,
    groups: tuple | None = None,
    summaries=SUMMARIES,
    progress: bool = True,
    figures: bool = True,
    source=None,
    motion=None,
) -> CycleModelOutcome:
    """Test the contrasts of a linear model on a cycle study; write the analysis.

    Parameters
    ----------
    study : path
        A folder written by ``symladders cycle-study``.
    table : dict of str to list
        The design table (:func:`ladders.statistics.read_design`): a ``subject`` column
        and the covariates. Subjects of the study not in it are left out (listed);
        subjects in it but not in the study raise, naming the line.
    formula : str
        E.g. ``"group + age + sex"``.
    contrasts : list of str
        E.g. ``["group[patients] - group[controls]", "age", "group"]``.
    output : path, optional
        Default ``study/analysis``.
    n_permutations : int, default 5000
    seed : int, default 0
        Seed of the permutations (one stream over the contrasts and summaries).
    tfce : bool
        Also threshold-free cluster enhancement of every summary.
    landmarks : Landmarks, optional
        The atlas's apex, base-plane centre and septal point: the AHA segments' tests,
        the segments left out (``exclude_segments``) and the rotation's long axis.
    exclude_segments : sequence of int, optional
        AHA segments left out of the tests.
    blocks : str, optional
        A column of the table: exchangeability blocks.
    measure : {"normal", "rotation"}
    min_radius : float
    fwhm : float, optional
        Every map smoothed on the atlas first (mm, full width at half maximum).
    alpha : float
        The FWER level of the counts and figures.
    groups : (str, str), optional
        The model is two groups of the column ``group`` compared, A against B: their
        means in the tables and figures; each needs at least 3 of the study's subjects.
    summaries : sequence of str
        The summaries tested (:data:`~.cycle_model.SUMMARIES`).
    progress, figures : bool
    source : path, optional
        The design table's file, named in the errors.
    motion : CycleMotion or WallCycles, optional
        The curves already read (e.g. a cohort's wall maps,
        :func:`~ladders.study.wall.load_wall_cycles`, for a wall measure); default the
        cycle study's (:func:`~.cycle_analysis.load_cycle_motion`).

    Returns
    -------
    CycleModelOutcome
    """
    n_permutations = check_int(n_permutations, "n_permutations", minimum=1)
    motion = load_cycle_motion(study) if motion is None else motion
    model = model_design(table, formula, contrasts, motion.subjects, blocks, source, _STUDY)
    motion = motion.subset(model.kept)
    labels = None
    if groups is not None:
        by_subject = dict(zip([str(s).strip() for s in table["subject"]], table["group"]))
        labels = np.array([str(by_subject[s]).strip() == groups[0] for s in model.kept])
        for name, size in ((groups[0], labels.sum()), (groups[1], (~labels).sum())):
            if size < 3:
                raise CohortError(f"{source or 'groups'}: group {name!r} has {int(size)} "
                                  "subject(s) in the study; each group needs at least 3 subjects")  # fmt: skip
    segments, tested = _segments(motion, landmarks, exclude_segments)
    if measure == "rotation" and landmarks is None:
        raise CohortError("measure rotation: needs the atlas's landmarks (--aha), the long axis")
    axis = landmarks if measure == "rotation" else None
    try:
        responses = cycle_responses(motion, measure, axis, min_radius, fwhm, tested)
    except ValueError as exc:
        raise CohortError(str(exc)) from None
    rng = np.random.default_rng(seed)
    tests = []
    for spec in contrasts:
        result = cycle_model(responses, model.design, spec, n_permutations, rng, tfce=tfce,
                             blocks=model.blocks, segments=segments, progress=progress,
                             summaries=summaries)  # fmt: skip
        tests.append(result if labels is None else replace(result, labels=labels))
    folder = Path(output) if output is not None else Path(study) / "analysis"
    header = (f"Study: {Path(study).resolve()}; {len(model.kept)} subjects; model `{formula}`; "
              f"{n_permutations:,} permutations, seed {seed}.")  # fmt: skip
    if fwhm is not None:
        header += f" Maps smoothed on the atlas, {fwhm:g} mm FWHM."
    if exclude_segments:
        header += f" AHA segment(s) {', '.join(map(str, exclude_segments))} left out."
    if model.left_out:
        header += f" Left out (not in the design table): {', '.join(model.left_out)}."
    paths = write_cycle_tests(folder, motion, tests, groups or ("group1", "group2"), alpha,
                              table, header, figures)  # fmt: skip
    return CycleModelOutcome(tests, motion, model, paths)


def analyze_cycle_outcome(
    study,
    table: dict,
    time: str,
    event: str,
    output=None,
    *,
    baseline=None,
    measure: str = "normal",
    landmarks=None,
    min_radius: float = 5.0,
    fwhm: float | None = None,
    n_components: int = 5,
    n_splits: int = 5,
    n_bootstrap: int = 1000,
    seed: int = 0,
    source=None,
    motion=None,
) -> OutcomeOutcome:
    """Predict a survival outcome from the cycle's curves (every frame, every vertex).

    The curves of :meth:`~.cycle_analysis.CycleMotion.curves` (the normal motion, or the
    rotation at the vertices off the long axis) enter the cross-validated Cox model of
    their PCA scores (:func:`ladders.statistics.cross_validated_c_index_from_motion`),
    beside the ``baseline`` columns alone; writes ``outcome.csv`` and
    ``outcome_summary.md`` (:func:`~ladders.study.population.predict_outcome`).

    Parameters
    ----------
    study : path
    table : dict
        The design table with the columns ``time`` and ``event``.
    time, event : str
    output : path, optional
        Default ``study/analysis``.
    baseline : list of str, optional
    measure, landmarks, min_radius, fwhm : the curves (see :func:`analyze_cycle_model`).
    n_components, n_splits, n_bootstrap, seed : the Cox model's cross-validation.
    source : path, optional
    motion : CycleMotion or WallCycles, optional
        The curves already read (see :func:`analyze_cycle_model`).

    Returns
    -------
    OutcomeOutcome
    """
    motion = load_cycle_motion(study) if motion is None else motion
    kept, left_out = check_design_table(table, list(motion.subjects), source, _STUDY)
    motion = motion.subset(kept)
    if measure == "rotation" and landmarks is None:
        raise CohortError("measure rotation: needs the atlas's landmarks (--aha), the long axis")
    try:
        curves = motion.curves(measure, landmarks, min_radius, fwhm)
    except ValueError as exc:
        raise CohortError(str(exc)) from None
    curves = curves[..., np.isfinite(curves).all(axis=(0, 1))]
    folder = Path(output) if output is not None else Path(study) / "analysis"
    return predict_outcome(
        [(CycleLabel.of(study, measure), curves)], table, time, event, kept, folder,
        baseline=baseline, n_components=n_components, n_splits=n_splits,
        n_bootstrap=n_bootstrap, seed=seed, left_out=left_out,
        header=f"Study: {Path(study).resolve()}", what="the curves of every frame",
    )  # fmt: skip
