"""The geomstats adapter stays optional: ``manifolds`` never imports it or geomstats."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run(code: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120
    )


def test_manifolds_and_ladders_do_not_import_geomstats():
    proc = run(
        "import sys, manifolds, ladders, manifolds.interop\n"
        "assert 'geomstats' not in sys.modules\n"
        "assert 'manifolds.interop.geomstats' not in sys.modules\n"
    )
    assert proc.returncode == 0, proc.stderr


def test_missing_geomstats_names_the_extra():
    proc = run(
        "import sys\n"
        "sys.modules['geomstats'] = None  # as if geomstats were not installed\n"
        "try:\n"
        "    from manifolds.interop import from_geomstats\n"
        "except ModuleNotFoundError as exc:\n"
        "    print(exc)\n"
        "else:\n"
        "    raise SystemExit('no ImportError')\n"
    )
    assert proc.returncode == 0, proc.stderr
    assert "symladders[geomstats]" in proc.stdout
    assert "geomstats" in proc.stdout


def test_other_geomstats_backends_are_refused():
    proc = run(
        "import os\n"
        "os.environ['GEOMSTATS_BACKEND'] = 'pytorch'\n"
        "try:\n"
        "    import manifolds.interop.geomstats\n"
        "except ImportError as exc:\n"
        "    print(exc)\n"
    )
    assert proc.returncode == 0, proc.stderr
    assert "GEOMSTATS_BACKEND" in proc.stdout and "numpy" in proc.stdout
