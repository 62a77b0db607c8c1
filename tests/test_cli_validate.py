"""``symladders validate`` end to end (quick setting)."""

import json

import pytest

from ladders.study.cli import main


def test_validate_writes_outputs_and_numbers_hold(tmp_path, capsys):
    assert main(["validate", "--quick", "--output", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "Convergence orders" in out
    for name in ("validation.json", "validation.md", "convergence.png"):
        assert (tmp_path / name).stat().st_size > 0
    assert (tmp_path / "convergence.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    report = json.loads((tmp_path / "validation.json").read_text())
    for row in report["exactness"].values():
        assert row["pole_ladder"] <= 1e-12
        assert row["transvectivity"] <= 1e-12
    slopes = {c["label"]: c["slope"] for c in report["curves"]}
    assert slopes["Schild a=1 on S^2"] == pytest.approx(-1.0, abs=0.15)
    assert slopes["Schild a=2 on S^2"] == pytest.approx(-2.0, abs=0.15)
    assert slopes["Schild a=2 on SPD(3)"] == pytest.approx(-2.0, abs=0.15)
    assert slopes["pole a=1 on warped"] <= -1.8
    trans = report["transvectivity"]
    assert trans["slope"] == pytest.approx(4.0, abs=0.3)
    assert trans["nabla_r_rel_error"][-1] < 0.1
    assert report["half_plane"]["max_dist_error"] < 1e-8


def test_help_lists_subcommands(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "validate" in out and "study" in out
