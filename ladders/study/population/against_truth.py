"""Which transport finds a planted effect: detection power, Dice, AUC and the false-positive rate.

With a cohort whose abnormality is known
(:func:`~ladders.study.population.two_groups.make_two_group_cohort`), every
transported motion is compared between the groups (:func:`compare_groups`) and
scored against the truth:

* detection power: the fraction of the truly affected atlas vertices whose
  displacement test is significant at a family-wise error of ``alpha`` (and the
  same for the tests of the normal component, the area strain and the normal
  wall motion);
* Dice of the detected region with the planted one;
* the classifier's cross-validated AUC with its confidence interval;
* under the null, the family-wise false-positive rate: the same test on a cohort
  without an effect (both groups from one distribution), over random splits of
  its subjects into groups of the study's sizes (one set of transported vectors,
  many splits), with its exact binomial confidence interval.
"""

from __future__ import annotations

import csv
import io
from dataclasses import asdict, dataclass

import numpy as np
from tqdm.auto import tqdm

from ladders.statistics import binomial_interval, detection_power, dice, vertexwise_test
from manifolds.validation import check_int, check_rng

from ..errors import CohortError
from .group_comparison import GroupComparison, compare_groups
from .transported_motion import TransportedMotion

__all__ = [
    "NullRate",
    "TransportScore",
    "null_false_positive_rate",
    "score_transports",
    "scores_csv",
    "read_scores_csv",
    "scores_markdown",
]


@dataclass(frozen=True)
class NullRate:
    """The family-wise false-positive rate under the null and its binomial interval."""

    rate: float
    low: float
    high: float
    n_repetitions: int
    n_permutations: int
    alpha: float


def null_false_positive_rate(
    motion: TransportedMotion,
    n_first: int,
    rng: np.random.Generator,
    n_repetitions: int = 200,
    n_permutations: int = 1000,
    alpha: float = 0.05,
    quantity: str = "displacement",
    progress: bool = False,
) -> NullRate:
    """How often the max-T test finds any vertex when the groups do not differ.

    ``motion`` holds subjects of one distribution; each repetition splits them at
    random into ``n_first`` and ``n - n_first`` subjects and runs the vertexwise
    test of ``quantity`` (``"displacement"``, ``"strain"`` or ``"wall_motion"``)
    with ``n_permutations`` permutations. The rate is the fraction of
    repetitions with at least one vertex below ``alpha`` (family-wise corrected).
    """
    if quantity not in ("displacement", "strain", "wall_motion"):
        raise ValueError(
            f"quantity: expected 'displacement', 'strain' or 'wall_motion', got {quantity!r}"
        )
    rng = check_rng(rng)
    n = len(motion.subjects)
    n_first = check_int(n_first, "n_first", minimum=3)
    if n - n_first < 3:
        raise CohortError(f"n_first: leaves {n - n_first} subjects in the second group, need >= 3")
    n_repetitions = check_int(n_repetitions, "n_repetitions", minimum=1)
    data = getattr(motion, quantity)
    hits = 0
    for _ in tqdm(range(n_repetitions), desc="null splits", disable=not progress, leave=False):
        labels = np.zeros(n, dtype=bool)
        labels[rng.permutation(n)[:n_first]] = True
        test = vertexwise_test(data, labels, n_permutations, rng=rng)
        hits += bool((test.p_fwer < alpha).any())
    low, high = binomial_interval(hits, n_repetitions)
    return NullRate(hits / n_repetitions, low, high, n_repetitions, n_permutations, alpha)


@dataclass(frozen=True)
class TransportScore:
    """One row of the transport comparison: a motion scored against the planted truth.

    ``power`` and ``dice`` are those of the displacement test; ``strain_*``,
    ``normal_*`` and ``wall_*`` those of the area-strain, normal-component and
    normal-wall-motion tests (``wall_*`` last, None where not measured, so that the
    columns before them keep their places).
    """

    name: str
    method: str
    label: str
    deformation: str
    alpha2: float | None
    power: float
    dice: float
    n_detected: int
    n_affected: int
    strain_power: float
    strain_dice: float
    normal_power: float
    normal_dice: float
    auc: float
    auc_low: float
    auc_high: float
    global_p: float
    fwer: float | None = None
    fwer_low: float | None = None
    fwer_high: float | None = None
    wall_power: float | None = None
    wall_dice: float | None = None


def _score(comparison: GroupComparison, affected, alpha, null: NullRate | None) -> TransportScore:
    m = comparison.motion
    detected = comparison.detected(alpha, "displacement")
    strain = comparison.detected(alpha, "strain")
    normal = comparison.detected(alpha, "normal")
    wall = comparison.detected(alpha, "wall_motion")
    c = comparison.classifier
    return TransportScore(
        m.name, m.method, m.label, m.deformation, m.alpha2,
        detection_power(detected, affected), dice(detected, affected), int(detected.sum()),
        int(affected.sum()), detection_power(strain, affected), dice(strain, affected),
        detection_power(normal, affected), dice(normal, affected),
        c.auc, c.ci_low, c.ci_high, comparison.global_test.p_permutation,
        None if null is None else null.rate,
        None if null is None else null.low,
        None if null is None else null.high,
        wall_power=detection_power(wall, affected), wall_dice=dice(wall, affected),
    )  # fmt: skip


def score_transports(
    motions: list[TransportedMotion],
    labels,
    affected,
    rng: np.random.Generator,
    null_motions: list[TransportedMotion] | None = None,
    n_permutations: int = 10000,
    n_null_repetitions: int = 200,
    n_null_permutations: int = 1000,
    alpha: float = 0.05,
    normalize: str | None = None,
    progress: bool = False,
    groups: tuple = ("patients", "controls"),
    n_components: int = 5,
) -> tuple[list[TransportScore], list[GroupComparison]]:
    """Score every motion against the planted truth, and under the null where given.

    Parameters
    ----------
    motions : list of TransportedMotion
        The cohort with the planted effect, one entry per transport and ``alpha^2``.
    labels : array of bool, shape (n,)
        True for the patients.
    affected : array of bool, shape (k,)
        The planted region on the atlas.
    rng : numpy.random.Generator
    null_motions : list of TransportedMotion, optional
        The same transports on a cohort without an effect, matched by ``name``.
    n_permutations, n_null_repetitions, n_null_permutations : int
    alpha : float, default 0.05
    normalize : {None, "volume"}
    progress : bool
    groups : (str, str)
        Names of the patients' and the controls' groups.
    n_components : int
        PCA scores of the global test and the classifier.

    Returns
    -------
    scores : list of TransportScore
    comparisons : list of GroupComparison
    """
    rng = check_rng(rng)
    affected = np.asarray(affected, dtype=bool)
    nulls = {m.name: m for m in null_motions or []}
    labels = np.asarray(labels, dtype=bool)
    scores, comparisons = [], []
    for motion in tqdm(motions, desc="transports", disable=not progress):
        if motion.atlas.shape[0] != affected.size:
            raise CohortError(
                f"affected: {affected.size} vertices, the atlas of {motion.name} has "
                f"{motion.atlas.shape[0]}"
            )
        comparison = compare_groups(
            motion, labels, groups, n_permutations, n_components, rng, normalize
        )
        null = None
        if motion.name in nulls:
            null = null_false_positive_rate(
                nulls[motion.name], int(labels.sum()), rng, n_null_repetitions,
                n_null_permutations, alpha,
            )  # fmt: skip
        scores.append(_score(comparison, affected, alpha, null))
        comparisons.append(comparison)
    return scores, comparisons


def read_scores_csv(text: str) -> list[TransportScore]:
    """The scores of :func:`scores_csv`'s text (empty fields are None)."""
    kinds = {f: TransportScore.__annotations__[f] for f in TransportScore.__annotations__}
    out = []
    for row in csv.DictReader(io.StringIO(text)):
        values = {}
        for key, value in row.items():
            kind = str(kinds[key])
            if value in ("", "None"):
                values[key] = None
            elif "float" in kind:
                values[key] = float(value)
            elif kind.startswith("int"):
                values[key] = int(value)
            else:
                values[key] = value
        out.append(TransportScore(**values))
    return out


def scores_csv(scores: list[TransportScore]) -> str:
    """The scores as CSV, one row per motion."""
    out = io.StringIO()
    names = list(asdict(scores[0])) if scores else [f for f in TransportScore.__annotations__]
    writer = csv.DictWriter(out, fieldnames=names, lineterminator="\n")
    writer.writeheader()
    for s in scores:
        writer.writerow(asdict(s))
    return out.getvalue()


def _fmt(value, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def scores_markdown(scores: list[TransportScore]) -> str:
    """A Markdown table of the scores: power and Dice of the displacement test, power / Dice
    of the normal-motion, wall-motion and strain tests, AUC [CI], global p, null FWER [CI]."""
    lines = [
        "| transport | alpha^2 | power | Dice | normal-motion power / Dice | wall-motion power "
        "/ Dice | strain power / Dice | AUC [95 % CI] | global p | FWER under the null "
        "[95 % CI] |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for s in scores:
        alpha2 = "-" if s.alpha2 is None else f"{s.alpha2:g}"
        fwer = "-" if s.fwer is None else f"{s.fwer:.3f} [{s.fwer_low:.3f}, {s.fwer_high:.3f}]"
        name = s.label
        if s.method != "none" and not s.label.upper().startswith(s.deformation.upper()):
            name = f"{s.deformation.upper()} {s.label}"
        lines.append(
            f"| {name} | {alpha2} | "
            f"{_fmt(s.power)} | {_fmt(s.dice)} | {_fmt(s.normal_power)} / "
            f"{_fmt(s.normal_dice)} | {_fmt(s.wall_power)} / {_fmt(s.wall_dice)} | "
            f"{_fmt(s.strain_power)} / {_fmt(s.strain_dice)} | "
            f"{s.auc:.2f} [{s.auc_low:.2f}, {s.auc_high:.2f}] | {s.global_p:.2g} | {fwer} |"
        )
    return "\n".join(lines) + "\n"
