"""The layering is enforced: import-linter contracts, no import cycle, one kernel backend rule."""

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from manifolds.data_terms import VarifoldDistance
from manifolds.errors import ManifoldError
from manifolds.kernels import AUTO_ORDER, backends, register_backend, resolve_backend
from manifolds.lddmm import GaussianKernel, RegistrationSettings

ROOT = Path(__file__).resolve().parents[1]


def test_import_linter_contracts_are_kept():
    grimp = pytest.importorskip("grimp")  # installed with import-linter (the test extra)
    assert grimp is not None
    exe = shutil.which("lint-imports") or str(Path(sys.executable).parent / "lint-imports")
    proc = subprocess.run([exe, "--config", str(ROOT / "pyproject.toml")], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)  # fmt: skip
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    assert "0 broken" in proc.stdout


def test_no_import_cycle_between_the_modules_of_any_package():
    grimp = pytest.importorskip("grimp")
    graph = grimp.build_graph("manifolds", "ladders")
    packages = sorted(m for m in graph.modules if graph.find_children(m))
    cycles = {p: graph.nominate_cycle_breakers(p) for p in packages}
    assert not {p: c for p, c in cycles.items() if c}, "import cycles (imports to break them)"


def test_landmark_and_surface_kernels_resolve_auto_the_same_way():
    v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    f = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])
    landmarks = GaussianKernel(1.0, backend="auto").backend
    surfaces = VarifoldDistance(v, f, f, 1.0, backend="auto").backend
    settings = RegistrationSettings(sigma=1.0).resolved_backend()
    assert landmarks == surfaces == settings == resolve_backend("auto")


def test_a_registered_backend_takes_part_in_the_auto_rule():
    with pytest.raises(ManifoldError, match="expected 'auto' or one of"):
        resolve_backend("cuda")
    register_backend("never_here", lambda: False, auto_rank=0)
    try:
        assert resolve_backend("auto") != "never_here"  # not available: auto skips it
        with pytest.raises(ManifoldError, match="cannot run here"):
            resolve_backend("never_here")
    finally:
        AUTO_ORDER.remove("never_here")
        backends._REGISTRY.pop("never_here")
