"""The linear model on whole cycles: closed forms of its statistics, the trajectory's components,
a delayed contraction, the cohort with covariates through the cycle, and the command line."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from scipy import stats

from ladders.statistics import design_matrix, pillai_to_hotelling
from ladders.study.cli import main
from ladders.study.cohort.planted_effect import MotionAbnormality
from ladders.study.meshes.mesh_io import read_mesh, write_mesh
from ladders.study.population import (
    CohortGroup,
    Covariates,
    covariate_cycles,
    make_covariate_cohort,
    make_two_group_cycles,
)
from ladders.study.preparation.synthetic_landmarks import synthetic_landmarks
from ladders.study.sequences import (
    CycleMotion,
    compare_cycles,
    cycle_model,
    cycle_responses,
    read_tracked_frames,
    trajectory_components,
)


def _noisy(c, rng, fixed=0.35, frame=0.1) -> CycleMotion:
    """The true frames' motion with a tracking-like error: per subject and vertex a fixed
    part (every frame but ED) and an independent part per frame (mm per coordinate)."""
    d = c.frames - c.frames[:, :1]
    n, n_frames, k, _ = d.shape
    error = rng.normal(size=(n, 1, k, 3)) * fixed + rng.normal(size=(n, n_frames, k, 3)) * frame
    error[:, 0] = 0.0
    return CycleMotion(c.names, d + error, c.data.cohort.atlas, c.faces)


@pytest.fixture(scope="module")
def small():
    c = make_two_group_cycles(n_subjects=12, n_frames=8, n_vertices=150, seed=3, check=False)
    return c, _noisy(c, np.random.default_rng(0))


def test_the_statistics_are_those_of_the_closed_forms(small):
    """Two groups: the peak's and every frame's t are the pooled two-sample t; three
    groups: the F of the factor is the one-way ANOVA's; with a covariate, the group's t
    is the least-squares t of the adjusted model."""
    c, motion = small
    tests = compare_cycles(motion, c.patients, 20, np.random.default_rng(0))
    t_peak = stats.ttest_ind(tests.peaks[c.patients], tests.peaks[~c.patients]).statistic
    np.testing.assert_allclose(tests.peak.statistic, t_peak, rtol=1e-8)
    curves = tests.curves(motion)
    t_frame = stats.ttest_ind(curves[c.patients, 3], curves[~c.patients, 3]).statistic
    np.testing.assert_allclose(tests.per_frame.statistic[3], t_frame, rtol=1e-8)
    assert np.all(tests.per_frame.statistic[0] == 0)  # ED: no motion, no statistic
    groups = np.array(["a", "b", "c"] * 4)
    rng = np.random.default_rng(1)
    age = rng.normal(60, 10, 12)
    table = {"subject": list(c.names), "group": list(groups), "age": list(age)}
    responses = cycle_responses(motion)
    three = cycle_model(responses, design_matrix(table, "group"), "group", 20, rng,
                        summaries=("peak",))  # fmt: skip
    f_oneway = stats.f_oneway(*(responses.peaks[groups == g] for g in "abc")).statistic
    assert three.peak.kind == "F" and three.per_frame is None
    np.testing.assert_allclose(three.peak.statistic, f_oneway, rtol=1e-8)
    design = design_matrix(table, "group + age")
    adjusted = cycle_model(responses, design, "group[b] - group[a]", 20, rng,
                           summaries=("time_to_peak",))  # fmt: skip
    x, y = design.matrix, responses.times
    beta, *_ = np.linalg.lstsq(x, y, rcond=None)
    resid = ((y - x @ beta) ** 2).sum(axis=0) / (12 - x.shape[1])
    cvec = np.zeros(x.shape[1])
    cvec[design.columns.index("group[T.b]")] = 1.0
    se = np.sqrt(resid * (cvec @ np.linalg.inv(x.T @ x) @ cvec))
    np.testing.assert_allclose(adjusted.time_to_peak.statistic, cvec @ beta / se, rtol=1e-8)
    np.testing.assert_allclose(adjusted.time_to_peak.effect[0], cvec @ beta, rtol=1e-8)


def test_the_trajectory_test_is_hotellings_t2_on_each_vertexs_components(small):
    """Pillai's trace of two groups on a vertex's principal-component scores is the
    two-sample Hotelling T^2 of those scores (T^2 = nu V / (1 - V))."""
    c, motion = small
    tests = compare_cycles(motion, c.patients, 20, np.random.default_rng(0),
                           summaries=("trajectory",))  # fmt: skip
    components = cycle_responses(motion).trajectory
    assert tests.components == components.n_components >= 2
    n1, n2 = int(c.patients.sum()), int((~c.patients).sum())
    for v in (0, 40, 120):
        a, b = components.scores[c.patients, v], components.scores[~c.patients, v]
        pooled = ((n1 - 1) * np.cov(a.T) + (n2 - 1) * np.cov(b.T)) / (n1 + n2 - 2)
        d = a.mean(axis=0) - b.mean(axis=0)
        t2 = n1 * n2 / (n1 + n2) * d @ np.linalg.solve(pooled, d)
        assert pillai_to_hotelling(tests.trajectory.statistic[v], n1 + n2 - 2) == (
            pytest.approx(t2, rel=1e-6)
        )


def test_the_number_of_components_follows_the_stated_rule():
    """Curves built on orthonormal temporal patterns with known variances: d is the fewest
    components holding 90 % of the variance, at least 2 and at most 5 (and n - 3); the
    scores recover the curves' projections."""
    rng = np.random.default_rng(4)
    n, n_frames, m = 30, 12, 6
    patterns = np.linalg.qr(rng.normal(size=(n_frames, 6)))[0].T  # orthonormal rows
    z = rng.normal(size=(n, 6))
    z = (z - z.mean(axis=0)) @ np.linalg.inv(np.linalg.cholesky(np.cov(z.T, bias=True))).T
    for shares, expected in (([0.97, 0.03], 2), ([0.6, 0.25, 0.1, 0.05], 3),
                             ([0.2] * 5 + [0.0], 5), ([0.15] * 6, 5)):  # fmt: skip
        sd = np.sqrt(np.pad(shares, (0, 6 - len(shares))))
        curves = np.repeat(((z * sd) @ patterns)[..., None], m, axis=2)  # every vertex alike
        tc = trajectory_components(curves)
        assert tc.n_components == expected
        assert tc.explained == pytest.approx(min(1.0, sum(sorted(shares)[::-1][:expected])
                                                 / sum(shares)), abs=1e-9)  # fmt: skip
    assert trajectory_components(curves, min_components=1, variance=0.1).n_components == 1
    assert trajectory_components(curves[:6]).n_components == 3  # n - 3
    with pytest.raises(ValueError, match="need 4"):
        trajectory_components(curves[:3])


def test_a_delayed_contraction_is_found_by_its_timing_and_trajectory_not_its_peak():
    """A tenth of the cycle of delay, no change of amplitude, through a tracking-like error:
    the time to peak and the trajectory find the planted region, the peak does not; random
    splits of the controls find nothing."""
    delay = MotionAbnormality("delay", transition_height=0.1)
    c = make_two_group_cycles(24, delay, n_frames=12, n_vertices=300, seed=4, check=False)
    motion = _noisy(c, np.random.default_rng(2))
    tests = compare_cycles(motion, c.patients, 400, np.random.default_rng(0),
                           summaries=("peak", "time_to_peak", "trajectory"))  # fmt: skip
    region = c.data.region.affected
    found = {s: tests.detected(s)[region].mean() for s in tests.tests()}
    print(f"delay found: {found}")
    assert found["time_to_peak"] >= 0.8 and found["trajectory"] >= 0.5
    assert found["peak"] <= 0.05
    controls = np.flatnonzero(~c.patients)
    null = CycleMotion(tuple(c.names[i] for i in controls), motion.displacement[controls],
                       motion.atlas, motion.faces)  # fmt: skip
    null_tests = compare_cycles(null, np.arange(len(controls)) % 2 == 0, 400,
                                np.random.default_rng(1),
                                summaries=("time_to_peak", "trajectory"))  # fmt: skip
    assert not any(null_tests.detected(s).any() for s in null_tests.tests())


def test_the_covariates_act_on_the_motion_through_the_cycle():
    """Every subject's frames of a cohort in several groups with covariates start at its
    ED mesh and pass through its ES mesh (its covariates' and its group's effects); each
    group carries its own abnormality."""
    groups = (CohortGroup("controls"), CohortGroup("lad", MotionAbnormality(
        transition_height=0.1)), CohortGroup("late", MotionAbnormality("delay",
        transition_height=0.1)))  # fmt: skip
    data = make_covariate_cohort(3, groups, Covariates(imbalance=1.0, age_effect=0.15),
                                 seed=2, n_vertices=150, outcome_effect=1.0)  # fmt: skip
    cycles = covariate_cycles(data, n_frames=20)
    for i, s in enumerate(data.cohort.subjects):
        np.testing.assert_allclose(cycles.frames[i, 0], s.ed, atol=1e-12)
        np.testing.assert_allclose(cycles.frames[i, 7], s.es, atol=1e-10)  # t = 7 / 20
        group = data.groups[s.name]
        assert cycles.motion_of(i)[1] == next(g.abnormality for g in groups if g.name == group)
    assert list(cycles.patients) == [data.groups[n] != "controls" for n in cycles.names]
    table = data.design_table()
    assert {"time", "event"} <= set(table) and all(t > 0 for t in table["time"])


def _fake_cycle_study(folder, frames_folder, atlas_path) -> list[str]:
    """A cycle study's folder from true frames (the motion without transport), as
    ``symladders cycle-study`` lays it out."""
    atlas, faces = read_mesh(atlas_path)
    folder.mkdir()
    write_mesh(folder / "atlas.vtk", atlas, faces)
    names = []
    for name, paths in read_tracked_frames(frames_folder).items():
        frames = np.stack([read_mesh(p)[0] for p in paths])
        np.savez(folder / f"{name}.npz", transported=atlas + frames - frames[0])
        names.append(name)
    record = {"settings": {"alpha2": [100.0], "deformation": "lddmm"},
              "subjects": dict.fromkeys(names, "computed")}  # fmt: skip
    (folder / "cycle_study.json").write_text(json.dumps(record))
    return names


def test_cli_covariate_cycle_cohort_then_the_model_and_bad_input(tmp_path, capsys):
    """symladders cohort --cycle with groups, covariates and an outcome writes design.csv;
    cycle-analyze tests the model's contrasts (an F over three groups, a covariate's t),
    the segments and the outcome; a design naming a subject the study lacks, subjects with
    different frames and a contrast on an absent column are refused in one line naming
    the file and the culprit."""
    cohort = tmp_path / "cohort"
    assert main(["cohort", "--cycle", "6", "--subjects", "12", "--vertices", "150",
                 "--group", "controls", "--group", "lad=hypokinesia", "--group", "late=delay",
                 "--imbalance", "0.5", "--age-effect", "0.1", "--outcome-effect", "1",
                 "--images", "none", "--landmarks", "-o", str(cohort)]) == 0  # fmt: skip
    printed = capsys.readouterr().out
    assert "late: delay, magnitude 0.1 fraction of the cycle" in printed and "events" in printed
    design = list(csv.DictReader(open(cohort / "design.csv")))
    assert len(design) == 12 and {"group", "age", "sex", "body_size", "time", "event"} <= set(
        design[0]
    )
    study = tmp_path / "study"
    names = _fake_cycle_study(study, cohort / "frames", cohort / "atlas.vtk")
    lm = synthetic_landmarks(read_mesh(cohort / "atlas.vtk")[0])
    aha = tmp_path / "aha.json"
    aha.write_text(json.dumps({"apex": lm.apex.tolist(), "base_centre": lm.base.tolist(),
                               "septal_point": lm.septum.tolist()}))  # fmt: skip
    out = tmp_path / "analysis"
    base = ["cycle-analyze", str(study), "--design", str(cohort / "design.csv"),
            "--model", "group + age + body_size", "--permutations", "50", "--no-progress"]  # fmt: skip
    assert main([*base, "--contrast", "group", "age", "--tfce", "--aha", str(aha),
                 "--outcome", "time,event", "-o", str(out)]) == 0  # fmt: skip
    printed = capsys.readouterr().out
    assert "model 'group + age + body_size', 12 subjects" in printed and "C-index" in printed
    assert "'group': vertices found" in printed and "'age': vertices found" in printed
    rows = list(csv.DictReader(open(out / "cycle_vertices.csv")))
    k = len(read_mesh(cohort / "atlas.vtk")[0])
    assert len(rows) == 2 * k and {r["contrast"] for r in rows} == {"group", "age"}
    assert "peak_effect_mm" in rows[0] and rows[0]["peak_effect_mm"] == ""  # F: no effect
    assert all(0 < float(r["trajectory_tfce_p_fwer"]) <= 1 for r in rows)
    summary = (out / "cycle_summary.md").read_text()
    assert "| `group` | peak | F |" in summary and "| `age` | trajectory | Pillai's V |" in summary
    assert (out / "cycle_segments.csv").is_file() and (out / "outcome.csv").is_file()
    assert {p.name for p in out.glob("*.png")} == {
        "cycle_curves_group.png", "cycle_trajectory_group.png", "cycle_curves_age.png",
        "cycle_trajectory_age.png"}  # fmt: skip
    blocked = [*base, "--contrast", "age", "--blocks", "sex", "--summaries", "peak",
               "--no-figures", "-o", str(tmp_path / "blocks")]  # fmt: skip
    assert main(blocked) == 0 and "'age': vertices found at FWER 5 %: peak " in (
        capsys.readouterr().out
    )
    # bad input: one line naming the file and the culprit
    bad = tmp_path / "bad.csv"
    bad.write_text((cohort / "design.csv").read_text() + "stranger,controls,60,F,1.0,3,1\n")
    assert main([*base, "--contrast", "group", "--design", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and (
        f"design table {bad}, line 14, column 'subject': unknown subject 'stranger', not in the "
        "cycle study" in err
    )
    assert main([*base, "--contrast", "weight"]) == 2
    err = capsys.readouterr().err.strip()
    assert "design.csv: --contrast 'weight': unknown term 'weight'" in err and "\n" not in err
    assert main([*base[:4], "--model", "group + weight", "--contrast", "group"]) == 2
    assert "unknown column 'weight'" in capsys.readouterr().err
    short = np.load(study / f"{names[4]}.npz")["transported"][:-1]
    np.savez(study / f"{names[4]}.npz", transported=short)
    assert main([*base, "--contrast", "group"]) == 2
    err = capsys.readouterr().err.strip()
    assert f"subject '{names[4]}' ({study / (names[4] + '.npz')}) has 5 frames, 11 of the 12 " \
        "subjects have 6" in err  # fmt: skip
    np.savez(study / f"{names[4]}.npz", transported=np.concatenate([short, short[-1:]]))
    groups = tmp_path / "groups.csv"
    groups.write_text("subject,group\n" + "".join(
        f"{r['subject']},{r['group']}\n" for r in design))  # fmt: skip
    two = ["cycle-analyze", str(study), "--groups", str(groups), "--permutations", "20",
           "--no-progress", "--no-figures", "--summaries", "peak", "-o", str(tmp_path / "g")]  # fmt: skip
    assert main([*two, "--compare", "lad", "controls"]) == 0
    captured = capsys.readouterr()
    assert "deprecated; write '--compare lad,controls'" in captured.err
    assert "lad (4) against controls (4)" in captured.out
    assert main([*two, "--compare", "lad,controls"]) == 0 and not capsys.readouterr().err
    assert main([*base, "--contrast", "group", "--compare", "lad,controls"]) == 2
    assert "--compare: only with --groups" in capsys.readouterr().err
    assert main([*two]) == 2
    assert "expected two groups, the table has 3" in capsys.readouterr().err
