"""The study runs with the SVF deformation model: same outputs as LDDMM, CLI flag, hashes."""

import json

import numpy as np
import pytest

from ladders.study.cli import build_parser, main
from ladders.study.cli.cli_types import UsageError
from ladders.study.cohort.synthetic_lv import make_synthetic_cohort
from ladders.study.running import ERROR_NAMES, VARIANTS, StudyConfig, compute_pair, make_space
from manifolds.lddmm import LDDMMLandmarks, SVFLandmarks

from .fake_results import fake_pair, fake_subject

COHORT = make_synthetic_cohort(n_subjects=2, grid=(8, 5), seed=0)


def test_svf_subject_has_the_lddmm_fields_and_finite_values():
    kw = dict(alpha2=(1.0,), sigma=20.0, max_iter=40, fanning_steps=3)
    subject = COHORT.subjects[0]
    args = (COHORT.atlas, COHORT.faces, subject, 1.0)
    a_svf = compute_pair(StudyConfig.build(deformation="svf", **kw), *args)
    a_lddmm = compute_pair(StudyConfig.build(**kw), *args)
    assert a_svf.deformation == "svf" and a_lddmm.deformation == "lddmm"
    # The third transport is named for what it is in each study.
    assert [t.method for t in a_svf.transports] == [
        "pole_ladder_residual", "pole_ladder_no_residual", "svf_conjugation"
    ]  # fmt: skip
    assert a_lddmm.transports[2].method == "fanning"
    assert a_svf.non_finite_fields() == []
    for variant in VARIANTS:
        for name in (*ERROR_NAMES, "ase"):
            assert np.isfinite(a_svf.measure(variant, name)) and a_svf.measure(variant, name) >= 0
    assert np.isfinite(a_svf.transport("svf_conjugation").ase)
    assert a_svf.registration.inverse_consistency >= 0
    # the two models give different registrations of the same pair
    assert a_svf.registration.rkhs_norm != pytest.approx(a_lddmm.registration.rkhs_norm, rel=1e-3)


def test_config_builds_the_chosen_space_and_keeps_lddmm_hashes():
    atlas = COHORT.atlas
    assert isinstance(make_space(StudyConfig(), atlas, 1.0), LDDMMLandmarks)
    assert isinstance(make_space(StudyConfig(deformation="svf"), atlas, 1.0), SVFLandmarks)
    assert StudyConfig().as_dict()["deformation"] == "lddmm"
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


def _fake_results(values: dict[str, float], inverse: float) -> list:
    """Per-subject results whose every error equals ``values[subject]``."""
    out = []
    for name, v in values.items():
        errors = {variant: (v, v, v, v) for variant in VARIANTS}
        ase = {"pole_ladder_residual": v, "pole_ladder_no_residual": v, "fanning": v}
        pair = fake_pair(name, 1.0, errors, ase, (v, 2 * v, inverse, True))
        out.append(fake_subject(name, [pair]))
    return out


def test_comparison_pairs_subjects_by_name_with_known_answers(tmp_path):
    from ladders.study.reporting.deformation_comparison import (
        compare_deformations,
        comparison_csv,
        comparison_markdown,
    )

    lddmm = _fake_results({f"s{i}": 10.0 + i for i in range(6)}, inverse=1.0)
    # SVF lower by i + 1 on subject i; subjects listed in another order; one missing.
    svf = _fake_results({f"s{i}": 10.0 + i - (i + 1) for i in (5, 3, 1, 0, 2)}, inverse=1.0)
    rows = compare_deformations(lddmm, svf, seed=0, n_boot=500)
    row = next(r for r in rows if r.variant == "residual" and r.measure == "involutivity")
    assert row.n == 5 and row.fraction_svf_lower == 1.0
    assert row.median_difference == -3.0  # differences -1, -2, -3, -4, -6
    assert row.mean_lddmm == pytest.approx(np.mean([10, 11, 12, 13, 15]))
    assert row.wilcoxon_p == pytest.approx(0.0625)  # exact two-sided, n = 5, all negative
    inverse = next(r for r in rows if r.measure == "inverse_consistency")
    assert inverse.variant == "registration" and inverse.median_difference == 0.0
    assert inverse.wilcoxon_p == 1.0
    text = comparison_markdown(rows)
    assert "5 subjects" in text and "| 1 | residual | involutivity |" in text
    assert comparison_csv(rows).splitlines()[0].startswith("alpha2,variant,measure,n,")
    from ladders.study.reporting import write_deformation_comparison

    path, written = write_deformation_comparison(lddmm, svf, tmp_path / "both")
    assert path.read_text() == written and "| 1 | residual | involutivity |" in written
    assert (tmp_path / "both" / "comparison.csv").read_text() == comparison_csv(
        compare_deformations(lddmm, svf)
    )


def test_cli_runs_both_deformations_and_compares_them(tmp_path, capsys):
    argv = ["study", "--subjects", "2", "--vertices", "30", "--alpha2", "1", "--max-iter", "20"]
    argv += ["--deformation", "both", "-o", str(tmp_path), "--jobs", "1", "--no-progress"]
    argv += ["--no-meshes", "--n-steps", "4", "--fanning-steps", "2"]
    assert main(argv) == 0
    for model in ("lddmm", "svf"):
        assert (tmp_path / model / "summary.md").exists()
        assert (tmp_path / model / "results.csv").exists()
    text = (tmp_path / "comparison.md").read_text()
    assert "LDDMM against SVF, 2 subjects" in text
    rows = (tmp_path / "comparison.csv").read_text().splitlines()
    assert len(rows) == 1 + 2 * 5 + 3  # one alpha^2: 2 variants x 5 measures + 3 shared
    assert main([*argv, "--optimize-control-points"]) == 2
    assert (
        "--optimize-control-points works with --deformation lddmm only" in capsys.readouterr().err
    )
