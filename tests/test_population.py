"""Group statistics of transported motion against a planted truth, on the documented default cohort."""

import csv

import meshio
import numpy as np
import pytest

from ladders.statistics import binomial_interval, detection_power, dice
from ladders.study.cli import main
from ladders.study.errors import CohortError
from ladders.study.population import (
    analyze,
    check_groups_table,
    compare_groups,
    load_transported_motion,
    null_false_positive_rate,
    select_motions,
)


def _motion(out, method):
    return next(m for m in load_transported_motion(out / "study") if m.method == method)


def test_the_default_effect_is_found_by_the_pole_ladder_with_residuals(default_study):
    data, out = default_study
    motion = _motion(out, "pole_ladder_residual")
    labels = np.array([data.groups[s] == "patients" for s in motion.subjects])
    c = compare_groups(motion, labels, n_permutations=2000, rng=np.random.default_rng(0))
    found = c.detected(0.05)
    assert detection_power(found, data.region.affected) >= 0.8
    assert dice(found, data.region.affected) >= 0.6
    # hypokinesia moves the wall along its normal: the normal component finds it too
    assert detection_power(c.detected(0.05, "normal"), data.region.affected) >= 0.8
    assert c.global_test.p_permutation < 0.01
    assert (
        c.classifier.auc > 0.8 and c.classifier.ci_low <= c.classifier.auc <= c.classifier.ci_high
    )


def test_false_positive_rate_under_the_null_is_five_percent(default_study):
    """Controls only (one distribution), split at random: the max-T test's FWER is 5 %."""
    data, out = default_study
    motion = _motion(out, "pole_ladder_residual")
    controls = [s for s in motion.subjects if data.groups[s] == "controls"]
    null = null_false_positive_rate(motion.subset(controls), 10, np.random.default_rng(1),
                                    n_repetitions=200, n_permutations=400)  # fmt: skip
    low, high = binomial_interval(round(0.05 * 200), 200, confidence=0.99)
    assert low <= null.rate <= high, (null.rate, low, high)
    assert null.low <= 0.05 <= null.high


def test_classifier_auc_is_chance_under_the_null(default_study):
    data, out = default_study
    motion = _motion(out, "pole_ladder_residual")
    controls = [s for s in motion.subjects if data.groups[s] == "controls"]
    sub = motion.subset(controls)
    rng = np.random.default_rng(2)
    aucs = []
    for _ in range(12):
        labels = np.zeros(len(controls), dtype=bool)
        labels[rng.permutation(len(controls))[:10]] = True
        aucs.append(compare_groups(sub, labels, n_permutations=50, rng=rng, n_components=3,
                                   n_splits=5).classifier.auc)  # fmt: skip
    assert abs(np.mean(aucs) - 0.5) < 3 * np.std(aucs) / np.sqrt(len(aucs)) + 0.05


def test_analyze_writes_tables_maps_and_figures(default_study, tmp_path):
    data, out = default_study
    outcome = analyze(out / "study", data.groups, tmp_path / "analysis", region=data.region,
                      n_permutations=500, progress=False)  # fmt: skip
    k = data.cohort.n_vertices
    with open(outcome.paths["vertices.csv"]) as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(outcome.comparisons) * 4 * k
    assert {r["test"] for r in rows} == {"hotelling_t2", "normal_t", "strain_t", "wall_motion_t"}
    assert len(outcome.scores) == len(outcome.comparisons) == 4  # none + three transports
    ladder = next(s for s in outcome.scores if s.method == "pole_ladder_residual")
    assert ladder.power >= 0.8
    vtu = meshio.read(tmp_path / "analysis" / "maps" / "lddmm_pole_ladder_residual_alpha2=1.vtu")
    assert {"hotelling_p_fwer", "planted_region", "mean_displacement_patients"} <= set(
        vtu.point_data
    )
    for name in ("fig_pvalue_map.png", "fig_group_means.png", "fig_pca_modes.png",
                 "fig_transport_scores.png", "summary.md"):  # fmt: skip
        assert (tmp_path / "analysis" / name).stat().st_size > 0
    assert "Against the planted truth" in (tmp_path / "analysis" / "summary.md").read_text()


def test_bad_groups_and_selections_are_refused_before_any_computation(default_study):
    data, out = default_study
    subjects = list(data.groups)
    with pytest.raises(CohortError, match="not in the study"):
        check_groups_table(subjects, {**data.groups, "stranger": "patients"})
    with pytest.raises(CohortError, match="two groups"):
        check_groups_table(subjects, dict.fromkeys(subjects, "all"))
    few = {s: ("rare" if i < 2 else "common") for i, s in enumerate(subjects)}
    with pytest.raises(CohortError, match="at least 3"):
        check_groups_table(subjects, few)
    with pytest.raises(CohortError, match="name the two"):
        check_groups_table(subjects, {s: f"g{i % 3}" for i, s in enumerate(subjects)})
    labels, names, kept = check_groups_table(
        subjects, {s: f"g{i % 3}" for i, s in enumerate(subjects)}, compare=("g2", "g0")
    )
    assert names == ("g2", "g0") and len(kept) == labels.size == 27
    motions = load_transported_motion(out / "study")
    with pytest.raises(CohortError, match="alpha2"):
        select_motions(motions, alpha2=[10.0])
    with pytest.raises(CohortError, match="transport"):
        select_motions(motions, methods=["svf_conjugation"])


def test_cli_cohort_then_analyze(default_study, tmp_path, capsys):
    data, out = default_study
    assert main(["cohort", "-o", str(tmp_path / "c"), "--subjects", "6", "--vertices", "241",
                 "--effect", "twist", "--magnitude", "4"]) == 0  # fmt: skip
    assert (tmp_path / "c" / "groups.csv").is_file()
    assert "twist, magnitude 4 degrees" in capsys.readouterr().out
    code = main(["analyze", str(out / "study"), "--groups", str(out / "meshes" / "groups.csv"),
                 "--truth", str(out / "meshes" / "planted_region.json"), "--permutations", "200",
                 "--compare", "patients,controls", "--no-figures", "--no-progress",
                 "-o", str(tmp_path / "a")])  # fmt: skip
    assert code == 0
    printed = capsys.readouterr().out
    assert "patients (20) against controls (20)" in printed
    bad = tmp_path / "bad.csv"
    bad.write_text("subject,group\nsynthetic_000,a\nnobody,b\n")
    assert main(["analyze", str(out / "study"), "--groups", str(bad), "--no-progress"]) == 2
    assert "not in the study" in capsys.readouterr().err
