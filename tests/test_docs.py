"""The documentation builds, and the README's usage example runs."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_sphinx_builds_api_reference(tmp_path):
    pytest.importorskip("sphinx")
    pytest.importorskip("numpydoc")
    pytest.importorskip("myst_parser")
    proc = subprocess.run(
        [sys.executable, "-m", "sphinx", "-b", "html", "-q", str(ROOT / "docs"), str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    api = (tmp_path / "api.html").read_text()
    for name in (
        "pole_ladder",
        "schild_ladder",
        "symmetry_errors",
        "LDDMMLandmarks",
        "Hypersphere",
    ):
        assert name in api
    assert "import failed" not in proc.stderr.lower(), proc.stderr[-3000:]
    for page in ("index", "add_your_own_space", "lddmm", "svf", "study", "cohort", "validation"):
        assert (tmp_path / f"{page}.html").exists(), page


def test_readme_usage_example_runs():
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "README has no python example"
    namespace: dict = {}
    exec(compile(blocks[0], "README.md", "exec"), namespace)
