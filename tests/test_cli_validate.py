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


def test_validation_figure_has_titles_explains_a_and_no_overlapping_ticks():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ladders.convergence import ConvergenceCurve
    from ladders.study.analytic_validation import plot_convergence

    ns = np.array([1, 2, 4, 8, 16, 32, 64])
    curves = [
        ConvergenceCurve(f"Schild a={a} on S^2", ns, 0.3 * ns.astype(float) ** -a) for a in (1, 2)
    ]
    h = [0.2, 0.1, 0.05, 0.025]
    trans = {"h": h, "errors": [x**4 for x in h], "slope": 4.0}
    fig = plot_convergence(curves, trans)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    left, right = fig.axes[:2]
    assert left.get_title().startswith("(a)") and right.get_title().startswith("(b)")
    assert "scaling exponent" in left.get_legend().get_title().get_text()
    for ax in (left, right):
        labels = [t for t in ax.get_xticklabels() if t.get_visible() and t.get_text()]
        assert len(labels) >= 3
        boxes = sorted((t.get_window_extent(renderer) for t in labels), key=lambda b: b.x0)
        for a, b in zip(boxes, boxes[1:]):
            assert a.x1 <= b.x0, (ax.get_title(), [t.get_text() for t in labels])
    assert [t.get_text() for t in right.get_xticklabels()] == ["0.025", "0.05", "0.1", "0.2"]
    plt.close(fig)
