"""The documentation builds, and the README's usage example runs."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.docs_pages import PAGES, ROOT


def test_sphinx_builds_api_reference(tmp_path):
    pytest.importorskip("sphinx")
    pytest.importorskip("numpydoc")
    pytest.importorskip("myst_parser")
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "sphinx",
            "-b",
            "html",
            "-q",
            "-W",
            "--keep-going",
            str(ROOT / "docs"),
            str(tmp_path),
        ],  # fmt: skip
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
        "track_cohort",
        "compare_cycles",
        "landmarks_from_labels",
    ):
        assert name in api
    assert "import failed" not in proc.stderr.lower(), proc.stderr[-3000:]
    docs = ROOT / "docs"
    for page in PAGES:
        if docs in page.parents:
            html = page.relative_to(docs).with_suffix(".html")
            assert (tmp_path / html).exists(), html


DOC_PAGES = sorted(p.relative_to(ROOT).as_posix() for p in PAGES)


def python_blocks(path: Path) -> list[str]:
    """The fenced ```python blocks of a Markdown file, in order."""
    return re.findall(r"^```python\n(.*?)^```", path.read_text(), flags=re.S | re.M)


def test_readme_has_a_usage_example():
    assert python_blocks(ROOT / "README.md"), "README has no python example"


@pytest.mark.filterwarnings("error::manifolds.errors.ConvergenceWarning")
@pytest.mark.parametrize("page", DOC_PAGES)
def test_python_snippets_run(page, tmp_path, monkeypatch):
    """Every ```python block of the page runs, in order, in one namespace (from a scratch folder)."""
    blocks = python_blocks(ROOT / page)
    if not blocks:
        pytest.skip(f"{page} has no python snippet")
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": f"snippets_of_{Path(page).stem}"}
    for i, block in enumerate(blocks):
        exec(compile(block, f"{page} (python block {i + 1})", "exec"), namespace)
