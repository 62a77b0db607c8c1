"""A cross-validated classifier of the group, and its AUC with a confidence interval.

:func:`cross_validated_auc` fits scikit-learn's PCA (``n_components``) followed by
a logistic regression inside each fold of a stratified ``n_splits``-fold
cross-validation (the PCA sees only the training subjects), collects the
out-of-fold decision scores of every subject and measures their area under the ROC
curve. Its confidence interval is a bootstrap over the subjects stratified by group
(:func:`scipy.stats.bootstrap` of the Mann-Whitney form of the AUC, each group's
out-of-fold scores resampled within the group, so that every resample has both
groups; percentile interval).
The features are not standardised feature by feature: they are coordinates of one
geometric quantity (displacements in mm), whose small, noisy components a
per-feature scaling would inflate; the PCA keeps the directions of largest variance.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy import stats
from sklearn.decomposition import PCA
from sklearn.linear_model import LogisticRegression
from sklearn.metrics import roc_auc_score
from sklearn.model_selection import StratifiedKFold
from sklearn.pipeline import make_pipeline

from manifolds.validation import check_rng

from .group_tests import check_groups

__all__ = ["ClassifierResult", "cross_validated_auc"]


@dataclass(frozen=True)
class ClassifierResult:
    """Result of :func:`cross_validated_auc`.

    Attributes
    ----------
    auc : float
        Area under the ROC curve of the out-of-fold scores (0.5 is chance).
    ci_low, ci_high : float
        Its bootstrap interval at ``confidence``.
    confidence : float
    decision_scores : ndarray, shape (n,)
        Out-of-fold decision score of each subject (higher: the first group).
    n_splits, n_components : int
    model : str
    """

    auc: float
    ci_low: float
    ci_high: float
    confidence: float
    decision_scores: np.ndarray
    n_splits: int
    n_components: int
    model: str


def _auc_two_sample(first, second, axis=-1):
    """Mann-Whitney AUC ``P(x > y) + P(x = y) / 2`` of scores of the first group over the second."""
    x = np.moveaxis(np.asarray(first), axis, -1)[..., :, None]
    y = np.moveaxis(np.asarray(second), axis, -1)[..., None, :]
    return (x > y).mean(axis=(-2, -1)) + 0.5 * (x == y).mean(axis=(-2, -1))


def cross_validated_auc(
    features,
    groups,
    n_splits: int = 5,
    n_components: int = 5,
    rng: np.random.Generator | None = None,
    confidence: float = 0.95,
    n_bootstrap: int = 2000,
) -> ClassifierResult:
    """Cross-validated AUC of the group from ``features`` ``(n, p)`` (see the module).

    Parameters
    ----------
    features : array, shape (n, p)
        One row per subject (flatten per-vertex vectors first).
    groups : array of bool or 0/1, shape (n,)
    n_splits : int, default 5
        Folds; each group needs at least ``n_splits`` subjects.
    n_components : int, default 5
        PCA components (at most the training fold's size minus one).
    rng : numpy.random.Generator
        Draws the folds and the bootstrap (required).
    confidence : float, default 0.95
    n_bootstrap : int, default 2000

    Returns
    -------
    ClassifierResult
    """
    rng = check_rng(rng)
    x = np.asarray(features, dtype=float)
    if x.ndim != 2:
        raise ValueError(f"features: expected an array (n, p), got shape {x.shape}")
    if not np.isfinite(x).all():
        raise ValueError("features: contains NaN or infinite values")
    labels = check_groups(groups, x.shape[0])
    if isinstance(n_splits, bool) or int(n_splits) < 2:
        raise ValueError(f"n_splits: expected an int >= 2, got {n_splits!r}")
    n_splits = int(n_splits)
    smallest = min(int(labels.sum()), int((~labels).sum()))
    if smallest < n_splits:
        raise ValueError(
            f"n_splits: {n_splits} folds need at least {n_splits} subjects per group, "
            f"the smaller group has {smallest}"
        )
    if not 0 < confidence < 1:
        raise ValueError(f"confidence: expected a level in (0, 1), got {confidence}")
    train_size = x.shape[0] - int(np.ceil(x.shape[0] / n_splits))
    k = max(1, min(int(n_components), train_size - 1, x.shape[1]))
    folds = StratifiedKFold(n_splits, shuffle=True, random_state=int(rng.integers(2**31 - 1)))
    scores = np.empty(x.shape[0])
    for train, test in folds.split(x, labels):
        model = make_pipeline(PCA(k), LogisticRegression(C=1.0, max_iter=1000))
        model.fit(x[train], labels[train])
        scores[test] = model.decision_function(x[test])
    auc = float(roc_auc_score(labels, scores))
    with warnings.catch_warnings():  # a perfect separation makes every resample's AUC 1
        warnings.simplefilter("ignore", stats.DegenerateDataWarning)
        boot = stats.bootstrap(
            (scores[labels], scores[~labels]), _auc_two_sample, vectorized=True,
            n_resamples=int(n_bootstrap), confidence_level=confidence, method="percentile",
            rng=rng,
        )  # fmt: skip
    low, high = boot.confidence_interval
    if not (np.isfinite(low) and np.isfinite(high)):  # every resample equal: the AUC itself
        low = high = auc
    return ClassifierResult(
        auc, float(low), float(high), float(confidence), scores, n_splits, k,
        f"PCA({k}) + logistic regression, stratified {n_splits}-fold cross-validation",
    )  # fmt: skip
