"""Survival predicted from a study's transported motion, as ``symladders analyze --outcome`` runs it.

:func:`analyze_outcome` reads a study's output folder and a design table holding a
follow-up time and an event indicator per subject (and, optionally, clinical
baseline columns such as the ejection fraction), and for every motion of the study
predicts the outcome from the first PCA scores of the displacements by Cox regression
(:func:`ladders.statistics.cross_validated_c_index_from_motion`: PCA and Cox fitted
inside each fold, the C-index of the pooled out-of-fold predictions with a bootstrap
interval), beside the baseline alone and the paired difference. Writes::

    outcome.csv          one row per motion: C-index and interval, baseline's, difference
    outcome_summary.md   the same as a table
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ladders.statistics import SurvivalResult, cross_validated_c_index_from_motion

from ..errors import CohortError
from ..files import atomic_write_text
from .analysis import select_motions
from .model_design import check_design_table
from .transported_motion import TransportedMotion, load_transported_motion

__all__ = ["OutcomeOutcome", "outcome_arrays", "analyze_outcome", "predict_outcome"]


@dataclass
class OutcomeOutcome:
    """What :func:`analyze_outcome` returns: per motion its result, and the files written."""

    results: list[tuple[TransportedMotion, SurvivalResult]]
    paths: dict = field(default_factory=dict)
    left_out: list = field(default_factory=list)


def _numbers(table: dict, column: str, subjects: list[str]) -> np.ndarray:
    if column not in table:
        raise CohortError(f"outcome: no column {column!r} in the design table "
                          f"(columns: {', '.join(table)})")  # fmt: skip
    by_subject = dict(zip([str(s).strip() for s in table["subject"]], table[column]))
    values = []
    for s in subjects:
        try:
            values.append(float(by_subject[s]))
        except (TypeError, ValueError):
            raise CohortError(
                f"outcome: column {column!r}, subject {s}: expected a number, got {by_subject[s]!r}"
            ) from None
    out = np.array(values)
    if not np.isfinite(out).all():
        bad = [s for s, v in zip(subjects, out) if not np.isfinite(v)]
        raise CohortError(f"outcome: column {column!r}: missing value for {', '.join(bad)}")
    return out


def outcome_arrays(table: dict, time: str, event: str, baseline, subjects):
    """Follow-up time ``(n,)``, event ``(n,)`` bool and baseline ``(n, b)`` or None, checked."""
    t = _numbers(table, time, subjects)
    e = _numbers(table, event, subjects)
    if not np.isin(e, (0.0, 1.0)).all():
        raise CohortError(
            f"outcome: column {event!r}: expected 0 or 1 (event), got {sorted(set(e))}"
        )
    if (t <= 0).any():
        raise CohortError(f"outcome: column {time!r}: follow-up times must be positive")
    base = None
    if baseline:
        base = np.column_stack([_numbers(table, c, subjects) for c in baseline])
    return t, e.astype(bool), base


def _label(m) -> str:
    return m.label + ("" if m.alpha2 is None else f", alpha^2 = {m.alpha2:g}")


def _csv(results, baseline_name: str) -> str:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["motion", "deformation", "method", "alpha2", "c_index", "ci_low", "ci_high",
                     "baseline", "baseline_c_index", "baseline_ci_low", "baseline_ci_high",
                     "difference_ci_low", "difference_ci_high"])  # fmt: skip
    for m, r in results:
        has = r.baseline_c_index is not None
        writer.writerow([
            m.name, m.deformation, m.method, "" if m.alpha2 is None else f"{m.alpha2:g}",
            f"{r.c_index:.4f}", f"{r.ci_low:.4f}", f"{r.ci_high:.4f}",
            baseline_name if has else "",
            f"{r.baseline_c_index:.4f}" if has else "",
            f"{r.baseline_ci_low:.4f}" if has else "", f"{r.baseline_ci_high:.4f}" if has else "",
            f"{r.difference_ci[0]:.4f}" if has else "", f"{r.difference_ci[1]:.4f}" if has else "",
        ])  # fmt: skip
    return out.getvalue()


def _markdown(results, header: str, baseline_name: str) -> str:
    lines = ["# Outcome predicted from the transported motion", "", header, "",
             "| motion | C-index [95 % CI] | " + (f"{baseline_name} alone | motion - baseline |"
                                              if baseline_name else ""),
             "|---|---|" + ("---|---|" if baseline_name else "")]  # fmt: skip
    for m, r in results:
        row = f"| {_label(m)} | {r.c_index:.2f} [{r.ci_low:.2f}, {r.ci_high:.2f}] |"
        if r.baseline_c_index is not None:
            row += (f" {r.baseline_c_index:.2f} [{r.baseline_ci_low:.2f}, "
                    f"{r.baseline_ci_high:.2f}] | [{r.difference_ci[0]:+.2f}, "
                    f"{r.difference_ci[1]:+.2f}] |")  # fmt: skip
        lines.append(row)
    return "\n".join(lines) + "\n"


def analyze_outcome(
    study_output,
    table: dict,
    time: str,
    event: str,
    output=None,
    *,
    baseline=None,
    alpha2=None,
    methods=None,
    n_components: int = 5,
    n_splits: int = 5,
    n_bootstrap: int = 1000,
    seed: int = 0,
    source=None,
) -> OutcomeOutcome:
    """Predict a survival outcome from every motion of a study (see the module).

    Parameters
    ----------
    study_output : path
    table : dict of str to list
        The design table, with the ``subject``, ``time`` and ``event`` columns.
    time, event : str
        Columns of the follow-up time (positive) and of the event (1) or censoring (0).
    output : path, optional
        Default ``study_output/analysis``.
    baseline : list of str, optional
        Clinical columns (e.g. ``["ejection_fraction"]``) predicted alone for comparison.
    alpha2, methods : optional
        Restrict the motions.
    n_components, n_splits, n_bootstrap, seed : int
    source : path, optional
        The design table's file, named in the errors.

    Returns
    -------
    OutcomeOutcome
    """
    motions = select_motions(load_transported_motion(study_output), alpha2, methods)
    kept, left_out = check_design_table(table, motions[0].subjects, source)
    motions = [m.subset(kept) for m in motions]
    folder = Path(output) if output is not None else Path(study_output) / "analysis"
    return predict_outcome(
        [(m, m.displacement) for m in motions], table, time, event, kept, folder,
        baseline=baseline, n_components=n_components, n_splits=n_splits,
        n_bootstrap=n_bootstrap, seed=seed, left_out=left_out,
        header=f"Study: {Path(study_output).resolve()}", what="the displacements",
    )  # fmt: skip


def predict_outcome(
    features: list,
    table: dict,
    time: str,
    event: str,
    kept: list,
    folder,
    *,
    baseline=None,
    n_components: int = 5,
    n_splits: int = 5,
    n_bootstrap: int = 1000,
    seed: int = 0,
    left_out=(),
    header: str = "",
    what: str = "the motion",
) -> OutcomeOutcome:
    """Predict the outcome from each motion's PCA scores; write ``outcome.csv`` and its summary.

    Parameters
    ----------
    features : list of (motion, array (n, ...))
        Each motion (``name``, ``label``, ``deformation``, ``method``, ``alpha2``: a
        :class:`TransportedMotion` or alike) and its per-subject values (flattened for
        the PCA), the rows those of ``kept``.
    table : dict
        The design table.
    time, event : str
        Its columns of the follow-up time and the event.
    kept : list of str
        The subjects, in the rows' order.
    folder : path
    baseline, n_components, n_splits, n_bootstrap, seed : see :func:`analyze_outcome`
    left_out : list of str
        Named in the summary.
    header, what : str
        The study, and what the PCA is of, in the summary.

    Returns
    -------
    OutcomeOutcome
    """
    t, e, base = outcome_arrays(table, time, event, baseline, kept)
    if not e.any():
        raise CohortError(f"outcome: column {event!r}: no event among the subjects")
    results = []
    for m, values in features:
        try:
            r = cross_validated_c_index_from_motion(
                values, t, e, n_components=n_components, n_splits=n_splits,
                rng=np.random.default_rng(seed), baseline=base, n_bootstrap=n_bootstrap,
            )  # fmt: skip
        except ValueError as exc:
            raise CohortError(f"outcome: {exc}") from None
        results.append((m, r))
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    name = ", ".join(baseline) if baseline else ""
    header = (f"{header}; {len(kept)} subjects, {int(e.sum())} events; Cox on {n_components} "
              f"PCA scores of {what}, {n_splits} folds, {n_bootstrap} bootstrap resamples; "
              f"seed {seed}.")  # fmt: skip
    if left_out:
        header += f" Left out (not in the design table): {', '.join(left_out)}."
    paths = {}
    for file, text in (("outcome.csv", _csv(results, name)),
                       ("outcome_summary.md", _markdown(results, header, name))):  # fmt: skip
        atomic_write_text(folder / file, text)
        paths[file] = folder / file
    return OutcomeOutcome(results, paths, list(left_out))
