"""Valve planes estimated from label series, against the true planes of two ground truths.

The analytic ventricle (:class:`~ladders.study.cohort.analytic_ventricle.AnalyticVentricle`)
and a subject of the synthetic model are rendered on 8 mm short-axis slices; the true plane
of every frame is the plane of the moved rim. On such slices the top of a frame's cavity
bounds its base within a slice; the estimate must place every frame's plane within 1 mm
of the truth (an eighth of a slice) where the base is level with the slices, and within
0.5 mm where it is tilted against them (the columns then pin it), far closer than the
middle of the slice.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from ladders.study.cohort import cycle_fraction, make_synthetic_cohort, motion_forward
from ladders.study.cohort.analytic_ventricle import AnalyticVentricle
from ladders.study.imaging import (
    ImageError,
    LabelImage,
    planes_by_image,
    read_plane_table,
    render_labels,
    short_axis_affine,
    write_series,
)
from ladders.study.meshes import read_mesh, write_mesh
from ladders.study.population import cycle_grid
from ladders.study.tracking import (
    PLANES_FILE,
    TrackingSettings,
    estimate_base_planes,
    rim_plane,
    thick_sliced,
    track_cohort,
)

from .cli_runner import run_cli

SLICE, PIXEL = 8.0, 2.0  # mm
#: Largest height error of an estimated plane (mm): base level with the slices, tilted.
LEVEL_TOL, TILTED_TOL = 1.0, 0.5


def _series(av: AnalyticVentricle, times, in_plane=PIXEL, thickness=SLICE):
    v, f = av.mesh(12, 24)
    affine, shape = cycle_grid(v, in_plane, thickness)
    frames = [LabelImage(av.labels(affine, shape, t).astype(np.int64), affine, Path("av"), k)
              for k, t in enumerate(times)]  # fmt: skip
    truth = np.array([rim_plane(av.motion(v, t), f) for t in times])
    return v, f, frames, truth, affine


def _heights(planes, normal):
    return np.asarray(planes)[:, :3] @ normal


def test_the_rim_plane_of_the_analytic_mesh_is_its_valve_plane():
    av = AnalyticVentricle()
    v, f = av.mesh(12, 24)
    plane = rim_plane(v, f)
    np.testing.assert_allclose(plane[3:], av.plane_normal, atol=1e-12)
    assert abs((plane[:3] - [0.0, 0.0, av.length]) @ av.plane_normal) < 1e-9
    closed = np.r_[f, [[1, 2, 3]]]  # still open: a closed surface has no rim
    assert len(rim_plane(v, closed)) == 6
    with pytest.raises(ValueError, match="rim_plane: expected an open surface"):
        rim_plane(v[:4], np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]]))


@pytest.mark.parametrize("tilt, tolerance", [(0.0, LEVEL_TOL), (12.0, TILTED_TOL)])
def test_estimated_planes_follow_the_analytic_base(tilt, tolerance):
    av = AnalyticVentricle(tilt=tilt)
    v, f, frames, truth, _ = _series(av, av.times(9))
    est = estimate_base_planes(v, f, frames, 1)
    normal = truth[0, 3:]
    error = est.heights - _heights(truth, normal)
    middle = est.bounds.mean(axis=1) - _heights(truth, normal)
    print(f"tilt {tilt}: error {error.round(2)}; middle of the slice {middle.round(2)}")
    assert np.abs(error).max() < tolerance
    assert ((est.heights >= est.bounds[:, 0]) & (est.heights <= est.bounds[:, 1])).all()
    np.testing.assert_allclose(est.planes[:, 3:], np.tile(normal, (9, 1)), atol=1e-12)
    if tilt == 0.0:  # a whole slice of room: the profile places the plane in it
        assert est.consistent and est.lag == 0.0
        assert est.descent == pytest.approx(np.ptp(_heights(truth, normal)), abs=tolerance)
        assert np.abs(error).mean() < 0.5 * np.abs(middle).mean()


def test_estimated_planes_follow_the_synthetic_base():
    cohort = make_synthetic_cohort(1, n_vertices=241)
    s = cohort.subjects[0]
    low = s.ed.min(0) - 15.0
    affine = short_axis_affine(low, PIXEL, SLICE)
    shape = tuple(int(n) for n in np.ceil((s.ed.max(0) + 8.0 - low) / [PIXEL, PIXEL, SLICE]))
    fractions = [float(cycle_fraction(t / 9)) for t in range(9)]
    frames = [LabelImage(render_labels(s.parameters, affine, shape, x).astype(np.int64), affine,
                         Path("s"), t) for t, x in enumerate(fractions)]  # fmt: skip
    truth = np.array([rim_plane(motion_forward(s.parameters, s.ed, x), cohort.faces)
                      for x in fractions])  # fmt: skip
    est = estimate_base_planes(s.ed, cohort.faces, frames, 1)
    error = est.heights - _heights(truth, truth[0, 3:])
    print(f"synthetic subject: error {error.round(2)}")
    assert np.abs(error).max() < LEVEL_TOL


def test_a_descent_that_lags_the_contraction_is_found():
    """The base descends a tenth of the cycle (1.2 frames of 12) after the contraction: the
    profile without the lag cannot agree with every frame; with it, it does."""
    av = AnalyticVentricle(tilt=0.0, delay=0.1)
    v, f, frames, truth, _ = _series(av, av.times(12))
    est = estimate_base_planes(v, f, frames, 1)
    error = est.heights - _heights(truth, truth[0, 3:])
    middle = est.bounds.mean(axis=1) - _heights(truth, truth[0, 3:])
    print(f"lagging descent: lag {est.lag} frames, error {error.round(2)}, middle "
          f"{middle.round(2)}")  # fmt: skip
    assert est.consistent and est.lag == pytest.approx(0.1 * 12, abs=0.5)
    assert ((est.heights >= est.bounds[:, 0]) & (est.heights <= est.bounds[:, 1])).all()
    assert np.abs(error).mean() < 0.5 * np.abs(middle).mean()


def test_thick_slices_and_bad_input():
    assert thick_sliced(short_axis_affine(np.zeros(3), 1.5, 8.0))
    assert thick_sliced(short_axis_affine(np.zeros(3), 1.5, 3.0))
    assert not thick_sliced(short_axis_affine(np.zeros(3), 1.5, 2.9))
    assert not thick_sliced(short_axis_affine(np.zeros(3), 1.5, 1.5, tilt_deg=20.0))
    av = AnalyticVentricle()
    v, f, frames, _, _ = _series(av, av.times(3))
    empty = dataclasses.replace(frames[2], labels=np.zeros_like(frames[2].labels))
    with pytest.raises(ImageError, match="av frame 2: label 1 is absent"):
        estimate_base_planes(v, f, [*frames[:2], empty], 1)
    with pytest.raises(ValueError, match="frames: no frame"):
        estimate_base_planes(v, f, [], 1)


@pytest.fixture(scope="module")
def tracked(tmp_path_factory):
    """The analytic ventricle's first frames as a thick-sliced and an isotropic series,
    tracked with the defaults (and the isotropic one with the rule ``auto``)."""
    root = tmp_path_factory.mktemp("planes")
    av = AnalyticVentricle()
    times = [0.0, 0.1, 0.2, 0.3]
    out = {}
    for name, thickness, rule in (("thick", SLICE, "always"), ("iso", PIXEL, "always"),
                                  ("iso_auto", PIXEL, "auto")):  # fmt: skip
        v, f, frames, truth, affine = _series(av, times, thickness=thickness)
        meshes, images = root / name / "meshes", root / name / "images"
        meshes.mkdir(parents=True)
        write_mesh(meshes / "av_ed.vtk", v, f)
        write_series(images / "av.nii.gz", [x.labels for x in frames], affine)
        settings = TrackingSettings(estimate_planes=rule)
        assert (rule == "always") == (settings == TrackingSettings())  # the default
        outcome = track_cohort(meshes, images, root / name / "out", 1, settings,
                               jobs=1, progress=False)  # fmt: skip
        out[name] = (meshes, images, root / name / "out", outcome, truth)
    return out


def test_the_defaults_estimate_the_planes_of_a_thick_sliced_series(tracked):
    meshes, images, out, outcome, truth = tracked["thick"]
    assert outcome.failed == [] and outcome.planes_file == out / PLANES_FILE
    record = json.loads((out / "av.json").read_text())
    assert record["base_anchors"] is True and record["cut_planes"] is None
    estimated = np.array(record["estimated_planes"]["planes"])
    normal = truth[0, 3:]
    assert np.abs(_heights(estimated, normal) - _heights(truth, normal)).max() < TILTED_TOL
    table = planes_by_image(read_plane_table(outcome.planes_file))  # as --cut-planes reads it
    np.testing.assert_allclose([table["av"][str(t)] for t in range(4)], estimated, atol=1e-6)
    # given back as cut planes, they track the same way
    again = track_cohort(meshes, images, out.parent / "again", 1, TrackingSettings(),
                         cut_planes=table, jobs=1, progress=False)  # fmt: skip
    assert again.failed == [] and again.planes_file is None
    for t in range(4):
        first = read_mesh(out / "av" / f"frame_0{t}.vtk")[0]
        second = read_mesh(out.parent / "again" / "av" / f"frame_0{t}.vtk")[0]
        np.testing.assert_allclose(first, second, atol=1e-4)


def test_the_defaults_estimate_the_planes_of_an_isotropic_series_too(tracked):
    _, _, out, outcome, truth = tracked["iso"]
    assert outcome.failed == [] and outcome.planes_file == out / PLANES_FILE
    record = json.loads((out / "av.json").read_text())
    estimated = np.array(record["estimated_planes"]["planes"])
    normal = truth[0, 3:]
    assert np.abs(_heights(estimated, normal) - _heights(truth, normal)).max() < TILTED_TOL


def test_the_rule_auto_leaves_an_isotropic_series_without_estimated_planes(tracked):
    _, _, out, outcome, _ = tracked["iso_auto"]
    assert outcome.failed == [] and outcome.planes_file is None
    assert not (out / PLANES_FILE).exists()
    record = json.loads((out / "av.json").read_text())
    assert "estimated_planes" not in record and record["base_anchors"] is False


def test_the_command_estimates_by_default_and_is_told_not_to(tracked, tmp_path):
    meshes, images, _, _, _ = tracked["thick"]
    argv = ("track", meshes, images, "--label", 1, "--jobs", 1, "--no-progress", "-o")
    status, stdout, stderr = run_cli(*argv, tmp_path / "default")
    assert status == 0, stderr
    assert f"valve planes estimated from the images: {tmp_path / 'default' / PLANES_FILE}" in stdout
    record = json.loads((tmp_path / "default" / "av.json").read_text())
    assert record["settings"]["refine_ed"] is True and record["base_anchors"] is True
    status, stdout, stderr = run_cli(*argv, tmp_path / "off", "--estimate-planes", "never",
                                     "--no-refine-ed")  # fmt: skip
    assert status == 0, stderr
    assert "valve planes" not in stdout and not (tmp_path / "off" / PLANES_FILE).exists()
    record = json.loads((tmp_path / "off" / "av.json").read_text())
    assert record["settings"]["refine_ed"] is False and record["base_anchors"] is False
    status, _, stderr = run_cli(*argv, tmp_path / "bad", "--estimate-planes", "sometimes")
    assert status == 2 and "--estimate-planes" in stderr
