"""The group analysis of a study's transported motion, as ``symladders analyze`` runs it.

:func:`analyze` reads a study's output folder, checks the groups table against it
before any computation, compares the two groups for every transport and
``alpha^2`` (:func:`~.group_comparison.compare_groups`: per vertex, the displacement,
its normal component, the area strain and the normal wall motion), scores every transport
against a planted truth when one is given (:func:`~.against_truth.score_transports`)
and writes the outputs (:mod:`.analysis_outputs`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ladders.tables import locate
from manifolds.validation import check_int

from ..cohort.planted_effect import PlantedRegion
from ..errors import CohortError
from ..recommendations import main_motion
from .against_truth import TransportScore, score_transports
from .analysis_outputs import write_analysis
from .group_comparison import NORMALIZATIONS, GroupComparison, compare_groups
from .model_design import compared_groups
from .transported_motion import TransportedMotion, load_transported_motion

__all__ = [
    "AnalysisOutcome",
    "check_groups_table",
    "select_motions",
    "read_planted_region",
    "analyze",
]


@dataclass
class AnalysisOutcome:
    """What :func:`analyze` returns: the comparisons, the scores and the files written."""

    comparisons: list[GroupComparison]
    main: GroupComparison
    scores: list[TransportScore] = field(default_factory=list)
    paths: dict = field(default_factory=dict)
    left_out: list = field(default_factory=list)


def check_groups_table(
    subjects, groups: dict, compare: tuple | None = None
) -> tuple[np.ndarray, tuple[str, str], list]:
    """Labels of the study's subjects from ``{subject: group}``, checked before any computation.

    Parameters
    ----------
    subjects : sequence of str
        The subjects of the study (with a result at every ``alpha^2``).
    groups : dict
        ``{subject: group}`` (:func:`~ladders.study.cohort.read_groups`).
    compare : (str, str), optional
        The two groups to compare, the first tested against the second; needed
        when the table has more than two groups. Default: the two groups, the one
        named first in the table first.

    Returns
    -------
    labels : ndarray of bool
        Per kept subject, True for the first group.
    names : (str, str)
    kept : list of str
        The subjects compared (those of the two groups, in the study's order).

    Raises
    ------
    CohortError
        The table names subjects the study does not have; fewer or more than two
        groups (without ``compare``); a group of ``compare`` absent; fewer than
        three subjects in a group.
    """
    subjects = list(subjects)
    absent = [s for s in groups if s not in set(subjects)]
    if absent:
        shown = ", ".join(absent[:5]) + (" ..." if len(absent) > 5 else "")
        raise CohortError(
            f"{locate(groups, 'subject', absent[0], 'groups')}: unknown subject {absent[0]!r}: "
            f"{len(absent)} subject(s) of the table are not in the study (no result at every "
            f"alpha^2): {shown}"
        )
    compare = compared_groups(groups, compare)
    kept = [s for s in subjects if groups.get(s) in compare]
    labels = np.array([groups[s] == compare[0] for s in kept])
    for name, count in ((compare[0], labels.sum()), (compare[1], (~labels).sum())):
        if count < 3:
            raise CohortError(
                f"groups: group {name!r} has {int(count)} subject(s), need at least 3"
            )
    return labels, (str(compare[0]), str(compare[1])), kept


def select_motions(
    motions: list[TransportedMotion], alpha2=None, methods=None
) -> list[TransportedMotion]:
    """The motions at the ``alpha2`` values and of the ``methods`` asked for (all by default).

    The motion without transport (``"none"``) is kept whatever ``alpha2`` (it has
    none). An ``alpha2`` or a method the study does not have raises, naming what
    it has.
    """
    have_alpha = sorted({m.alpha2 for m in motions if m.alpha2 is not None})
    have_methods = sorted({m.method for m in motions})
    out = list(motions)
    if alpha2 is not None:
        wanted = [float(a) for a in np.atleast_1d(alpha2)]
        bad = [a for a in wanted if not any(np.isclose(a, h, rtol=1e-12) for h in have_alpha)]
        if bad:
            raise CohortError(f"alpha2: {bad} not in the study, which has {have_alpha}")
        out = [m for m in out if m.alpha2 is None or any(np.isclose(m.alpha2, a) for a in wanted)]
    if methods is not None:
        bad = [x for x in methods if x not in have_methods]
        if bad:
            raise CohortError(f"transport: {bad} not in the study, which has {have_methods}")
        out = [m for m in out if m.method in methods]
    return out


def read_planted_region(path) -> PlantedRegion:
    """The planted truth from a ``planted_region.json`` (written by ``symladders cohort``)."""
    path = Path(path)
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise CohortError(f"truth {path}: cannot be read ({exc})") from None
    region = record.get("region") if isinstance(record, dict) and "region" in record else record
    if region is None:
        raise CohortError(f"truth {path}: the cohort has no planted abnormality (a null cohort)")
    return PlantedRegion.from_dict(region)


def analyze(
    study_output,
    groups: dict,
    output=None,
    *,
    compare: tuple | None = None,
    alpha2=None,
    methods=None,
    region: PlantedRegion | None = None,
    null_output=None,
    n_permutations: int = 10000,
    n_components: int = 5,
    normalize: str | None = None,
    alpha: float = 0.05,
    seed: int = 0,
    n_null_repetitions: int = 200,
    n_null_permutations: int = 1000,
    progress: bool = True,
    figures: bool = True,
) -> AnalysisOutcome:
    """Compare two groups' transported motion in a study's outputs; write the analysis.

    Parameters
    ----------
    study_output : path
        A folder written by ``symladders study`` (or ``run_study``).
    groups : dict
        ``{subject: group}``.
    output : path, optional
        Where to write; default ``study_output/analysis``.
    compare : (str, str), optional
        The two groups (see :func:`check_groups_table`).
    alpha2, methods : optional
        Restrict the motions (see :func:`select_motions`).
    region : PlantedRegion, optional
        The planted truth on the atlas: every transport is then scored.
    null_output : path, optional
        A study of the same subjects without the effect: the FWER under the null.
    n_permutations, n_components, normalize, alpha : see :func:`compare_groups`
    seed : int
        Seed of every random draw (permutations, folds, null splits).
    n_null_repetitions, n_null_permutations : int
    progress, figures : bool

    Returns
    -------
    AnalysisOutcome
    """
    n_permutations = check_int(n_permutations, "n_permutations", minimum=1)
    if normalize not in NORMALIZATIONS:
        raise CohortError(f"normalize: expected one of {NORMALIZATIONS}, got {normalize!r}")
    motions = select_motions(load_transported_motion(study_output), alpha2, methods)
    labels, names, kept = check_groups_table(motions[0].subjects, groups, compare)
    left_out = [s for s in motions[0].subjects if s not in set(kept)]
    motions = [m.subset(kept) for m in motions]
    if region is not None and region.weight.size != motions[0].atlas.shape[0]:
        raise CohortError(
            f"truth: {region.weight.size} vertices, the study's atlas has "
            f"{motions[0].atlas.shape[0]}: the truth belongs to another atlas"
        )
    null_motions = None
    if null_output is not None:
        null_motions = select_motions(load_transported_motion(null_output), alpha2, methods)
    rng = np.random.default_rng(seed)
    scores: list[TransportScore] = []
    if region is not None:
        scores, comparisons = score_transports(
            motions, labels, region.affected, rng, null_motions, n_permutations,
            n_null_repetitions, n_null_permutations, alpha, normalize, progress, names,
            n_components,
        )  # fmt: skip
    else:
        comparisons = [
            compare_groups(
                m, labels, names, n_permutations, n_components, rng, normalize, progress=progress
            )  # fmt: skip
            for m in motions
        ]
    main = main_motion(comparisons)
    truth = (
        None
        if region is None
        else f"Planted: {region.abnormality.describe()}; "
        + (f"{int(region.affected.sum())} of {region.weight.size} atlas vertices affected.")
    )
    header = f"Study: {Path(study_output).resolve()}; seed {seed}."
    if left_out:
        header += f" Left out (not in the two groups): {', '.join(left_out)}."
    paths = write_analysis(
        Path(output) if output is not None else Path(study_output) / "analysis",
        comparisons, main, alpha, None if region is None else region.weight, scores, truth,
        header, figures,
    )  # fmt: skip
    return AnalysisOutcome(comparisons, main, scores, paths, left_out)
