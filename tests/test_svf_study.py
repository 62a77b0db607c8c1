"""The study runs with the SVF deformation model: same outputs as LDDMM, CLI flag, hashes."""

import json

import numpy as np
import pytest

from ladders.study.cli import build_parser, main
from ladders.study.cli_types import UsageError
from ladders.study.pipeline import ERROR_NAMES, VARIANTS, StudyConfig, make_space, run_subject
from ladders.study.synthetic_lv import make_synthetic_cohort
from manifolds.lddmm import LDDMMLandmarks, SVFLandmarks

COHORT = make_synthetic_cohort(n_subjects=2, grid=(8, 5), seed=0)


def test_svf_subject_has_the_lddmm_fields_and_finite_values():
    kw = dict(alpha2=(1.0,), sigma=20.0, max_iter=40, fanning_steps=3)
    subject = COHORT.subjects[0]
    svf = run_subject(StudyConfig(deformation="svf", **kw), COHORT.atlas, COHORT.faces, subject)
    lddmm = run_subject(StudyConfig(**kw), COHORT.atlas, COHORT.faces, subject)
    a_svf, a_lddmm = svf["alpha2"]["1.0"], lddmm["alpha2"]["1.0"]
    assert set(a_svf) == set(a_lddmm)
    for variant in VARIANTS:
        for name in (*ERROR_NAMES, "ase"):
            assert np.isfinite(a_svf[variant][name]) and a_svf[variant][name] >= 0
    assert np.isfinite(a_svf["fanning"]["ase"]) and a_svf["inverse_consistency"] >= 0
    # the two models give different registrations of the same pair
    assert a_svf["rkhs_norm"] != pytest.approx(a_lddmm["rkhs_norm"], rel=1e-3)


def test_config_builds_the_chosen_space_and_keeps_lddmm_hashes():
    atlas = COHORT.atlas
    assert isinstance(make_space(StudyConfig(), atlas, 1.0), LDDMMLandmarks)
    assert isinstance(make_space(StudyConfig(deformation="svf"), atlas, 1.0), SVFLandmarks)
    assert "deformation" not in StudyConfig().as_dict()
    assert StudyConfig(deformation="svf").as_dict()["deformation"] == "svf"
    with pytest.raises(ValueError, match="deformation"):
        make_space(StudyConfig(deformation="lddmm2"), atlas, 1.0)


def test_cli_deformation_flag(tmp_path):
    args = build_parser().parse_args(["study", "--deformation", "svf"])
    assert args.deformation == "svf"
    with pytest.raises(UsageError, match="--deformation"):
        build_parser().parse_args(["study", "--deformation", "stationary"])
    out = tmp_path / "svf"
    argv = ["study", "--subjects", "2", "--vertices", "40", "--alpha2", "1", "--max-iter", "20"]
    argv += ["--deformation", "svf", "--output", str(out), "--jobs", "1", "--no-progress"]
    assert main(argv) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["config"]["deformation"] == "svf"
