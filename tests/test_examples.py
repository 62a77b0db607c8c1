"""Every example script runs and writes its figure."""

import importlib.util
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.parametrize("name", ["ladders_on_sphere", "svf_pole_ladder"])
def test_example_runs(name, tmp_path):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = module.main(["--output", str(tmp_path / f"{name}.png")])
    assert out.read_bytes()[:4] == b"\x89PNG"
