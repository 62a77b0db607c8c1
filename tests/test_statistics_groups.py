"""Per-vertex two-group tests: exact statistics, family-wise error under the null, power, AUC."""

import numpy as np
import pytest
from scipy import stats

from ladders.statistics import (
    binomial_interval,
    check_groups,
    cross_validated_auc,
    detection_power,
    dice,
    global_test,
    vertexwise_test,
)


def _naive_t2(x, g):
    a, b = x[g], x[~g]
    n1, n2 = len(a), len(b)
    d = a.mean(0) - b.mean(0)
    pooled = (a - a.mean(0)).T @ (a - a.mean(0)) + (b - b.mean(0)).T @ (b - b.mean(0))
    pooled /= n1 + n2 - 2
    return n1 * n2 / (n1 + n2) * d @ np.linalg.solve(pooled, d)


def test_statistics_equal_the_textbook_formulas():
    rng = np.random.default_rng(0)
    x = rng.standard_normal((17, 9, 3))
    g = np.arange(17) < 7
    test = vertexwise_test(x, g, 50, rng=rng)
    naive = np.array([_naive_t2(x[:, v], g) for v in range(9)])
    np.testing.assert_allclose(test.statistic, naive, rtol=1e-6)
    n, d = 17, 3
    f = naive * (n - d - 1) / (d * (n - 2))
    np.testing.assert_allclose(test.p_uncorrected, stats.f.sf(f, d, n - d - 1), rtol=1e-5)
    scalar = vertexwise_test(x[..., 0], g, 50, rng=rng)
    ref = stats.ttest_ind(x[g, :, 0], x[~g, :, 0])
    np.testing.assert_allclose(scalar.statistic, ref.statistic, rtol=1e-7)
    np.testing.assert_allclose(scalar.p_uncorrected, ref.pvalue, rtol=1e-6)
    assert test.kind == "hotelling" and scalar.kind == "t" and test.group_sizes == (7, 10)


def test_permutation_maxima_equal_a_loop_over_the_same_permutations():
    x = np.random.default_rng(1).standard_normal((12, 5, 2))
    g = np.arange(12) < 5
    test = vertexwise_test(x, g, 40, rng=np.random.default_rng(7), chunk_size=7)
    rng = np.random.default_rng(7)  # the same draws, chunk by chunk
    maxima = []
    for start in range(0, 40, 7):
        m = min(7, 40 - start)
        for labels in rng.permuted(np.broadcast_to(g, (m, 12)), axis=1):
            maxima.append(max(_naive_t2(x[:, v], labels) for v in range(5)))
    np.testing.assert_allclose(test.max_null, maxima, rtol=1e-6)
    exceed = [(np.array(maxima) >= s * (1 - 1e-9)).sum() for s in test.statistic]
    np.testing.assert_allclose(test.p_fwer, (1 + np.array(exceed)) / 41)


def test_family_wise_error_under_the_null_is_the_nominal_level():
    rng = np.random.default_rng(2)
    hits, uncorrected_hits, reps = 0, 0, 300
    for _ in range(reps):
        x = rng.standard_normal((20, 30, 3)) @ np.diag([1.0, 2.0, 0.5])  # one distribution
        g = rng.permutation(20) < 10
        test = vertexwise_test(x, g, 200, rng=rng)
        hits += bool((test.p_fwer < 0.05).any())
        uncorrected_hits += bool((test.p_uncorrected < 0.05).any())
    low, high = binomial_interval(round(0.05 * reps), reps, confidence=0.99)
    assert low <= hits / reps <= high, hits / reps
    # without the correction, 30 vertices give a far larger rate: the check can fail
    assert uncorrected_hits / reps > high


def test_a_planted_shift_is_found_where_it_is():
    rng = np.random.default_rng(3)
    x = rng.standard_normal((40, 200, 3))
    g = np.arange(40) < 20
    truth = np.zeros(200, dtype=bool)
    truth[50:80] = True
    x[np.ix_(g, truth)] += np.array([2.0, 0.0, 0.0])
    test = vertexwise_test(x, g, 2000, rng=rng)
    found = test.significant(0.05)
    assert detection_power(found, truth) >= 0.8
    assert dice(found, truth) >= 0.8
    assert found[~truth].sum() <= 2


def test_a_vertex_that_never_moves_has_statistic_zero():
    rng = np.random.default_rng(4)
    x = rng.standard_normal((10, 4, 3))
    x[:, 0] = 0.0
    test = vertexwise_test(x, np.arange(10) < 5, 100, rng=rng)
    assert test.statistic[0] == 0.0 and test.p_uncorrected[0] == 1.0
    assert np.isfinite(test.statistic).all()


def test_global_test_is_uniform_under_the_null_and_small_under_an_effect():
    rng = np.random.default_rng(5)
    rejections = 0
    for _ in range(200):
        s = rng.standard_normal((24, 4))
        rejections += global_test(s, rng.permutation(24) < 12, 200, rng=rng).p_permutation < 0.05
    low, high = binomial_interval(10, 200, confidence=0.99)
    assert low <= rejections / 200 <= high
    s = rng.standard_normal((24, 4))
    g = np.arange(24) < 12
    s[g, 0] += 2.0
    result = global_test(s, g, 2000, rng=rng)
    assert result.p_permutation < 0.01 and result.p_parametric < 0.01


def test_classifier_auc_is_chance_under_the_null_and_high_under_an_effect():
    rng = np.random.default_rng(6)
    aucs = [cross_validated_auc(rng.standard_normal((30, 60)), np.arange(30) < 15, rng=rng,
                                n_bootstrap=200).auc for _ in range(30)]  # fmt: skip
    assert abs(np.mean(aucs) - 0.5) < 3 * np.std(aucs) / np.sqrt(30) + 0.02
    x = rng.standard_normal((30, 60))
    g = np.arange(30) < 15
    x[g, :5] += 1.5
    result = cross_validated_auc(x, g, rng=rng, n_bootstrap=500)
    assert result.auc > 0.9 and result.ci_low <= result.auc <= result.ci_high
    assert result.decision_scores.shape == (30,)


def test_bad_inputs_name_the_argument():
    rng = np.random.default_rng(7)
    x = rng.standard_normal((10, 4, 3))
    with pytest.raises(ValueError, match="groups"):
        vertexwise_test(x, np.arange(9) < 5, 10, rng=rng)
    with pytest.raises(ValueError, match="at least 3"):
        check_groups(np.arange(10) < 2, 10)
    with pytest.raises(ValueError, match="0/1"):
        check_groups(np.arange(10), 10)
    with pytest.raises(ValueError, match="NaN"):
        vertexwise_test(np.full((10, 4), np.nan), np.arange(10) < 5, 10, rng=rng)
    with pytest.raises(ValueError, match="n_permutations"):
        vertexwise_test(x, np.arange(10) < 5, 0, rng=rng)
    with pytest.raises(TypeError, match="rng"):
        vertexwise_test(x, np.arange(10) < 5, 10, rng=None)
    with pytest.raises(ValueError, match="n_splits"):
        cross_validated_auc(x.reshape(10, -1), np.arange(10) < 3, n_splits=5, rng=rng)
    with pytest.raises(ValueError, match="truth"):
        detection_power(np.ones(3, bool), np.zeros(3, bool))
