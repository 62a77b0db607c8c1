"""The cohort in several groups with covariates: design table, truth file and planted effects."""

import json
import re
from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

from ladders.statistics import design_matrix, read_design
from ladders.study.cohort.cohort import Cohort
from ladders.study.cohort.planted_effect import MotionAbnormality, PlantedRegion
from ladders.study.cohort.synthetic_lv import grid_shape, lv_grid, lv_shapes, make_synthetic_cohort
from ladders.study.errors import CohortError
from ladders.study.population import (
    DESIGN_FILE,
    AnatomyShift,
    Covariates,
    make_covariate_cohort,
    write_covariate_cohort,
)
from ladders.study.volume import enclosed_volume

K = 241  # vertices per mesh: small and fast
FOUR = (
    ("controls", None),
    ("lad", MotionAbnormality("hypokinesia", (7, 8, 13, 14))),
    ("rca", MotionAbnormality("radial", (3, 4, 9, 10), 0.6)),
    ("lcx", MotionAbnormality("longitudinal", (5, 6, 11, 12))),
)
SHIFT = AnatomyShift(scale=1.15, sphericity=1.1)


def volumes(data, group=None):
    """ED volumes and ES/ED volume ratios of a group's subjects (all subjects without one)."""
    keep = [group is None or data.groups[s.name] == group for s in data.cohort.subjects]
    ed = enclosed_volume(data.cohort.ed[keep], data.cohort.faces)
    return ed, enclosed_volume(data.cohort.es[keep], data.cohort.faces) / ed


def test_design_table_and_truth_file_of_four_groups(tmp_path):
    data = make_covariate_cohort(4, FOUR, Covariates(imbalance=0.5), seed=3, n_vertices=K)
    assert isinstance(data.cohort, Cohort) and len(data.cohort) == 16
    folder = write_covariate_cohort(data, tmp_path / "cohort")
    table = read_design(folder / DESIGN_FILE)
    assert list(table) == ["subject", "group", "age", "sex", "body_size"]
    assert table["subject"] == data.cohort.names
    for i, name in enumerate(table["subject"]):
        assert float(table["age"][i]) == data.covariates[name]["age"]
        assert float(table["body_size"][i]) == data.covariates[name]["body_size"]
        assert table["sex"][i] == data.covariates[name]["sex"]
    design = design_matrix(table, "group + age + sex + body_size")
    assert design.shape == (16, 7)  # intercept, 3 groups, age, sex, body size
    assert np.linalg.matrix_rank(design.matrix) == 7

    truth = json.loads((folder / "planted_region.json").read_text())
    assert list(truth["groups"]) == ["controls", "lad", "rca", "lcx"]
    assert truth["groups"]["controls"]["region"] is None
    affected = []
    for name, abnormality in FOUR[1:]:
        record = truth["groups"][name]
        region = PlantedRegion.from_dict(record["region"])
        assert region.abnormality == abnormality and record["n_subjects"] == 4
        affected.append(frozenset(np.flatnonzero(region.affected)))
    assert len(set(affected)) == 3 and all(affected)
    assert truth["region_group"] == "lad" and truth["region"] == truth["groups"]["lad"]["region"]
    assert truth["covariates"]["imbalance"] == 0.5
    assert truth["covariates"]["age"]["factor_per_year"] == pytest.approx(-0.1 / 10)
    assert truth["covariates"]["other_group_means"]["age"] == pytest.approx(70.0)


def test_imbalance_shifts_the_covariates_by_the_stated_amount():
    for imbalance in (0.0, 1.0):
        model = Covariates(imbalance=imbalance)
        rng = np.random.default_rng(5)
        ref, other = model.draw(4000, False, rng), model.draw(4000, True, rng)
        for key, sd in (("age", model.age_sd), ("body_size", model.body_size_sd)):
            gap = other[key].mean() - ref[key].mean()
            assert abs(gap - imbalance * model.shift * sd) < 4 * sd * np.sqrt(2 / 4000)
        males = np.mean(np.array(other["sex"]) == "M") - np.mean(np.array(ref["sex"]) == "M")
        assert males == pytest.approx(imbalance * model.sex_shift, abs=1e-3)
    data = make_covariate_cohort(30, covariates=Covariates(imbalance=1.0), n_vertices=K)
    ages = {g: [data.covariates[s]["age"] for s in data.groups if data.groups[s] == g]
            for g in ("controls", "patients")}  # fmt: skip
    gap = np.mean(ages["patients"]) - np.mean(ages["controls"])
    assert abs(gap - 20.0) < 4 * 10 * (2 / 30) ** 0.5


def test_age_reduces_the_contraction_and_body_size_scales_the_volumes():
    model = Covariates(age_effect=0.15, sex_effect=0.1)
    groups = (("controls", None), ("big", SHIFT))
    data = make_covariate_cohort(12, groups, model, seed=2, n_vertices=K)
    base = make_synthetic_cohort(24, n_vertices=K, seed=2)
    ed, ratio = volumes(data)
    ed0 = enclosed_volume(base.ed, base.faces)
    age = np.array([data.covariates[s]["age"] for s in data.cohort.names])
    sex = np.array([data.covariates[s]["sex"] for s in data.cohort.names])
    size = np.array([data.covariates[s]["body_size"] for s in data.cohort.names])
    assert stats.spearmanr(age, ratio).statistic > 0.5  # older: less ejected
    k = (1 - 0.15 * (age - 60) / 10) * (1 - 0.1 * (sex == "M"))
    for s, s0, factor in zip(data.cohort.subjects, base.subjects, k):
        p, p0 = s.parameters, s0.parameters
        assert p.radial_contraction == pytest.approx(p0.radial_contraction * factor, rel=1e-12)
        assert p.longitudinal_shortening == pytest.approx(p0.longitudinal_shortening * factor)
        assert p.apex_rotation == p0.apex_rotation
    anatomy = np.where(np.arange(24) < 12, 1.0, 1.15**3 * 1.1**2)
    np.testing.assert_allclose(ed / ed0, size**3 * anatomy, rtol=1e-9)


def test_anatomy_groups_keep_the_motion_relative_to_their_anatomy():
    groups = (("controls", None), ("dilated", SHIFT), ("dilated_lad", SHIFT, MotionAbnormality()))
    data = make_covariate_cohort(25, groups, Covariates(), seed=4, n_vertices=K)
    assert data.regions["dilated"] is None and data.regions["dilated_lad"] is not None
    ed_c, ratio_c = volumes(data, "controls")
    ed_d, ratio_d = volumes(data, "dilated")
    _, ratio_dl = volumes(data, "dilated_lad")
    assert np.mean(ed_d) > 1.4 * np.mean(ed_c)  # the anatomy differs
    assert stats.ttest_ind(ratio_c, ratio_d).pvalue > 0.01  # the relative motion does not
    assert np.mean(ratio_dl) > np.mean(ratio_d) + 0.01  # the planted hypokinesia
    theta, phi, faces = lv_grid(*grid_shape(K))
    for s in data.cohort.subjects[25:30]:  # exact: the shift leaves the ES/ED ratio unchanged
        p = s.parameters
        undo = replace(p, radius=p.radius / (1.15 * 1.1), long_axis=p.long_axis / 1.15)
        ed, es = lv_shapes(undo, theta, phi)
        assert enclosed_volume(s.es, faces) / enclosed_volume(s.ed, faces) == pytest.approx(
            enclosed_volume(es, faces) / enclosed_volume(ed, faces), rel=1e-10
        )


def test_the_same_seed_gives_the_same_cohort():
    model = Covariates(imbalance=0.3, sex_effect=0.05)
    a, b = (make_covariate_cohort(3, FOUR, model, seed=7, n_vertices=K) for _ in range(2))
    c = make_covariate_cohort(3, FOUR, model, seed=8, n_vertices=K)
    assert a.covariates == b.covariates and a.groups == b.groups
    np.testing.assert_array_equal(a.cohort.es, b.cohort.es)
    assert a.covariates != c.covariates
    assert not np.allclose(a.cohort.ed, c.cohort.ed)


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: Covariates(imbalance=1.5), "imbalance"),
        (lambda: Covariates(imbalance=-0.1), "imbalance"),
        (lambda: Covariates(age_effect=0.5), "age_effect"),
        (lambda: make_covariate_cohort(2, n_vertices=K), "n_per_group"),
        (lambda: make_covariate_cohort((5, 2), n_vertices=K), "n_per_group"),
        (lambda: make_covariate_cohort(3, (("a", None), ("a", None))), "duplicate group name"),
        (lambda: make_covariate_cohort(3, (("a", None), ("b", 1.0))), "groups"),
        (lambda: AnatomyShift(scale=0.0), "scale"),
        (lambda: make_covariate_cohort(3, seed=-1), "seed"),
    ],
)
def test_bad_input_is_refused_naming_the_argument(call, match):
    with pytest.raises(CohortError, match=match):
        call()


def test_the_command_line_writes_the_same_cohort_as_python(tmp_path, capsys):
    """``symladders cohort --group ... --anatomy ... --imbalance``: make_covariate_cohort's cohort."""
    from ladders.study.cli import main
    from ladders.study.meshes import read_mesh

    argv = ["cohort", "-o", str(tmp_path / "cli"), "--subjects", "16", "--vertices", str(K),
            "--seed", "3", "--imbalance", "0.5", "--group", "controls",
            "--group", "lad=hypokinesia@7,8,13,14", "--group", "rca=radial@3,4,9,10@0.6",
            "--group", "lcx=longitudinal@5,6,11,12", "--anatomy", "lcx=scale:1.15,sphericity:1.1"]  # fmt: skip
    assert main(argv) == 0
    groups = (*FOUR[:3], ("lcx", FOUR[3][1], SHIFT))
    data = make_covariate_cohort(4, groups, Covariates(imbalance=0.5), seed=3, n_vertices=K)
    folder = tmp_path / "cli"
    assert read_design(folder / DESIGN_FILE) == read_design(
        write_covariate_cohort(data, tmp_path / "py") / DESIGN_FILE
    )
    last = data.cohort.subjects[-1]
    np.testing.assert_allclose(read_mesh(folder / f"{last.name}_es.vtk")[0], last.es, atol=1e-5)
    truth = json.loads((folder / "planted_region.json").read_text())
    assert truth["groups"]["lcx"]["anatomy"]["scale"] == 1.15
    assert "lcx: longitudinal" in capsys.readouterr().out
    # without any group option, the two-group cohort and no design table, as before
    assert (
        main(["cohort", "-o", str(tmp_path / "two"), "--subjects", "6", "--vertices", str(K)]) == 0
    )
    assert not (tmp_path / "two" / DESIGN_FILE).exists()
    assert main(["cohort", "-o", str(tmp_path / "d"), "--subjects", "6", "--vertices", str(K),
                 "--design"]) == 0  # fmt: skip
    assert read_design(tmp_path / "d" / DESIGN_FILE)["group"] == ["controls"] * 3 + ["patients"] * 3


@pytest.mark.parametrize("extra, message", [
    (["--anatomy", "nobody=scale:1.1"], "--anatomy nobody: no such group"),
    (["--anatomy", "patients=scale:9"], "AnatomyShift.scale"),
    (["--anatomy", "patients=size:1.1"], "keys scale, sphericity, bulge"),
    (["--group", "a=twirl"], "KIND one of hypokinesia"),
    (["--group", "a", "--group", "a"], "duplicate group name 'a'"),
    (["--imbalance", "2"], "expected a fraction in \\[0, 1\\]"),
])  # fmt: skip
def test_the_command_line_refuses_bad_groups_naming_them(tmp_path, capsys, extra, message):
    from ladders.study.cli import main

    assert main(["cohort", "-o", str(tmp_path / "c"), "--subjects", "6", "--vertices", str(K),
                 *extra]) == 2  # fmt: skip
    assert re.search(message, capsys.readouterr().err)
