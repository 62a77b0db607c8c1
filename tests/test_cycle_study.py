"""Whole cycles in the study: every frame transported by the pole ladder, and the cycle tests."""

from __future__ import annotations

import csv
import dataclasses
import json

import numpy as np
import pytest

from ladders.study.cli import main
from ladders.study.cohort import Subject
from ladders.study.cohort.planted_effect import MotionAbnormality
from ladders.study.errors import CohortError
from ladders.study.meshes.mesh_io import write_mesh
from ladders.study.population.aha_model import aha_segments
from ladders.study.population.cycle_cohort import CYCLE_ABNORMALITY, make_two_group_cycles
from ladders.study.preparation.synthetic_landmarks import synthetic_landmarks
from ladders.study.running.pipeline import StudyConfig, compute_pair, make_space
from ladders.study.sequences import (
    CycleMotion,
    compare_cycles,
    curve_peaks,
    load_cycle_motion,
    read_tracked_frames,
    run_cycle_study,
    transport_frames,
)
from ladders.study.sequences.cycle_outputs import write_cycle_tests

FAST = {"sigma": 20.0, "max_iter": 60}
N_FRAMES, ES_FRAME = 20, 7  # es_phase 0.35: frame 7 is end-systole


@pytest.fixture(scope="module")
def cycles():
    return make_two_group_cycles(n_subjects=6, n_frames=N_FRAMES, n_vertices=150, seed=2)


def test_the_end_systolic_frame_is_the_study_pair(cycles):
    """Frame t of a cycle is the study's pair (S, S_t): the ES frame gives compute_pair's ladder."""
    atlas, faces, frames = cycles.data.cohort.atlas, cycles.faces, cycles.frames[1]
    assert np.allclose(frames[0], cycles.data.cohort.subjects[1].ed)
    config = StudyConfig.build(alpha2=(1.0,), **FAST)
    result = transport_frames(make_space(config, atlas, 1.0), atlas, frames[: ES_FRAME + 1])
    pair = compute_pair(config, atlas, faces, Subject("s", frames[0], frames[ES_FRAME]), 1.0)
    ladder = next(t for t in pair.transports if t.method == "pole_ladder_residual")
    expected = np.asarray(ladder.displacement).reshape(-1, 3)
    got = result.displacement[ES_FRAME]
    assert np.abs(got - expected).max() < 1e-8 * np.abs(expected).max()
    assert np.all(result.displacement[0] == 0)
    assert result.converged.all()


def test_a_subject_equal_to_the_atlas_keeps_its_motion(cycles):
    """With S = T the ladder is s_T o s_T: the identity, up to the registrations' involutivity."""
    frames = cycles.frames[0]
    space = make_space(StudyConfig.build(alpha2=(1.0,), **FAST), frames[0], 1.0)
    result = transport_frames(space, frames[0], frames[::4])
    motion = np.linalg.norm(frames[::4] - frames[0], axis=-1).mean(axis=1)
    error = np.linalg.norm(result.transported - frames[::4], axis=-1).mean(axis=1)
    assert motion.max() > 3.0  # mm: the check is not trivial
    assert np.all(error <= 0.05 * motion.max())


def test_bad_frames_are_named(cycles):
    atlas = cycles.data.cohort.atlas
    space = make_space(StudyConfig.build(alpha2=(1.0,), **FAST), atlas, 1.0)
    with pytest.raises(ValueError, match="frames: expected at least 2 frames"):
        transport_frames(space, atlas, cycles.frames[0][:1])
    with pytest.raises(ValueError, match="vertices per frame, the atlas has"):
        transport_frames(space, atlas, cycles.frames[0][:, :-1])
    bad = cycles.frames[0].copy()
    bad[3, 5, 0] = np.nan
    with pytest.raises(ValueError, match=r"frame\(s\) \[3\] contain NaN"):
        transport_frames(space, atlas, bad)


def test_study_resumes_records_a_failure_and_goes_on(cycles, tmp_path):
    atlas, faces = cycles.data.cohort.atlas, cycles.faces
    seqs = {n: cycles.frames[i][::5] for i, n in enumerate(cycles.names[:3])}
    seqs["broken"] = cycles.frames[0][::5, :-2]  # not in the atlas's correspondence
    out = run_cycle_study(atlas, faces, seqs, tmp_path, **FAST)
    assert sorted(out.computed) == sorted(cycles.names[:3])
    assert "atlas has" in out.failures["broken"]
    rows = {r["subject"]: r for r in csv.DictReader(open(tmp_path / "cycle_study.csv"))}
    assert rows["broken"]["status"] == "failed" and rows[cycles.names[0]]["status"] == "computed"
    first = load_cycle_motion(tmp_path)
    assert first.subjects == tuple(cycles.names[:3]) and first.displacement.shape[1] == 4
    seqs[cycles.names[1]] = cycles.frames[1][1::5]  # changed frames: computed again
    again = run_cycle_study(atlas, faces, seqs, tmp_path, **FAST)
    assert again.computed == [cycles.names[1]]
    assert sorted(again.reused) == sorted([cycles.names[0], cycles.names[2]])
    other = run_cycle_study(atlas, faces, seqs, tmp_path, alpha2=10.0, **FAST)  # new settings
    assert len(other.computed) == 3 and not other.reused


def test_curve_peaks_recovers_a_peak_between_frames():
    n = 25
    t = np.arange(n) / n
    true_time = np.array([0.3, 0.333, 0.37, 0.95])  # the last wraps around the cycle
    amplitude = np.array([8.0, 5.0, 2.0, 3.0])
    d = (t[:, None] - true_time[None] + 0.5) % 1.0 - 0.5
    curves = -amplitude * np.exp(-0.5 * (d / 0.08) ** 2)  # inward (negative), periodic
    peak, time = curve_peaks(curves)
    step = 1.0 / n
    assert np.all(np.abs(((time - true_time + 0.5) % 1.0) - 0.5) < 0.1 * step)
    assert np.allclose(peak, amplitude, rtol=0.02)
    on_grid = np.abs(((np.round(true_time * n) / n - true_time + 0.5) % 1.0) - 0.5)
    assert on_grid.max() > 0.3 * step  # the refinement is what gets within 0.1 step
    with pytest.raises(ValueError, match="fractions: expected 25 evenly spaced"):
        curve_peaks(curves, fractions=np.linspace(0, 1, n))


def _corresponded_motion(c) -> CycleMotion:
    """The cohort's own motion without transport (every subject on its own anatomy)."""
    return CycleMotion(c.names, c.frames - c.frames[:, :1], c.data.cohort.atlas, c.faces)


def test_the_cycle_tests_find_the_planted_region_and_nothing_under_the_null(tmp_path):
    c = make_two_group_cycles(n_subjects=24, n_frames=12, n_vertices=300, seed=4)
    motion = _corresponded_motion(c)
    rng = np.random.default_rng(0)
    tests = compare_cycles(motion, c.patients, 1000, rng)
    region = c.data.region.weight > 0
    found = tests.peak.p_fwer < 0.05
    assert found.sum() >= 0.3 * region.sum()
    assert (found & ~region).sum() <= 0.02 * len(region)
    assert tests.peak.statistic[found].max() < 0  # patients move less inward: lower peak
    frames_found = (tests.per_frame.p_fwer < 0.05).any(axis=1)
    assert not frames_found[0] and frames_found[ES_FRAME * 12 // N_FRAMES]
    controls, null = _controls_only(c, motion)
    null_tests = compare_cycles(null, np.arange(len(controls)) % 2 == 0, 1000, rng)
    assert (null_tests.peak.p_fwer < 0.05).sum() <= 0.01 * len(region)
    paths = write_cycle_tests(tmp_path, motion, tests, ("patients", "controls"))
    assert all(p.is_file() and p.stat().st_size > 0 for p in paths)
    rows = list(csv.DictReader(open(tmp_path / "cycle_vertices.csv")))
    assert len(rows) == len(region)
    assert int(rows[int(np.argmin(tests.peak.p_fwer))]["vertex"]) >= 0


def _controls_only(c, motion):
    """The indices of the controls and their motion alone (a cohort under the null)."""
    controls = np.flatnonzero(~c.patients)
    null = CycleMotion(tuple(c.names[i] for i in controls), motion.displacement[controls],
                       motion.atlas, motion.faces)  # fmt: skip
    return controls, null


def _noisy_cycles():
    """24 subjects whose every frame but ED carries a fixed per-subject, per-vertex error
    of 1.5 mm RMS (as a tracked point's): the cohort and the noisy motion."""
    c = make_two_group_cycles(n_subjects=24, n_frames=12, n_vertices=300, seed=4)
    d = c.frames - c.frames[:, :1]
    rng = np.random.default_rng(1)
    error = rng.normal(size=(d.shape[0], 1, d.shape[2], 3)) * 1.5 / np.sqrt(3)
    motion = CycleMotion(c.names, d + error * (np.arange(d.shape[1]) > 0)[None, :, None, None],
                         c.data.cohort.atlas, c.faces)  # fmt: skip
    return c, motion


def test_tfce_on_the_peak_keeps_a_region_that_vertex_noise_hides():
    """A fixed per-subject, per-vertex error (as a tracked point's) added to every frame:
    the peak's ``t`` is the same as the max-t test's, and TFCE finds more of the planted
    region than the maximum statistic, with as few false vertices; nothing under the null."""
    c, motion = _noisy_cycles()
    tests = compare_cycles(motion, c.patients, 1000, np.random.default_rng(0), tfce=True,
                           summaries=("peak",))  # fmt: skip
    np.testing.assert_allclose(tests.peak_tfce.statistic, tests.peak.statistic, rtol=1e-7)
    region = c.data.region.weight > 0
    max_t, enhanced = tests.peak.p_fwer < 0.05, tests.peak_tfce.p_fwer_enhanced < 0.05
    assert enhanced[region].mean() >= max_t[region].mean() + 0.05
    assert (enhanced & ~region).sum() <= 0.02 * len(region)
    controls, null = _controls_only(c, motion)
    null_tests = compare_cycles(null, np.arange(len(controls)) % 2 == 0, 1000,
                                np.random.default_rng(2), tfce=True, summaries=("peak",))  # fmt: skip
    assert (null_tests.peak_tfce.p_fwer_enhanced < 0.05).sum() <= 0.01 * len(region)
    assert compare_cycles(null, np.arange(len(controls)) % 2 == 0, 10,
                          np.random.default_rng(2)).peak_tfce is None  # fmt: skip


def test_smoothing_the_maps_finds_a_region_that_vertex_noise_hides():
    """The same fixed per-vertex error as above: every map smoothed on the atlas (10 mm
    FWHM) before the tests finds more of the planted region than the raw maps, with as
    few false vertices, and nothing under the null; the curves tested are the smoothed
    ones; the rotation is smoothed off the axis only."""
    from ladders.statistics import SurfaceSmoother

    c, motion = _noisy_cycles()
    raw = compare_cycles(motion, c.patients, 1000, np.random.default_rng(0))
    smooth = compare_cycles(motion, c.patients, 1000, np.random.default_rng(0), fwhm=10.0)
    assert raw.fwhm is None and smooth.fwhm == 10.0
    smoother = SurfaceSmoother(motion.atlas, motion.faces, 10.0)
    np.testing.assert_allclose(smooth.curves(motion), smoother(motion.normal()), atol=1e-12)
    region = c.data.region.weight > 0
    found_raw, found = raw.peak.p_fwer < 0.05, smooth.peak.p_fwer < 0.05
    print(f"region found: {found_raw[region].mean():.2f} raw, {found[region].mean():.2f} "
          f"smoothed; outside {(found_raw & ~region).sum()}, {(found & ~region).sum()}")  # fmt: skip
    assert found[region].mean() >= found_raw[region].mean() + 0.1
    assert (found & ~region).sum() <= 0.03 * len(region)
    controls, null = _controls_only(c, motion)
    null_tests = compare_cycles(null, np.arange(len(controls)) % 2 == 0, 1000,
                                np.random.default_rng(2), fwhm=10.0)  # fmt: skip
    assert (null_tests.peak.p_fwer < 0.05).sum() <= 0.01 * len(region)
    lm = synthetic_landmarks(c.data.cohort.atlas)
    turned = compare_cycles(motion, c.patients, 10, np.random.default_rng(0), fwhm=10.0,
                            measure="rotation", axis=lm)  # fmt: skip
    rotation = turned.curves(motion)
    near = ~np.isfinite(rotation).all(axis=(0, 1))
    assert near.any() and (turned.tested == ~near).all()
    mask = SurfaceSmoother(motion.atlas, motion.faces, 10.0, mask=~near)
    np.testing.assert_allclose(rotation[..., ~near],
                               mask(motion.curves("rotation", lm))[..., ~near], atol=1e-12)  # fmt: skip
    with pytest.raises(ValueError, match="fwhm: expected a width"):
        compare_cycles(motion, c.patients, 10, np.random.default_rng(0), fwhm=-1.0)


def _apical_cap(c) -> np.ndarray:
    """The atlas's AHA segment 17 (the apical cap)."""
    lm = synthetic_landmarks(c.data.cohort.atlas)
    return aha_segments(c.data.cohort.atlas, lm.apex, lm.base, lm.septum, c.faces) == 17


def test_leaving_a_noisy_apical_cap_out_keeps_the_power_of_the_rest():
    """Heavy-tailed errors at the apical cap (thick slices resolve it poorly) raise the
    permutation maximum over all vertices and hide the planted region; tested without the
    cap, the region is found again. The t of a tested vertex does not depend on which
    others are tested, and its FWER p is at most the one over every vertex."""
    mild = dataclasses.replace(CYCLE_ABNORMALITY, magnitude=0.4)
    c = make_two_group_cycles(n_subjects=24, n_frames=12, n_vertices=300, seed=4, abnormality=mild)
    d = c.frames - c.frames[:, :1]
    cap = _apical_cap(c)
    assert 5 <= cap.sum() < 0.2 * len(cap)
    rng = np.random.default_rng(3)
    error = rng.standard_t(2, size=(d.shape[0], 1, d.shape[2], 3)) * 2.0 * cap[None, None, :, None]
    motion = CycleMotion(c.names, d + error * (np.arange(d.shape[1]) > 0)[None, :, None, None],
                         c.data.cohort.atlas, c.faces)  # fmt: skip
    region = c.data.region.affected & ~cap
    full = compare_cycles(motion, c.patients, 1000, np.random.default_rng(0), tfce=True,
                          summaries=("peak", "per_frame"))  # fmt: skip
    part = compare_cycles(motion, c.patients, 1000, np.random.default_rng(0), tfce=True,
                          vertices=~cap, summaries=("peak", "per_frame"))  # fmt: skip
    np.testing.assert_allclose(part.peak.statistic[~cap], full.peak.statistic[~cap], rtol=1e-7)
    assert np.isnan(part.peak.statistic[cap]).all() and np.isnan(part.peak.p_fwer[cap]).all()
    assert np.isnan(part.peak_tfce.p_fwer_enhanced[cap]).all()
    assert np.isfinite(part.peak_tfce.p_fwer_enhanced[~cap]).all()
    assert part.per_frame.p_fwer.shape == full.per_frame.p_fwer.shape
    assert (part.peak.p_fwer[~cap] <= full.peak.p_fwer[~cap] + 1e-12).all()
    found_full, found_part = full.peak.p_fwer < 0.05, part.peak.p_fwer < 0.05
    print(f"region found: {found_full[region].mean():.2f} over every vertex, "
          f"{found_part[region].mean():.2f} without the cap")  # fmt: skip
    assert found_part[region].mean() >= found_full[region].mean() + 0.2
    assert (found_part & ~region).sum() <= 0.02 * len(region)
    assert part.tested is not None and (part.tested == ~cap).all()
    with pytest.raises(ValueError, match="vertices: expected 300 booleans"):
        compare_cycles(motion, c.patients, 10, np.random.default_rng(0), vertices=~cap[:10])


def test_the_rotation_finds_a_planted_twist_that_the_normal_motion_does_not_see():
    """A twist (5 degrees about the long axis in segments 7, 8, 13, 14) through the true
    frames: the rotation's peak finds the region, the normal motion's does not, and
    random splits of the controls find something at about the nominal rate. The atlas's apex and its vertices near the axis
    are left out. On a rigid turn of every frame, the rotation is the turn's angle."""
    twist = MotionAbnormality("twist", transition_height=0.1)
    c = make_two_group_cycles(n_subjects=24, n_frames=12, n_vertices=300, seed=4,
                              abnormality=twist)  # fmt: skip
    motion = _corresponded_motion(c)
    lm = synthetic_landmarks(c.data.cohort.atlas)
    region = c.data.region.affected
    tests = compare_cycles(motion, c.patients, 1000, np.random.default_rng(0),
                           measure="rotation", axis=lm)  # fmt: skip
    near = np.linalg.norm(np.cross(motion.atlas - lm.apex, lm.long_axis), axis=1) < 5.0
    assert near.any() and (tests.tested == ~near).all()
    assert np.isnan(tests.peak.p_fwer[near]).all() and np.isnan(tests.peaks[:, near]).all()
    found = tests.peak.p_fwer < 0.05
    print(f"twist: rotation finds {found[region].mean():.2f} of the region, "
          f"{(found & ~region).sum()} vertices outside")  # fmt: skip
    assert found[region].mean() >= 0.8
    assert (found & ~region).sum() <= 0.02 * len(region)
    sign = np.sign(tests.peaks[:, found].mean(axis=0))  # the peak in the cohort's sense
    assert (np.sign(tests.peaks[:, found]) == sign).mean() > 0.9
    normal = compare_cycles(motion, c.patients, 1000, np.random.default_rng(0))
    assert (normal.peak.p_fwer < 0.05)[region].mean() <= 0.1
    controls, null = _controls_only(c, motion)
    rng, hits = np.random.default_rng(5), 0
    for _ in range(40):  # the null FWER over random splits of the controls
        split = np.isin(np.arange(len(controls)), rng.permutation(len(controls))[:6])
        null_tests = compare_cycles(null, split, 200, rng, measure="rotation",
                                    axis=np.stack([lm.apex, lm.base]), summaries=("peak",))  # fmt: skip
        hits += bool((null_tests.peak.p_fwer < 0.05).any())
    assert hits / 40 <= 0.15  # nominal 0.05; 7 or more of 40 has probability 0.014
    turns = np.linspace(0.0, 12.0, 12)
    rigid = np.stack([_rotated(motion.atlas, lm, a) - motion.atlas for a in turns])
    curve = CycleMotion(("a",), rigid[None], motion.atlas, motion.faces).rotation(lm.apex, lm.base)
    np.testing.assert_allclose(curve[0][:, ~near], np.repeat(turns[:, None], (~near).sum(), 1),
                               atol=1e-9)  # fmt: skip
    with pytest.raises(ValueError, match="axis: the rotation needs"):
        compare_cycles(motion, c.patients, 10, np.random.default_rng(0), measure="rotation")
    with pytest.raises(ValueError, match="measure: expected one of"):
        compare_cycles(motion, c.patients, 10, np.random.default_rng(0), measure="twist")
    with pytest.raises(ValueError, match="min_radius: fewer than 2 vertices"):
        compare_cycles(motion, c.patients, 10, np.random.default_rng(0), measure="rotation",
                       axis=lm, min_radius=1e4)  # fmt: skip


def _rotated(points, lm, degrees):
    """``points`` turned counter-clockwise, seen from the apex, about the landmarks' axis."""
    from scipy.spatial.transform import Rotation

    turn = Rotation.from_rotvec(-np.radians(degrees) * lm.long_axis)  # long_axis: apex to base
    return turn.apply(points - lm.apex) + lm.apex


def test_groups_must_name_every_subject(cycles):
    motion = _corresponded_motion(cycles)
    with pytest.raises(CohortError, match="no group for subject"):
        compare_cycles(motion, {cycles.names[0]: True}, 10, np.random.default_rng(0))


def test_tracked_folder_layout_is_checked(tmp_path, cycles):
    faces = cycles.faces
    (tmp_path / "a").mkdir()
    for t in (0, 1, 3):
        write_mesh(tmp_path / "a" / f"frame_{t:02d}.vtk", cycles.frames[0][t], faces)
    with pytest.raises(CohortError, match=r"a: frame\(s\) \[2\] missing"):
        read_tracked_frames(tmp_path)
    write_mesh(tmp_path / "a" / "frame_02.vtk", cycles.frames[0][2], faces)
    write_mesh(tmp_path / "a" / "frame_2.ply", cycles.frames[0][2], faces)
    with pytest.raises(CohortError, match="frame 2 given twice"):
        read_tracked_frames(tmp_path)


def test_cli_from_tracked_meshes_to_the_cycle_tests(tmp_path, cycles, capsys):
    atlas, faces = cycles.data.cohort.atlas, cycles.faces
    write_mesh(tmp_path / "atlas.vtk", atlas, faces)
    groups = ["subject,group"]
    for i, name in enumerate(cycles.names):
        (tmp_path / "tracked" / name).mkdir(parents=True)
        for t in range(0, N_FRAMES, 5):
            write_mesh(tmp_path / "tracked" / name / f"frame_{t // 5:02d}.vtk",
                       cycles.frames[i][t], faces)  # fmt: skip
        groups.append(f"{name},{'patients' if cycles.patients[i] else 'controls'}")
    (tmp_path / "groups.csv").write_text("\n".join(groups) + "\n")
    study = tmp_path / "study"
    argv = ["cycle-study", str(tmp_path / "tracked"), "--atlas", str(tmp_path / "atlas.vtk"),
            "-o", str(study), "--sigma", "20", "--jobs", "1", "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    assert "6 transported" in capsys.readouterr().out
    assert main(argv) == 0 and "6 already done" in capsys.readouterr().out
    assert main(["cycle-analyze", str(study), "--groups", str(tmp_path / "groups.csv"),
                 "--permutations", "200", "--no-figures", "--tfce"]) == 0  # fmt: skip
    assert "(TFCE: " in capsys.readouterr().out
    rows = list(csv.DictReader(open(study / "analysis" / "cycle_vertices.csv")))
    assert len(rows) == len(atlas) and all(0 < float(r["peak_tfce_p_fwer"]) <= 1 for r in rows)
    assert main(["cycle-analyze", str(study), "--groups", str(tmp_path / "groups.csv"),
                 "--permutations", "200", "--no-figures"]) == 0  # fmt: skip
    assert "vertices found at FWER 5 %" in capsys.readouterr().out
    raw = _column(study / "analysis" / "cycle_vertices.csv", "peak_group1_mm")
    assert main(["cycle-analyze", str(study), "--groups", str(tmp_path / "groups.csv"),
                 "--permutations", "200", "--no-figures", "--fwhm", "12", "-o", str(tmp_path / "fwhm")]) == 0  # fmt: skip
    assert ", smoothed 12 mm FWHM: " in capsys.readouterr().out
    smooth = _column(tmp_path / "fwhm" / "cycle_vertices.csv", "peak_group1_mm")
    assert 0 < np.std(smooth) < np.std(raw)  # the group's mean peak map, smoothed
    assert main(["cycle-analyze", str(study), "--groups", str(tmp_path / "groups.csv"),
                 "--fwhm", "0"]) == 2  # fmt: skip
    assert "--fwhm" in capsys.readouterr().err
    lm = synthetic_landmarks(atlas)
    (tmp_path / "aha.json").write_text(json.dumps({"apex": lm.apex.tolist(), "base_centre":
        lm.base.tolist(), "septal_point": lm.septum.tolist()}))  # fmt: skip
    cap = _apical_cap(cycles)
    assert main(["cycle-analyze", str(study), "--groups", str(tmp_path / "groups.csv"),
                 "--permutations", "200", "--no-figures", "--tfce", "--aha", str(tmp_path / "aha.json"),
                 "--exclude-segments", "17", "-o", str(tmp_path / "no17")]) == 0  # fmt: skip
    assert f"(of {int((~cap).sum())} vertices tested)" in capsys.readouterr().out
    rows = list(csv.DictReader(open(tmp_path / "no17" / "cycle_vertices.csv")))
    assert [r["tested"] == "1" for r in rows] == list(~cap)
    assert all(r["peak_p_fwer"] == "nan" for r, c in zip(rows, cap) if c)
    assert main(["cycle-analyze", str(study), "--groups", str(tmp_path / "groups.csv"),
                 "--permutations", "200", "--no-figures", "--measure", "rotation", "--aha",
                 str(tmp_path / "aha.json"), "-o", str(tmp_path / "rotation")]) == 0  # fmt: skip
    near = np.linalg.norm(np.cross(atlas - lm.apex, lm.long_axis), axis=1) < 5.0
    assert "peak rotation " in capsys.readouterr().out
    rows = list(csv.DictReader(open(tmp_path / "rotation" / "cycle_vertices.csv")))
    assert [r["tested"] == "1" for r in rows] == list(~near)
    assert all(np.isfinite(float(r["peak_group1_deg"])) != c for r, c in zip(rows, near))
    assert main(["cycle-analyze", str(study), "--groups", str(tmp_path / "groups.csv"),
                 "--measure", "rotation"]) == 2  # fmt: skip
    assert "--measure rotation: needs --aha" in capsys.readouterr().err
    assert main(["cycle-analyze", str(study), "--groups", str(tmp_path / "groups.csv"),
                 "--aha", str(tmp_path / "aha.json"), "--permutations", "50", "--no-figures",
                 "-o", str(tmp_path / "segments")]) == 0  # fmt: skip
    segments = list(csv.DictReader(open(tmp_path / "segments" / "cycle_segments.csv")))
    assert {r["summary"] for r in segments} == {"per_frame", "peak", "time_to_peak", "trajectory"}
    assert len(segments) == 4 * 17 and all(0 < float(r["p_fwer"]) <= 1 for r in segments)
    assert main(["cycle-analyze", str(study), "--groups", str(tmp_path / "groups.csv"),
                 "--exclude-segments", "17"]) == 2  # fmt: skip
    assert "--exclude-segments: needs --aha" in capsys.readouterr().err
    assert main(["cycle-analyze", str(study), "--groups", str(tmp_path / "groups.csv"),
                 "--aha", str(tmp_path / "aha.json"), "--exclude-segments", "18"]) == 2  # fmt: skip
    assert "--exclude-segments: expected AHA segment numbers 1..17" in capsys.readouterr().err
    assert (study / "analysis" / "cycle_tests.vtu").is_file()
    (tmp_path / "bad.csv").write_text("subject,group\n" + f"{cycles.names[0]},a\n")
    assert main(["cycle-analyze", str(study), "--groups", str(tmp_path / "bad.csv")]) == 2
    assert "expected two groups, the table has 1" in capsys.readouterr().err
    (tmp_path / "small.csv").write_text("subject,group\n" + "".join(
        f"{n},{'a' if i < 2 else 'b'}\n" for i, n in enumerate(cycles.names)))  # fmt: skip
    assert main(["cycle-analyze", str(study), "--groups", str(tmp_path / "small.csv")]) == 2
    assert "at least 3 subjects" in capsys.readouterr().err


def _column(path, name) -> np.ndarray:
    """A column of a CSV table as floats."""
    with open(path) as fh:
        return np.array([float(r[name]) for r in csv.DictReader(fh)])


def test_the_ideal_cycle_transport_is_the_ideal_transport_at_end_systole(cycles):
    from ladders.study.population import ideal_cycle_transport, ideal_transport

    ideal = ideal_cycle_transport(cycles)
    assert ideal.shape == cycles.frames.shape
    assert np.all(ideal[:, 0] == 0)
    es = ideal_transport(cycles.data)
    assert np.abs(ideal[:, ES_FRAME] - es).max() < 1e-9 * np.abs(es).max()
    # a subject's own motion on its own anatomy differs from it on the atlas's
    own = cycles.frames - cycles.frames[:, :1]
    assert np.linalg.norm(own[:, ES_FRAME] - es, axis=-1).mean() > 0.5
    with pytest.raises(CohortError, match="expected a CohortCycles"):
        ideal_cycle_transport(cycles.data)
