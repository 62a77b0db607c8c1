"""Per-subject results as a tidy table, and the paired comparison residual vs no residual."""

from __future__ import annotations

import csv
import io
import math
import warnings

import numpy as np
from scipy.stats import wilcoxon

from ..running.results import ERROR_NAMES, REGISTRATION_MEASURES, VARIANTS
from .rows import PairedComparison, PairedRow
from .selection import alpha_values, other_rows

__all__ = [
    "MEASURES",
    "tidy_rows",
    "tidy_csv",
    "bootstrap_median_ci",
    "paired_comparison",
    "paired_statistics",
    "paired_csv",
]

#: Measures of the tidy table, in order.
MEASURES = (*ERROR_NAMES, "ase", *REGISTRATION_MEASURES, "converged")
_FIXED_UNITS = {"ase": "1", "converged": "bool", "registration_norm": "rkhs"}


def tidy_rows(results: list, unit: str | None = None) -> list[dict]:
    """One row per ``(subject, alpha2, variant, measure)``.

    Variants ``residual`` and ``no_residual`` carry the four errors and the ASE
    of the pole ladder, and the measures of the registration ``T -> S``
    (the same values in both, since the registration is shared); the model's own
    transport method (``fanning``, ``svf_conjugation``, ...; none for a model without
    one) carries its ASE.
    ``converged`` is 1.0 or 0.0.

    Parameters
    ----------
    results : list of SubjectResults
        :attr:`ladders.study.running.runner.StudyOutcome.results`.
    unit : str, optional
        Unit of the distances; default: each result's ``unit``.
    """
    if not any(r.pairs for r in results):
        return []
    rows = []
    others = other_rows(results)
    for r in results:
        for pair in r.pairs:
            for variant in (*VARIANTS, *others):
                for m in MEASURES if variant in VARIANTS else ("ase",):
                    rows.append(
                        {
                            "subject": r.subject,
                            "alpha2": pair.alpha2,
                            "variant": variant,
                            "measure": m,
                            "value": float(pair.measure(variant, m)),
                            "unit": _FIXED_UNITS.get(m, unit or pair.unit),
                        }
                    )
    return rows


def tidy_csv(rows: list[dict]) -> str:
    """The rows of :func:`tidy_rows` as CSV text."""
    buf = io.StringIO()
    fields = ["subject", "alpha2", "variant", "measure", "value", "unit"]
    writer = csv.DictWriter(buf, fieldnames=fields, lineterminator="\n")
    writer.writeheader()
    writer.writerows({**row, "value": repr(row["value"])} for row in rows)
    return buf.getvalue()


def _median_difference(x, y, axis=-1):
    return np.median(x - y, axis=axis)


def bootstrap_median_ci(a, b, rng: np.random.Generator, n_boot: int = 2000):
    """95 % BCa bootstrap interval of the median of ``a - b``, subjects resampled in pairs.

    ``scipy.stats.bootstrap`` with ``paired=True`` and ``method="BCa"``. Its
    degenerate cases have a documented answer instead of NaN:

    * all differences equal: every resample has that median, and the interval is
      that value, ``[d, d]``;
    * fewer than 3 subjects (and unequal differences): no interval (``None``);
    * a BCa interval that is not finite (ties make its acceleration 0 / 0): the
      percentile interval of the same resamples.

    Returns
    -------
    low, high : float or None
    note : str
        Which fallback was used, or ``""``.
    """
    from scipy.stats import bootstrap

    d = a - b
    if np.all(d == d[0]):
        return float(d[0]), float(d[0]), "all differences equal: the interval is that value"
    if d.size < 3:
        return None, None, f"n = {d.size} < 3: no bootstrap interval"
    kwargs = {"paired": True, "vectorized": True, "rng": rng}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the degenerate BCa case is handled below
        res = bootstrap((a, b), _median_difference, n_resamples=n_boot, method="BCa", **kwargs)
        low, high = res.confidence_interval
        if np.isfinite(low) and np.isfinite(high):
            return float(low), float(high), ""
        res = bootstrap(
            (a, b), _median_difference, n_resamples=0, method="percentile",
            bootstrap_result=res, **kwargs,
        )  # fmt: skip
    low, high = res.confidence_interval
    return float(low), float(high), "BCa undefined (ties): percentile interval"


def paired_comparison(
    residual, no_residual, rng: np.random.Generator, n_boot: int = 2000
) -> PairedComparison:
    """Paired comparison of two samples (``residual - no_residual`` per subject).

    Parameters
    ----------
    residual, no_residual : array, shape (n,)
        The same error for the same subjects, with and without residuals.
    rng : numpy.random.Generator
        Draws the bootstrap resamples.
    n_boot : int
        Bootstrap resamples of the median difference.

    Returns
    -------
    PairedComparison
        ``n``; ``fraction_residual_lower`` (share of subjects with a strictly
        lower error with residuals); ``median_difference`` and its 95 % BCa
        bootstrap interval ``ci_low``, ``ci_high`` (:func:`bootstrap_median_ci`,
        with its fallbacks); ``wilcoxon_p`` (two-sided signed-rank test, exact for
        small samples) with ``note`` explaining a missing value or a fallback (no
        subject; all differences zero gives p = 1). Values that cannot be
        computed are ``None``, never NaN.
    """
    a, b = np.asarray(residual, dtype=float), np.asarray(no_residual, dtype=float)
    if a.shape != b.shape or a.ndim != 1:
        raise ValueError(
            f"residual, no_residual: expected two 1-d arrays of one length, got shapes "
            f"{a.shape} and {b.shape}"
        )
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("residual, no_residual: expected finite values, got NaN or inf")
    d = a - b
    if d.size == 0:
        return PairedComparison(0, note="no subject")
    lower, median = float(np.mean(d < 0)), float(np.median(d))
    ci_low, ci_high, ci_note = bootstrap_median_ci(a, b, rng, n_boot)
    notes = [ci_note] if ci_note else []
    if np.all(d == 0):
        note = "; ".join(["all differences zero", *notes])
        return PairedComparison(d.size, lower, median, ci_low, ci_high, 1.0, note)
    p = float(wilcoxon(d, zero_method="wilcox", alternative="two-sided").pvalue)
    if d.size < 6:
        notes.insert(0, f"n = {d.size}: p cannot fall below {2.0 ** (1 - np.count_nonzero(d)):.3g}")
    return PairedComparison(
        int(d.size), lower, median, ci_low, ci_high, p if math.isfinite(p) else None,
        "; ".join(notes),
    )  # fmt: skip


def paired_statistics(results: list, seed: int = 0, n_boot: int = 2000) -> list[PairedRow]:
    """:func:`paired_comparison` per ``alpha^2`` and error (the four errors and the ASE).

    Subjects without a result at an ``alpha^2`` (failed) are left out of that ``alpha^2``.
    The bootstrap uses ``numpy.random.default_rng(seed)``.
    """
    rng = np.random.default_rng(seed)
    rows = []
    for a2 in alpha_values(results):
        pairs = [p for p in (r.at(a2) for r in results) if p is not None]
        for name in (*ERROR_NAMES, "ase"):
            res = [p.measure("residual", name) for p in pairs]
            nores = [p.measure("no_residual", name) for p in pairs]
            stats = paired_comparison(res, nores, rng, n_boot=n_boot)
            rows.append(PairedRow.of(a2, name, stats))
    return rows


def paired_csv(rows: list[PairedRow]) -> str:
    """The rows of :func:`paired_statistics` as CSV text (``None`` as an empty cell)."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=PairedRow.fields(), lineterminator="\n")
    writer.writeheader()
    writer.writerows({k: ("" if v is None else v) for k, v in r.as_dict().items()} for r in rows)
    return buf.getvalue()
