"""Ground truth for the Cox regression and the cross-validated C-index."""

import numpy as np
import pandas as pd
import pytest
from lifelines import CoxPHFitter

from ladders.statistics.survival import (
    SurvivalResult,
    c_index,
    cross_validated_c_index,
    cross_validated_c_index_from_motion,
    simulate_survival,
)

BETA = np.array([1.0, -0.7, 0.5, 0.0])


def _linear_cohort(seed, n=200):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((n, BETA.size))
    risk = x @ BETA
    time, event = simulate_survival(risk, rng, censoring=0.3)
    return rng, x, risk, time, event


def test_simulated_censoring_fraction_and_hazard():
    rng = np.random.default_rng(0)
    risk = np.zeros(20000)
    time, event = simulate_survival(risk, rng, baseline_hazard=0.2, censoring=0.4)
    assert time.dtype == np.float64 and event.dtype == bool
    assert abs(1.0 - event.mean() - 0.4) < 0.02
    # min of independent exponentials with rates 0.2 and c: mean 1 / (0.2 + c), c = 0.2 * 0.4 / 0.6
    assert abs(time.mean() * (0.2 + 0.2 * 0.4 / 0.6) - 1.0) < 0.03
    time, event = simulate_survival(risk[:100], rng, censoring=0.0)
    assert event.all()


def test_c_index_sign_convention():
    time = np.arange(1.0, 11.0)
    event = np.ones(10, dtype=bool)
    assert c_index(time, -time, event) == 1.0  # highest risk dies first
    assert c_index(time, time, event) == 0.0
    assert c_index(time, np.zeros(10), event) == 0.5
    assert np.isnan(c_index(time[:2], time[:2], np.zeros(2, dtype=bool)))


def test_recovers_linear_risk():
    rng, x, risk, time, event = _linear_cohort(1)
    result = cross_validated_c_index(x, time, event, rng=rng, n_bootstrap=200, baseline=x[:, 3])
    assert isinstance(result, SurvivalResult)
    truth = c_index(time, risk, event)
    assert result.c_index > 0.7
    assert result.ci_low <= truth <= result.ci_high
    assert abs(result.c_index - truth) < 0.03
    assert result.ci_low <= result.c_index <= result.ci_high
    assert len(result.per_fold) == result.n_splits == 5
    assert result.n_components == 4 and result.risk_scores.shape == (200,)
    # the uninformative baseline feature: chance, and clearly worse than the model
    assert result.baseline_ci_low <= 0.5 <= result.baseline_ci_high
    assert result.difference_ci[0] > 0
    # hazard ratios per SD: the signs of the true coefficients
    assert np.all(np.sign(np.log(result.hazard_ratios[:3])) == np.sign(BETA[:3]))


def test_uninformative_features_give_chance():
    rng, _, _, time, event = _linear_cohort(2, n=120)
    noise = rng.standard_normal((120, 4))
    result = cross_validated_c_index(noise, time, event, rng=rng, n_bootstrap=200)
    assert result.ci_low <= 0.5 <= result.ci_high
    assert result.baseline_c_index is None and result.difference_ci is None


def test_hazard_ratios_match_lifelines():
    rng, x, _, time, event = _linear_cohort(3, n=150)
    result = cross_validated_c_index(x, time, event, n_splits=3, rng=rng, n_bootstrap=10)
    z = (x - x.mean(axis=0)) / x.std(axis=0, ddof=1)
    table = pd.DataFrame(z, columns=list("abcd")).assign(T=time, E=event.astype(int))
    fitter = CoxPHFitter(penalizer=0.1).fit(table, duration_col="T", event_col="E")
    np.testing.assert_allclose(result.hazard_ratios, fitter.hazard_ratios_.to_numpy(), rtol=1e-5)


def test_reproducible_with_the_same_generator():
    _, x, _, time, event = _linear_cohort(4, n=80)
    a = cross_validated_c_index(x, time, event, rng=np.random.default_rng(7), n_bootstrap=20)
    b = cross_validated_c_index(x, time, event, rng=np.random.default_rng(7), n_bootstrap=20)
    assert (a.c_index, a.ci_low, a.ci_high) == (b.c_index, b.ci_low, b.ci_high)


def test_pca_in_fold_on_displacement_fields():
    rng = np.random.default_rng(5)
    n, k = 60, 50
    amplitude = rng.standard_normal(n)
    region = np.zeros((k, 3))
    region[:10, 2] = 1.0  # a radial-like displacement of 10 vertices
    displacements = 0.3 * rng.standard_normal((n, k, 3)) + amplitude[:, None, None] * region
    time, event = simulate_survival(1.5 * amplitude, rng, censoring=0.3)
    noise = rng.standard_normal(n)
    result = cross_validated_c_index_from_motion(
        displacements, time, event, n_components=5, rng=rng, n_bootstrap=200, baseline=noise
    )
    assert result.n_components == 5
    assert result.c_index > 0.65
    assert result.c_index > result.baseline_c_index
    assert result.difference_ci[0] > 0


def test_bad_input_names_the_culprit():
    rng, x, _, time, event = _linear_cohort(6, n=30)
    with pytest.raises(ValueError, match="time: expected shape"):
        cross_validated_c_index(x, time[:-1], event, rng=rng)
    with pytest.raises(ValueError, match="features: contains NaN"):
        cross_validated_c_index(np.where(x > 2, np.nan, x), time, event, rng=rng)
    with pytest.raises(ValueError, match="event: no event"):
        cross_validated_c_index(x, time, np.zeros(30, dtype=bool), rng=rng)
    with pytest.raises(ValueError, match="time: expected positive"):
        cross_validated_c_index(x, -time, event, rng=rng)
    with pytest.raises(ValueError, match="n_splits"):
        cross_validated_c_index(x[:4], time[:4], event[:4], n_splits=5, rng=rng)
    with pytest.raises(ValueError, match="baseline: expected 30 rows"):
        cross_validated_c_index(x, time, event, rng=rng, baseline=np.ones(29))
    with pytest.raises(ValueError, match="displacements"):
        cross_validated_c_index_from_motion(np.ones(30), time, event, rng=rng)
    with pytest.raises(ValueError, match="censoring"):
        simulate_survival(np.zeros(5), rng, censoring=1.0)
    with pytest.raises(TypeError, match="rng"):
        cross_validated_c_index(x, time, event, rng=None)
