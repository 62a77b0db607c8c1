"""The linear-model analysis of transported motion: the two-group test as a special case, TFCE,
AHA segments, covariates, the command line and bad input, on the documented default cohort."""

import csv
import json

import meshio
import numpy as np
import pytest

from ladders.statistics import design_matrix, detection_power, dice, pillai_to_hotelling
from ladders.study.cli import main
from ladders.study.errors import CohortError
from ladders.study.population import (
    aha_segments,
    analyze_model,
    compare_groups,
    compare_model,
    load_transported_motion,
)
from ladders.study.preparation.synthetic_landmarks import synthetic_landmarks
from ladders.study.wall_motion import outward_vertex_normals

P = 1000


def _ladder(out):
    return next(
        m for m in load_transported_motion(out / "study") if m.method == "pole_ladder_residual"
    )


def _table(data, subjects, **extra):
    table = {"subject": list(subjects), "group": [data.groups[s] for s in subjects]}
    table.update(extra)
    return table


def _mc(p, n):
    """Four Monte Carlo standard errors of the difference of two permutation p-values (with a
    floor of one count's variance near 0 and 1), plus two steps."""
    return 4.0 * np.sqrt(2.0 * (p * (1.0 - p) + 1.0 / n) / n) + 2.0 / n


def test_two_group_model_is_the_two_group_test(default_study):
    data, out = default_study
    motion = _ladder(out)
    labels = np.array([data.groups[s] == "patients" for s in motion.subjects])
    groups = compare_groups(motion, labels, n_permutations=P, rng=np.random.default_rng(1))
    design = design_matrix(_table(data, motion.subjects), "group")
    model = compare_model(motion, design, "group[patients] - group[controls]", P,
                          np.random.default_rng(2))  # fmt: skip
    n, p = design.shape
    # equal up to the ridge of 1e-9 the two-group test adds to each vertex's scatter
    # (the statistics themselves agree to 1e-10 without it: tests/test_linear_model.py)
    for test in ("normal", "strain", "wall_motion"):
        np.testing.assert_allclose(model.tests[test].statistic, getattr(groups, test).statistic,
                                   rtol=1e-6)  # fmt: skip
        a, b = model.tests[test].p_fwer, getattr(groups, test).p_fwer
        assert np.all(np.abs(a - b) <= _mc(np.maximum(a, b), P))
    hotelling = pillai_to_hotelling(model.tests["displacement"].statistic, n - p)
    np.testing.assert_allclose(hotelling, groups.displacement.statistic, rtol=1e-8)
    # the effect of the normal component is the difference of the group means
    normal_diff = model.effects["normal"]
    along = np.einsum(
        "nkd,kd->nk", motion.displacement, outward_vertex_normals(motion.atlas, motion.faces)
    )
    np.testing.assert_allclose(
        normal_diff, along[labels].mean(0) - along[~labels].mean(0), atol=1e-10
    )


def test_tfce_and_segments_find_the_planted_region(default_study):
    data, out = default_study
    motion = _ladder(out)
    design = design_matrix(_table(data, motion.subjects), "group")
    lm = synthetic_landmarks(motion.atlas)
    segments = aha_segments(motion.atlas, lm.apex, lm.base, lm.septum)
    c = compare_model(motion, design, "group[patients] - group[controls]", P,
                      np.random.default_rng(3), tfce=True, segments=segments)  # fmt: skip
    affected = data.region.affected
    vertex = c.detected(0.05, "normal")
    cluster = c.detected(0.05, "normal", tfce=True)
    assert detection_power(cluster, affected) >= detection_power(vertex, affected) >= 0.8
    assert dice(cluster, affected) >= 0.6
    # hypokinesia in segments 7, 8, 13, 14: less inward motion (a positive normal effect)
    planted = set(data.region.abnormality.segments)
    found = set(np.flatnonzero(c.segment_tests["wall_motion"].p_fwer < 0.05) + 1)
    assert found & planted and found <= planted | {1, 2, 9, 12, 15, 16, 17}
    effect = c.segment_effects["wall_motion"]
    assert all(effect[s - 1] > 0 for s in planted)


def test_smoothed_maps_find_a_region_that_vertex_noise_hides(default_study):
    """Noise of 2 mm RMS along the normal, drawn independently at every vertex, added to
    every subject's transported displacement: the maps smoothed on the atlas (10 mm FWHM)
    find more of the planted region by the normal motion than the raw maps, with few
    vertices outside; the responses tested are the smoothed ones, the displacement
    component by component (a translation is kept)."""
    from dataclasses import replace

    from ladders.statistics import SurfaceSmoother
    from ladders.study.population import model_responses

    data, out = default_study
    motion = _ladder(out)
    nu = outward_vertex_normals(motion.atlas, motion.faces)
    noise = np.random.default_rng(11).normal(0.0, 2.0, motion.displacement.shape[:2])
    noisy = replace(motion, displacement=motion.displacement + noise[..., None] * nu)
    design = design_matrix(_table(data, noisy.subjects), "group")
    contrast = "group[patients] - group[controls]"
    raw = compare_model(noisy, design, contrast, P, np.random.default_rng(12))
    smooth = compare_model(noisy, design, contrast, P, np.random.default_rng(12), fwhm=10.0)
    affected = data.region.affected
    found_raw, found = raw.detected(0.05, "normal"), smooth.detected(0.05, "normal")
    print(f"normal motion: raw {detection_power(found_raw, affected):.2f}, smoothed "
          f"{detection_power(found, affected):.2f}; outside {(found & ~affected).sum()}")  # fmt: skip
    assert detection_power(found, affected) >= detection_power(found_raw, affected) + 0.1
    assert (found & ~affected).sum() <= 0.05 * affected.size
    smoother = SurfaceSmoother(noisy.atlas, noisy.faces, 10.0)
    responses = model_responses(noisy, 10.0)
    np.testing.assert_allclose(responses["strain"], smoother(noisy.strain), atol=1e-12)
    np.testing.assert_allclose(responses["displacement"][..., 1],
                               smoother(noisy.displacement[..., 1]), atol=1e-12)  # fmt: skip
    shifted = replace(motion, displacement=np.broadcast_to([1.0, -2.0, 0.5],
                                                           motion.displacement.shape))  # fmt: skip
    np.testing.assert_allclose(model_responses(shifted, 10.0)["displacement"],
                               shifted.displacement, atol=1e-9)  # fmt: skip


def test_an_irrelevant_covariate_keeps_the_power_and_age_has_no_effect(default_study):
    data, out = default_study
    motion = _ladder(out)
    rng = np.random.default_rng(4)
    age = rng.uniform(40, 80, len(motion.subjects))
    design = design_matrix(_table(data, motion.subjects, age=list(age)), "group + age")
    c = compare_model(motion, design, "group[patients] - group[controls]", P,
                      np.random.default_rng(5))  # fmt: skip
    assert detection_power(c.detected(0.05, "normal"), data.region.affected) >= 0.8
    slope = compare_model(motion, design, "age", P, np.random.default_rng(6))
    assert slope.detected(0.05, "normal").mean() < 0.05


def test_analyze_model_writes_tables_maps_and_bullseyes(default_study, tmp_path):
    data, out = default_study
    subjects = list(data.groups)
    table = _table(data, subjects[:-2])  # two subjects left out
    lm = synthetic_landmarks(data.cohort.atlas)
    outcome = analyze_model(out / "study", table, "group", ["group[patients] - group[controls]"],
                            tmp_path / "a", methods=["pole_ladder_residual"], n_permutations=200,
                            tfce=True, aha_landmarks=lm, progress=False)  # fmt: skip
    assert outcome.left_out == subjects[-2:]
    k = data.cohort.n_vertices
    with open(outcome.paths["model_vertices.csv"]) as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 4 * k and all(0 < float(r["p_fwer_tfce"]) <= 1 for r in rows)
    with open(outcome.paths["model_segments.csv"]) as fh:
        assert len(list(csv.DictReader(fh))) == 4 * 17
    vtu = meshio.read(next((tmp_path / "a" / "maps").glob("model_*.vtu")))
    assert {"aha_segment", "normal_tfce", "normal_tfce_p_fwer", "wall_motion_effect"} <= set(
        vtu.point_data
    )
    assert set(np.unique(vtu.point_data["aha_segment"]).astype(int)) == set(range(1, 18))
    assert (tmp_path / "a" / "fig_bullseye_group_patients_group_controls.png").stat().st_size
    summary = (tmp_path / "a" / "model_summary.md").read_text()
    assert "AHA segments: wall motion" in summary and "TFCE" in summary


def test_bad_designs_are_refused_before_any_computation(default_study):
    data, out = default_study
    subjects = list(data.groups)
    good = _table(data, subjects)
    cases = [
        ({**good, "subject": subjects[:-1] + ["stranger"]}, "group", ["group"], "stranger"),
        (good, "group + age", ["group"], "age"),
        (good, "group", ["group[sick] - group[controls]"], "sick"),
        ({**good, "age": [1.0] * len(subjects)}, "group + age", ["age"], "constant"),
        (
            {**good, "age": ["x"] + [1.0 + i for i in range(len(subjects) - 1)]},
            "group + age",
            ["age"],
            "x",
        ),  # fmt: skip
        (
            {**good, "age": [None] + [1.0 + i for i in range(len(subjects) - 1)]},
            "group + age",
            ["age"],
            "missing",
        ),  # fmt: skip
    ]
    for table, formula, contrasts, culprit in cases:
        with pytest.raises(CohortError, match=culprit):
            analyze_model(out / "study", table, formula, contrasts, n_permutations=10,
                          progress=False)  # fmt: skip


def test_cli_design_model_contrast_tfce_aha(default_study, tmp_path, capsys):
    data, out = default_study
    rng = np.random.default_rng(7)
    design = tmp_path / "design.csv"
    lines = ["subject,group,age,sex"] + [
        f"{s},{g},{rng.uniform(40, 80):.1f},{'FM'[i % 2]}"
        for i, (s, g) in enumerate(data.groups.items())
    ]
    design.write_text("\n".join(lines) + "\n")
    lm = synthetic_landmarks(data.cohort.atlas)
    aha = tmp_path / "atlas_landmarks.json"
    aha.write_text(json.dumps({"apex": lm.apex.tolist(), "base_centre": lm.base.tolist(),
                               "septal_point": lm.septum.tolist()}))  # fmt: skip
    code = main(["analyze", str(out / "study"), "--design", str(design), "--model",
                 "group + age + sex", "--contrast", "group[patients] - group[controls]", "age",
                 "--tfce", "--aha", str(aha), "--transport", "pole_ladder_residual",
                 "--permutations", "200", "--no-progress", "-o", str(tmp_path / "m")])  # fmt: skip
    assert code == 0
    printed = capsys.readouterr().out
    assert "model 'group + age + sex', 40 subjects" in printed and "TFCE" in printed
    assert (tmp_path / "m" / "model_segments.csv").is_file()
    # the groups table with --tfce and --aha runs both analyses
    code = main(["analyze", str(out / "study"), "--groups", str(out / "meshes" / "groups.csv"),
                 "--tfce", "--aha", str(aha), "--transport", "pole_ladder_residual",
                 "--permutations", "200", "--no-progress", "--no-figures", "--fwhm", "10",
                 "-o", str(tmp_path / "g")])  # fmt: skip
    assert code == 0
    assert "atlas vertices, maps smoothed 10 mm FWHM" in capsys.readouterr().out
    assert (
        "Maps smoothed on the atlas, 10 mm FWHM."
        in (tmp_path / "g" / "model_summary.md").read_text()
    )
    assert {"summary.md", "model_summary.md", "model_segments.csv"} <= {
        p.name for p in (tmp_path / "g").iterdir()
    }
    assert main(["analyze", str(out / "study"), "--design", str(design), "--model", "group + bmi",
                 "--contrast", "group", "--no-progress"]) == 2  # fmt: skip
    assert "bmi" in capsys.readouterr().err
    assert main(["analyze", str(out / "study"), "--no-progress"]) == 2
    assert "--groups or --design" in capsys.readouterr().err


def test_outcome_is_predicted_from_the_regional_motion(default_study, tmp_path, capsys):
    """A survival outcome simulated from each subject's true regional normal motion is
    predicted from the transported motion's PCA scores (C-index well above chance), not
    from a baseline column of noise; bad outcome columns are refused."""
    from ladders.statistics import simulate_survival

    data, out = default_study
    subjects = list(data.groups)
    by_name = {s.name: s for s in data.cohort.subjects}
    normals = outward_vertex_normals(data.cohort.atlas, data.cohort.faces)
    regional = np.array([
        np.einsum("kd,kd->k", by_name[s].es - by_name[s].ed, normals)[data.region.affected].mean()
        for s in subjects
    ])  # fmt: skip
    rng = np.random.default_rng(8)
    time, event = simulate_survival(2.0 * (regional - regional.mean()) / regional.std(), rng)
    noise = rng.standard_normal(len(subjects))
    design = tmp_path / "design.csv"
    design.write_text("subject,time,event,noise\n" + "".join(
        f"{s},{t:.6g},{int(e)},{x:.6g}\n" for s, t, e, x in zip(subjects, time, event, noise)))  # fmt: skip
    code = main(["analyze", str(out / "study"), "--design", str(design), "--outcome",
                 "time,event", "--baseline", "noise", "--transport", "pole_ladder_residual",
                 "--no-progress", "-o", str(tmp_path / "o")])  # fmt: skip
    assert code == 0
    with open(tmp_path / "o" / "outcome.csv") as fh:
        (row,) = list(csv.DictReader(fh))
    assert float(row["c_index"]) > 0.7 and float(row["ci_low"]) > 0.5
    assert float(row["difference_ci_low"]) > 0  # the motion beats the noise column
    assert "C-index" in capsys.readouterr().out
    bad = tmp_path / "bad.csv"
    bad.write_text(design.read_text().replace(",1,", ",2,", 1))
    assert main(["analyze", str(out / "study"), "--design", str(bad), "--outcome", "time,event",
                 "--no-progress", "-o", str(tmp_path / "b")]) == 2  # fmt: skip
    assert "0 or 1" in capsys.readouterr().err
    assert main(["analyze", str(out / "study"), "--design", str(design), "--outcome",
                 "followup,event", "--no-progress", "-o", str(tmp_path / "b")]) == 2  # fmt: skip
    assert "followup" in capsys.readouterr().err
