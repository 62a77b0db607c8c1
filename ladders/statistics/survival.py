"""Outcomes from motion: Cox regression and a cross-validated concordance index.

:func:`cross_validated_c_index` predicts survival from per-subject features with a
penalised Cox proportional-hazards model (:class:`lifelines.CoxPHFitter`) in a
``n_splits``-fold cross-validation stratified by the event indicator. In each fold the
features are standardised with the mean and standard deviation of the training rows,
the model is fitted on the training rows and the linear predictor ``x @ beta`` (the
log partial hazard, a monotone function of the partial hazard) of the test rows is
kept. Harrell's concordance index (:func:`c_index`) is computed once on the pooled
out-of-fold risk scores of all subjects. Its interval is a percentile bootstrap over
the subjects of these pooled out-of-fold predictions (the models are not refitted).
An optional baseline (for instance the ejection fraction) goes through the same folds
alone; the same bootstrap resamples give its interval and a paired interval of the
difference. The hazard ratios reported are those of one fit on all subjects, per
standard deviation of each feature.

:func:`cross_validated_c_index_from_motion` takes displacement fields ``(n, k, 3)`` and
fits a plain PCA on the flattened displacements of the training rows of each fold (the
test rows never enter the PCA, so the components leak no outcome information) before
the Cox model on the scores.

:func:`simulate_survival` draws survival times with a known risk for ground-truth tests.

The association of shape or motion with a continuous variable (age, ejection fraction,
a biomarker) is a contrast on a continuous column of the linear model:
:func:`ladders.statistics.glm_test`.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from lifelines import CoxPHFitter
from lifelines.utils import concordance_index
from scipy import optimize
from sklearn.decomposition import PCA
from sklearn.model_selection import StratifiedKFold

from manifolds.validation import check_rng

__all__ = ["SurvivalResult", "c_index", "cross_validated_c_index"]
__all__ += ["cross_validated_c_index_from_motion", "simulate_survival"]


@dataclass(frozen=True)
class SurvivalResult:
    """Result of :func:`cross_validated_c_index`.

    Attributes
    ----------
    c_index : float
        Harrell's C-index of the pooled out-of-fold risk scores (0.5 is chance).
    ci_low, ci_high : float
        Percentile bootstrap interval at ``confidence``, resampling the subjects of the
        pooled out-of-fold predictions.
    confidence : float
    risk_scores : ndarray, shape (n,)
        Out-of-fold log partial hazard of each subject (higher: shorter survival).
    n_splits, n_components : int
        Folds; features entering the Cox model (PCA components for the motion variant).
    per_fold : list of float
        C-index within each test fold (NaN where a fold has no comparable pair).
    hazard_ratios : ndarray, shape (n_components,)
        ``exp(beta)`` of the fit on all subjects, per standard deviation of each feature.
    penalizer : float
    baseline_c_index, baseline_ci_low, baseline_ci_high : float or None
        The same for the baseline features alone (None without a baseline).
    difference_ci : tuple of float or None
        Paired bootstrap interval of ``c_index - baseline_c_index``.
    model : str
    """

    c_index: float
    ci_low: float
    ci_high: float
    confidence: float
    risk_scores: np.ndarray
    n_splits: int
    n_components: int
    per_fold: list[float]
    hazard_ratios: np.ndarray
    penalizer: float
    baseline_c_index: float | None = None
    baseline_ci_low: float | None = None
    baseline_ci_high: float | None = None
    difference_ci: tuple[float, float] | None = None
    model: str = field(default="")


def c_index(time, risk, event) -> float:
    """Harrell's concordance index of a risk score (higher risk: shorter survival).

    ``lifelines.utils.concordance_index`` expects scores that grow with the survival
    time, so it is given ``-risk``: a risk ordering the times exactly in reverse gives 1.

    Parameters
    ----------
    time, risk : arrays, shape (n,)
    event : array of bool, shape (n,)

    Returns
    -------
    float
        NaN when no pair is comparable (no event before another subject's time).
    """
    try:
        return float(concordance_index(time, -np.asarray(risk, dtype=float), event))
    except ZeroDivisionError:
        return float("nan")


def _hazard_rate_for_censoring(rates: np.ndarray, fraction: float) -> float:
    """Censoring rate ``c`` with mean ``c / (c + rate_i)`` equal to ``fraction``."""
    if fraction <= 0:
        return 0.0

    def gap(log_c):
        c = np.exp(log_c)
        return float(np.mean(c / (c + rates))) - fraction

    centre = float(np.log(np.median(rates)))
    return float(np.exp(optimize.brentq(gap, centre - 60.0, centre + 60.0)))


def simulate_survival(
    risk,
    rng: np.random.Generator,
    baseline_hazard: float = 0.1,
    censoring: float = 0.3,
    shape: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Survival times with hazard ``h0 * shape * t**(shape - 1) * exp(risk)``, censored.

    The event time of subject ``i`` is Weibull, ``T_i = (E_i / (h0 exp(risk_i)))**(1/shape)``
    with ``E_i`` standard exponential (exponential times, hazard ``h0 exp(risk_i)``, for
    ``shape = 1``). The censoring time is independent, ``C_i = (E'_i / c)**(1/shape)``
    (exponential with rate ``c`` for ``shape = 1``), so that ``P(C_i < T_i) =
    c / (c + h0 exp(risk_i))`` for any shape; ``c`` is solved so that the expected
    censored fraction is ``censoring``. The observed time is ``min(T_i, C_i)``.

    Parameters
    ----------
    risk : array, shape (n,)
        Log hazard ratio of each subject.
    rng : numpy.random.Generator
    baseline_hazard : float, default 0.1
    censoring : float, default 0.3
        Expected fraction of censored subjects, in ``[0, 1)``.
    shape : float, default 1.0
        Weibull shape ``> 0``.

    Returns
    -------
    time : ndarray of float64, shape (n,)
    event : ndarray of bool, shape (n,)
        True where the event was observed (``T_i <= C_i``).
    """
    rng = check_rng(rng)
    r = np.asarray(risk, dtype=float)
    if r.ndim != 1 or r.size == 0 or not np.isfinite(r).all():
        raise ValueError(f"risk: expected a finite array (n,), got shape {r.shape}")
    if not (np.isfinite(baseline_hazard) and baseline_hazard > 0):
        raise ValueError(f"baseline_hazard: expected a positive number, got {baseline_hazard}")
    if not 0 <= censoring < 1:
        raise ValueError(f"censoring: expected a fraction in [0, 1), got {censoring}")
    if not (np.isfinite(shape) and shape > 0):
        raise ValueError(f"shape: expected a positive number, got {shape}")
    rates = baseline_hazard * np.exp(r)
    t_event = (rng.standard_exponential(r.size) / rates) ** (1.0 / shape)
    c = _hazard_rate_for_censoring(rates, float(censoring))
    if c == 0.0:
        return t_event, np.ones(r.size, dtype=bool)
    t_censor = (rng.standard_exponential(r.size) / c) ** (1.0 / shape)
    return np.minimum(t_event, t_censor), t_event <= t_censor


def _check_outcome(time, event, n: int) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(time, dtype=float)
    if t.shape != (n,):
        raise ValueError(f"time: expected shape ({n},), got {t.shape}")
    if not np.isfinite(t).all():
        raise ValueError("time: contains NaN or infinite values")
    if (t <= 0).any():
        raise ValueError(f"time: expected positive durations, got minimum {t.min()}")
    e = np.asarray(event)
    if e.shape != (n,):
        raise ValueError(f"event: expected shape ({n},), got {e.shape}")
    if e.dtype != bool:
        if not np.isin(e, (0, 1)).all():
            raise ValueError("event: expected booleans or 0/1 values")
        e = e.astype(bool)
    if not e.any():
        raise ValueError("event: no event observed, the Cox model cannot be fitted")
    return t, e


def _check_features(values, name: str, n: int | None = None) -> np.ndarray:
    x = np.asarray(values, dtype=float)
    if x.ndim == 1 and name == "baseline":
        x = x[:, None]
    if x.ndim != 2 or x.shape[1] == 0:
        raise ValueError(f"{name}: expected an array (n, m), got shape {x.shape}")
    if n is not None and x.shape[0] != n:
        raise ValueError(f"{name}: expected {n} rows (one per subject), got {x.shape[0]}")
    if not np.isfinite(x).all():
        raise ValueError(f"{name}: contains NaN or infinite values")
    return x


def _standardise(train: np.ndarray, test: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre and scale by the training rows' mean and standard deviation (``ddof=1``)."""
    mean = train.mean(axis=0)
    std = train.std(axis=0, ddof=1)
    std = np.where(std > 0, std, 1.0)
    return (train - mean) / std, (test - mean) / std


def _fit_cox(x: np.ndarray, time: np.ndarray, event: np.ndarray, penalizer: float) -> np.ndarray:
    """Coefficients of a penalised Cox fit of standardised features."""
    table = pd.DataFrame(x, columns=[f"x{j}" for j in range(x.shape[1])])
    table["time"] = time
    table["event"] = event.astype(int)
    fitter = CoxPHFitter(penalizer=penalizer)
    fitter.fit(table, duration_col="time", event_col="event")
    return fitter.params_.to_numpy(dtype=float)


def _identity(train: np.ndarray, test: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return train, test


def _out_of_fold(x, time, event, folds, penalizer, transform: Callable):
    risk = np.empty(x.shape[0])
    per_fold = []
    for train, test in folds:
        f_train, f_test = _standardise(*transform(x[train], x[test]))
        beta = _fit_cox(f_train, time[train], event[train], penalizer)
        risk[test] = f_test @ beta
        per_fold.append(c_index(time[test], risk[test], event[test]))
    return risk, per_fold


def _bootstrap(time, event, risks, n_bootstrap, rng):
    """C-index of each risk column on subject resamples (rows: resamples)."""
    n = time.size
    out = np.empty((int(n_bootstrap), len(risks)))
    for b in range(int(n_bootstrap)):
        idx = rng.integers(0, n, n)
        for j, risk in enumerate(risks):
            out[b, j] = c_index(time[idx], risk[idx], event[idx])
    return out


def _percentile(values: np.ndarray, confidence: float) -> tuple[float, float]:
    alpha = (1.0 - confidence) / 2.0
    kept = values[np.isfinite(values)]
    if kept.size == 0:
        return float("nan"), float("nan")
    low, high = np.quantile(kept, [alpha, 1.0 - alpha])
    return float(low), float(high)


def _cross_validate(
    x, time, event, n_splits, rng, penalizer, baseline, n_bootstrap, confidence, transform, label
) -> SurvivalResult:
    rng = check_rng(rng)
    n = x.shape[0]
    time, event = _check_outcome(time, event, n)
    base = None if baseline is None else _check_features(baseline, "baseline", n)
    if isinstance(n_splits, bool) or int(n_splits) != n_splits or n_splits < 2:
        raise ValueError(f"n_splits: expected an int >= 2, got {n_splits!r}")
    n_splits = int(n_splits)
    if n < n_splits:
        raise ValueError(f"n_splits: {n_splits} folds need at least {n_splits} subjects, got {n}")
    if int(event.sum()) < n_splits:
        raise ValueError(
            f"event: {n_splits} folds need at least {n_splits} events, got {int(event.sum())}"
        )
    if not (np.isfinite(penalizer) and penalizer >= 0):
        raise ValueError(f"penalizer: expected a number >= 0, got {penalizer}")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence: expected a level in (0, 1), got {confidence}")
    if isinstance(n_bootstrap, bool) or int(n_bootstrap) < 1:
        raise ValueError(f"n_bootstrap: expected an int >= 1, got {n_bootstrap!r}")
    splitter = StratifiedKFold(n_splits, shuffle=True, random_state=int(rng.integers(2**31 - 1)))
    with warnings.catch_warnings():  # fewer censored subjects than folds: uneven strata
        warnings.simplefilter("ignore", UserWarning)
        folds = list(splitter.split(x, event))
    risk, per_fold = _out_of_fold(x, time, event, folds, penalizer, transform)
    risks = [risk]
    if base is not None:
        base_risk, _ = _out_of_fold(base, time, event, folds, penalizer, _identity)
        risks.append(base_risk)
    boot = _bootstrap(time, event, risks, n_bootstrap, rng)
    full, _ = _standardise(*transform(x, x))
    hazard_ratios = np.exp(_fit_cox(full, time, event, penalizer))
    low, high = _percentile(boot[:, 0], confidence)
    extra = {}
    if base is not None:
        b_low, b_high = _percentile(boot[:, 1], confidence)
        extra = {
            "baseline_c_index": c_index(time, risks[1], event),
            "baseline_ci_low": b_low,
            "baseline_ci_high": b_high,
            "difference_ci": _percentile(boot[:, 0] - boot[:, 1], confidence),
        }
    return SurvivalResult(
        c_index=c_index(time, risk, event), ci_low=low, ci_high=high,
        confidence=float(confidence), risk_scores=risk, n_splits=n_splits,
        n_components=full.shape[1], per_fold=per_fold, hazard_ratios=hazard_ratios,
        penalizer=float(penalizer),
        model=f"{label} + Cox (penalizer {penalizer}), stratified {n_splits}-fold cross-validation",
        **extra,
    )  # fmt: skip


def cross_validated_c_index(
    features,
    time,
    event,
    n_splits: int = 5,
    rng: np.random.Generator | None = None,
    penalizer: float = 0.1,
    baseline=None,
    n_bootstrap: int = 1000,
    confidence: float = 0.95,
) -> SurvivalResult:
    """Cross-validated C-index of a Cox model of ``features`` (see the module).

    Parameters
    ----------
    features : array, shape (n, m)
        One row per subject (standardised inside each training fold).
    time : array, shape (n,)
        Positive follow-up times (to the event or to censoring).
    event : array of bool or 0/1, shape (n,)
        True where the event was observed; at least ``n_splits`` events.
    n_splits : int, default 5
    rng : numpy.random.Generator
        Draws the folds and the bootstrap (required).
    penalizer : float, default 0.1
        L2 penalty of :class:`lifelines.CoxPHFitter`.
    baseline : array, shape (n,) or (n, b), optional
        Reference predictors (e.g. the ejection fraction) cross-validated alone.
    n_bootstrap : int, default 1000
    confidence : float, default 0.95

    Returns
    -------
    SurvivalResult
    """
    x = _check_features(features, "features")
    return _cross_validate(
        x, time, event, n_splits, rng, penalizer, baseline, n_bootstrap, confidence,
        _identity, f"{x.shape[1]} features",
    )  # fmt: skip


def cross_validated_c_index_from_motion(
    displacements,
    time,
    event,
    n_components: int = 5,
    n_splits: int = 5,
    rng: np.random.Generator | None = None,
    penalizer: float = 0.1,
    baseline=None,
    n_bootstrap: int = 1000,
    confidence: float = 0.95,
) -> SurvivalResult:
    """Cross-validated C-index of a Cox model of PCA scores of displacement fields.

    The PCA (:class:`sklearn.decomposition.PCA` of the flattened displacements, not
    standardised coordinate by coordinate) is fitted on the training rows of each fold;
    its scores are then standardised and enter the Cox model as in
    :func:`cross_validated_c_index`. The hazard ratios are those of a PCA and a Cox fit
    on all subjects, per standard deviation of each component's score (the sign of a
    component is arbitrary).

    Parameters
    ----------
    displacements : array, shape (n, k, 3)
        Per-subject displacement of each vertex (any trailing shape is flattened).
    time, event : arrays, shape (n,)
    n_components : int, default 5
        Components kept (at most the smallest training fold's size minus one).
    n_splits, rng, penalizer, baseline, n_bootstrap, confidence
        As in :func:`cross_validated_c_index`.

    Returns
    -------
    SurvivalResult
    """
    d = np.asarray(displacements, dtype=float)
    if d.ndim < 2 or d.shape[0] == 0 or d[0].size == 0:
        raise ValueError(f"displacements: expected an array (n, k, 3), got shape {d.shape}")
    if not np.isfinite(d).all():
        raise ValueError("displacements: contains NaN or infinite values")
    if isinstance(n_components, bool) or int(n_components) != n_components or n_components < 1:
        raise ValueError(f"n_components: expected an int >= 1, got {n_components!r}")
    x = d.reshape(d.shape[0], -1)
    smallest_train = x.shape[0] - int(np.ceil(x.shape[0] / max(int(n_splits), 1)))
    k = max(1, min(int(n_components), smallest_train - 1, x.shape[1]))

    def pca_scores(train, test):
        pca = PCA(k).fit(train)
        return pca.transform(train), pca.transform(test)

    return _cross_validate(
        x, time, event, n_splits, rng, penalizer, baseline, n_bootstrap, confidence,
        pca_scores, f"PCA({k})",
    )  # fmt: skip
