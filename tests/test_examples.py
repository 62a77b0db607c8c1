"""Every example script runs and writes its figure."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.parametrize("name", ["ladders_on_sphere", "svf_pole_ladder"])
def test_example_runs(name, tmp_path):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = module.main(["--output", str(tmp_path / f"{name}.png")])
    assert out.read_bytes()[:4] == b"\x89PNG"


def _load(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_add_a_space_example(tmp_path):
    """Both routes pass the contract, their pole ladder is second order against the exact
    transport, and they give the same Frechet mean and tangent PCA."""
    results = _load("add_a_space").main(["--output", str(tmp_path / "space.png")])
    assert results["figure"].read_bytes()[:4] == b"\x89PNG"
    for route in ("subclass", "metric field"):
        out = results[route]
        assert not [k for k, v in out["contract"].items() if v.startswith("failed")]
        assert sum(v == "passed" for v in out["contract"].values()) >= 14
        assert -2.2 < out["curve"].slope < -1.8  # measured -2.02
        assert out["mean"].converged
        assert out["pca"].variances[0] > out["pca"].variances[1] > 0
    assert results["mean_gap"] < 1e-8
    np.testing.assert_allclose(results["subclass"]["pca"].variances,
                               results["metric field"]["pca"].variances, rtol=1e-6)  # fmt: skip


def test_point_distribution_model_example(tmp_path):
    """A third model registered from a file and run by `symladders study` and `analyze`
    beside LDDMM and SVF: its transport is the identity, its rows are in every table."""
    from ladders.study.deformations import unregister_deformation
    from ladders.study.population.transported_motion import load_study_results

    try:
        out = _load("point_distribution_model").main(
            ["--output", str(tmp_path), "--subjects", "6", "--permutations", "100"]
        )
    finally:
        unregister_deformation("pdm")
    study = out / "study"
    summary = (study / "pdm" / "summary.md").read_text()
    assert "Not run: fanning scheme (PointDistributionModel: no fanning scheme" in summary
    assert "| Area strain error (fanning scheme)" not in summary
    comparison = (study / "comparison.csv").read_text().splitlines()
    assert len(comparison) == 1 + 2 * 13  # SVF and the PDM against LDDMM, 13 rows each
    assert {line.split(",")[5] for line in comparison[1:]} == {"svf", "pdm"}
    assert "LDDMM against PDM, 6 subjects" in (study / "comparison.md").read_text()
    (pdm,) = load_study_results(study / "pdm")
    assert len(pdm.subjects) == 6 and not pdm.failures
    for r in pdm.subjects:
        pair = r.pairs[0]
        motion = np.reshape(pair.displacement_subject, (-1, 3))
        for t in pair.transports:  # the pole ladder of a flat space carries S' - S as it is
            np.testing.assert_allclose(t.displacement_array(), motion, rtol=0, atol=1e-10)
        assert max(e.involutivity for e in pair.errors) < 1e-10
    tests = (out / "analysis" / "tests.csv").read_text()
    for motion in ("lddmm/fanning", "svf/svf_conjugation", "pdm/pole_ladder_residual"):
        assert f"{motion}/alpha2=1" in tests
