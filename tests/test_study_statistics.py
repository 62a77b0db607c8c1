"""Tidy per-subject table and the paired comparison residual vs no residual."""

import csv
import dataclasses
import io

import numpy as np
import pytest

from ladders.study.reporting.statistics import (
    MEASURES,
    paired_comparison,
    paired_csv,
    paired_statistics,
    tidy_csv,
    tidy_rows,
)

from .fake_results import fake_pair, fake_subject


def _pair(subject, alpha2, shift: float, unit="mm"):
    res = (1.0 + shift, 1.0 + shift, 1.0 + shift, 2.0)
    nores = (3.0 + shift, 3.0 + shift, 3.0 + shift, 2.0)
    ase = {"pole_ladder_residual": 0.1, "pole_ladder_no_residual": 0.3, "fanning": 0.2}
    errors = {"residual": res, "no_residual": nores}
    return fake_pair(subject, alpha2, errors, ase, (4.0, 5.0, 0.5, True), unit=unit)


def _results(n=3, unit="mm", drop=None):
    """Subjects s0.. with results at alpha^2 1 and 10; ``drop`` = (i, alpha2) failed."""
    out = []
    for i in range(n):
        pairs = [_pair(f"s{i}", 1.0, i, unit), _pair(f"s{i}", 10.0, -0.5 * i, unit)]
        failed = [(p.alpha2, "RuntimeError: x") for p in pairs if (i, p.alpha2) == drop]
        pairs = [p for p in pairs if (i, p.alpha2) != drop]
        out.append(fake_subject(f"s{i}", pairs, failed))
    return out


def test_tidy_table_columns_rows_and_units():
    rows = tidy_rows(_results())
    assert len(rows) == 3 * 2 * (2 * len(MEASURES) + 1)
    text = tidy_csv(rows)
    table = list(csv.DictReader(io.StringIO(text)))
    assert text.splitlines()[0] == "subject,alpha2,variant,measure,value,unit"
    assert {r["variant"] for r in table} == {"residual", "no_residual", "fanning"}
    assert {r["measure"] for r in table} == set(MEASURES)
    get = {(r["subject"], r["alpha2"], r["variant"], r["measure"]): r for r in table}
    assert float(get[("s2", "1.0", "residual", "centrality")]["value"]) == 3.0
    assert float(get[("s2", "10.0", "no_residual", "centrality")]["value"]) == 2.0
    assert get[("s0", "1.0", "no_residual", "registration_norm")]["value"] == "5.0"
    assert get[("s0", "1.0", "residual", "converged")]["value"] == "1.0"
    assert get[("s0", "1.0", "fanning", "ase")]["unit"] == "1"
    assert get[("s0", "1.0", "residual", "involutivity")]["unit"] == "mm"
    assert ("s0", "1.0", "fanning", "centrality") not in get
    rms = tidy_rows(_results(unit="mm RMS"))
    assert {r["unit"] for r in rms if r["measure"] == "centrality"} == {"mm RMS"}
    assert {r["unit"] for r in tidy_rows(_results(), unit="px")} >= {"px"}


def test_paired_comparison_known_answer():
    rng = np.random.default_rng(0)
    res = paired_comparison([1, 2, 3, 4, 5], [2, 4, 6, 8, 10], rng)  # d = -1 ... -5
    assert res.n == 5 and res.fraction_residual_lower == 1.0
    assert res.median_difference == -3.0
    assert res.wilcoxon_p == pytest.approx(2 / 2**5)  # exact two-sided, all one sign
    assert -5 <= res.ci_low <= -3 <= res.ci_high <= -1
    # The interval is scipy's paired BCa bootstrap of the median difference, same seed.
    from scipy.stats import bootstrap

    expected = bootstrap(
        (np.array([1.0, 2, 3, 4, 5]), np.array([2.0, 4, 6, 8, 10])),
        lambda x, y, axis: np.median(x - y, axis=axis),
        paired=True, vectorized=True, method="BCa", n_resamples=2000,
        rng=np.random.default_rng(0),
    ).confidence_interval  # fmt: skip
    assert (res.ci_low, res.ci_high) == (expected.low, expected.high)
    again = paired_comparison([1, 2, 3, 4, 5], [2, 4, 6, 8, 10], np.random.default_rng(0))
    assert again == res  # seeded
    mixed = paired_comparison([0, 5, 0, 5, 0, 5, 0], [1, 0, 1, 0, 1, 0, 1], rng)
    assert mixed.fraction_residual_lower == pytest.approx(4 / 7)
    assert mixed.median_difference == -1.0


def test_paired_comparison_degenerate_cases():
    rng = np.random.default_rng(1)
    zero = paired_comparison([1.0, 2.0], [1.0, 2.0], rng)
    assert zero.wilcoxon_p == 1.0 and zero.median_difference == 0.0
    assert zero.fraction_residual_lower == 0.0 and "zero" in zero.note
    empty = paired_comparison([], [], rng)
    assert empty.n == 0 and empty.wilcoxon_p is None and empty.median_difference is None
    one = paired_comparison([1.0], [3.0], rng)
    assert one.wilcoxon_p == pytest.approx(1.0) and "n = 1" in one.note
    assert (one.ci_low, one.ci_high) == (-2.0, -2.0)  # all differences equal
    assert "all differences equal" in one.note
    two = paired_comparison([1.0, 2.0], [2.0, 2.0], rng)
    assert two.ci_low is None and two.ci_high is None and "n = 2 < 3" in two.note
    ties = paired_comparison([0, 0, 0, 0, 1], [0, 0, 0, 0, 0], rng)  # BCa is 0 / 0 here
    assert (ties.ci_low, ties.ci_high) == (0.0, 1.0)
    assert "percentile interval" in ties.note
    with pytest.raises(ValueError, match="residual, no_residual: .*shapes"):
        paired_comparison([1.0, 2.0], [1.0], rng)
    with pytest.raises(ValueError, match="finite"):
        paired_comparison([np.nan], [1.0], rng)


def test_paired_statistics_per_alpha_and_error_skip_failed_subjects():
    results = _results(4, drop=(3, 10.0))  # failed there
    rows = paired_statistics(results, seed=0)
    assert [(r.alpha2, r.measure) for r in rows[:2]] == [
        (1.0, "midpoint_distance"),
        (1.0, "centrality"),
    ]
    assert len(rows) == 2 * 5
    get = {(r.alpha2, r.measure): r for r in rows}
    assert get[(1.0, "centrality")].n == 4 and get[(10.0, "centrality")].n == 3
    assert get[(1.0, "centrality")].median_difference == -2.0
    assert get[(1.0, "transvectivity")].wilcoxon_p == 1.0
    assert get[(1.0, "ase")].fraction_residual_lower == 1.0
    lines = paired_csv(rows).splitlines()
    assert lines[0].startswith("alpha2,measure,n,fraction_residual_lower,median_difference")
    assert len(lines) == 11


def test_convergence_paragraph_counts_registrations_and_the_largest_gradient():
    from ladders.study.reporting.report import convergence_markdown
    from ladders.study.running import RegistrationCounts

    def pair(alpha2, gradient):
        counts = RegistrationCounts(13, 1, 260, 520, gradient)
        return dataclasses.replace(_pair("s", alpha2, 0.0), counts=counts)

    results = [
        fake_subject("s0", [pair(1.0, 2e-8)]),
        fake_subject("s1", [pair(1.0, 5e-7), pair(10.0, 0.0)]),
    ]
    text = convergence_markdown(results)
    assert "Registrations: 39; 36 (92.31%) converged, 3 stopped before" in text
    assert "20 iterations on average" in text
    ruled = convergence_markdown(results, "the shape moved by at most 1e-4")
    assert "converged (the stopping rule: the shape moved by at most 1e-4)" in ruled
    assert "(40 flow passes)" in text
    assert "largest final gradient 5e-07" in text


def test_terminal_table_fits_100_columns_and_names_the_unit():
    from ladders.study.reporting import summarize, terminal_summary

    alphas = (0.01, 0.1, 1.0, 10.0, 33.0, 100.0, 1089.0)
    results = []
    for i in range(20):
        shift = 1e-5 * (i + 1.2345)  # long numbers: 1.23e-05 / 3.00001
        errors = {"residual": (shift,) * 4, "no_residual": (123.456 + shift,) * 4}
        ase = {"pole_ladder_residual": shift, "pole_ladder_no_residual": 12.3456, "fanning": 0.5}
        pairs = [fake_pair(f"s{i}", a, errors, ase, (5.0345, 33.333, 0.299, True)) for a in alphas]
        results.append(fake_subject(f"s{i}", pairs))
    text = terminal_summary(summarize(results), "mm (per-vertex RMS)", 20)
    lines = text.splitlines()
    assert max(len(line) for line in lines) <= 100
    assert "per-vertex RMS" in lines[0] and "20 subjects" in lines[0]
    assert sum(line.startswith("0.01 ") for line in lines) == 2  # one row per table
    assert "ASE fanning" in text and "Inverse cons." in text
