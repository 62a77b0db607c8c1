"""The epicardium meshed and followed through the cycle, and the wall maps of a tracked cohort.

Two synthetic subjects' label series (2 mm voxels, four frames, ES at frame 2 of the
cycle's raised cosine) with their true valve planes: ``track_cohort`` with the
myocardium's label follows the endocardium and the epicardium, ``run_wall_maps``
measures the wall, and the maps are compared with the generator's truth
(:func:`~ladders.study.wall.true_wall_maps`). Tolerances are about twice the errors
measured with these settings, and a fraction of the quantities themselves.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from ladders.study.cohort import cycle_fraction, make_synthetic_cohort, motion_forward
from ladders.study.cohort.synthetic_lv import grid_shape, lv_grid
from ladders.study.errors import CohortError
from ladders.study.imaging import (
    ImageError,
    LabelImage,
    MeshingSettings,
    epicardial_image,
    render_labels,
    short_axis_affine,
    write_series,
)
from ladders.study.meshes import read_mesh, write_mesh
from ladders.study.preparation.synthetic_landmarks import synthetic_landmarks
from ladders.study.tracking import TrackingSettings, track_cohort
from ladders.study.wall import load_wall_cycles, run_wall_maps, true_epicardium, true_wall_maps

from .cli_runner import run_cli

VOXEL, N_FRAMES = 2.0, 4
SETTINGS = TrackingSettings(meshing=MeshingSettings(n_vertices=800))


@pytest.fixture(scope="module")
def cohort_folders(tmp_path_factory):
    """Two subjects' series and ED meshes, tracked with the epicardium, and their truth."""
    root = tmp_path_factory.mktemp("wall")
    cohort = make_synthetic_cohort(2, n_vertices=241)
    theta, phi, _ = lv_grid(*grid_shape(241))
    fractions = [float(cycle_fraction(t / N_FRAMES)) for t in range(N_FRAMES)]
    (root / "meshes").mkdir()
    planes, truth = {}, {}
    for s in cohort.subjects:
        ed = np.asarray(s.ed, float)
        low, high = ed.min(0) - 15.0, ed.max(0) + 6.0
        shape = tuple(int(n) for n in np.ceil((high - low) / VOXEL))
        affine = short_axis_affine(low, VOXEL, VOXEL)
        labels = [render_labels(s.parameters, affine, shape, f) for f in fractions]
        write_series(root / "images" / f"{s.name}.nii.gz", labels, affine)
        write_mesh(root / "meshes" / f"{s.name}_ed.vtk", ed, cohort.faces)
        planes[s.name] = {str(t): (0.0, 0.0, float(motion_forward(s.parameters, ed, f)[:, 2].max()),
                                   0.0, 0.0, 1.0) for t, f in enumerate(fractions)}  # fmt: skip
        truth[s.name] = true_wall_maps(s.parameters, theta, phi, fractions, n_around=240,
                                       n_rings=120)  # fmt: skip
    outcome = track_cohort(root / "meshes", root / "images", root / "tracked", 1, SETTINGS,
                           cut_planes=planes, jobs=1, progress=False, myocardium_label=2)  # fmt: skip
    assert [r["status"] for r in outcome.records] == ["ok", "ok"]
    return {"root": root, "cohort": cohort, "planes": planes, "truth": truth}


def test_the_epicardium_of_every_frame_is_followed_and_recorded(cohort_folders):
    root, cohort = cohort_folders["root"], cohort_folders["cohort"]
    name = cohort.subjects[0].name
    folder = root / "tracked" / name / "epicardium"
    assert sorted(p.name for p in folder.iterdir()) == [f"frame_0{t}.vtk" for t in range(4)]
    frames = [read_mesh(folder / f"frame_0{t}.vtk") for t in range(4)]
    assert all(np.array_equal(f, frames[0][1]) for _, f in frames)  # one triangulation
    record = json.loads((root / "tracked" / f"{name}.json").read_text())
    assert record["epicardium"]["myocardium_label"] == 2 and record["scale"] == 1.0
    assert len(record["epicardium"]["quality"]) == 4
    assert record["fingerprint"]["myocardium_label"] == 2
    params = cohort.subjects[0].parameters
    for t in (0, 2):  # the tracked epicardium lies on the true one, within a voxel's fraction
        f = float(cycle_fraction(t / N_FRAMES))
        true = true_epicardium(params, f, n_around=240, n_rings=120)
        from ladders.study.surface_queries import closest_points

        gap = closest_points(frames[t][0], *true)[1]
        assert gap.mean() < 0.3 * VOXEL and np.median(gap) < 0.25 * VOXEL
    again = track_cohort(root / "meshes", root / "images", root / "tracked", 1, SETTINGS,
                         cut_planes=cohort_folders["planes"], jobs=1, progress=False,
                         myocardium_label=2)  # fmt: skip
    assert [r["status"] for r in again.records] == ["skipped", "skipped"]


def test_the_wall_maps_of_the_tracked_cohort_match_the_truth(cohort_folders, tmp_path):
    root, cohort = cohort_folders["root"], cohort_folders["cohort"]
    landmarks = synthetic_landmarks(cohort.atlas)
    outcome = run_wall_maps(root / "tracked", cohort.atlas, cohort.faces, landmarks, tmp_path)
    assert sorted(outcome.computed) == [s.name for s in cohort.subjects] and not outcome.failures
    cycles = load_wall_cycles(tmp_path)
    es = 2
    for i, s in enumerate(cohort.subjects):
        truth = cohort_folders["truth"][s.name]
        errors = {m: np.abs(cycles.maps[m][i] - truth.measure(m) * (100.0 if m in (
            "radial", "circumferential", "longitudinal") else 1.0))[:, 1:] for m in cycles.maps}  # fmt: skip
        assert np.nanmean(errors["thickness"]) < 0.35 * VOXEL  # mm
        assert np.nanmean(errors["thickening"][es]) < 0.35 * VOXEL
        assert np.nanmean(errors["circumferential"][es]) < 3.0  # percent, of about -28
        assert np.nanmean(errors["longitudinal"][es]) < 3.0  # of about -15
        assert np.nanmean(errors["radial"][es]) < 12.0  # of about +40
    table = (tmp_path / "wall_segments.csv").read_text().splitlines()
    assert table[0].startswith("subject,segment,name,thickness_ed_mm") and len(table) == 1 + 34
    assert (tmp_path / "maps" / f"{cohort.subjects[0].name}.vtu").is_file()
    again = run_wall_maps(root / "tracked", cohort.atlas, cohort.faces, landmarks, tmp_path)
    assert sorted(again.reused) == sorted(outcome.computed) and not again.computed
    assert (tmp_path / "wall_segments.csv").read_text().splitlines() == table
    part = cycles.subset([cohort.subjects[1].name])
    np.testing.assert_array_equal(part.maps["radial"][0], cycles.maps["radial"][1])
    smooth = cycles.curves("radial", fwhm=15.0)
    assert smooth.shape == cycles.maps["radial"].shape
    assert smooth[:, 2].std(axis=1).mean() < cycles.maps["radial"][:, 2].std(axis=1).mean()
    with pytest.raises(ValueError, match="cycle study"):
        cycles.curves("normal")


def test_a_subject_tracked_without_the_epicardium_is_named(cohort_folders, tmp_path):
    import shutil

    root, cohort = cohort_folders["root"], cohort_folders["cohort"]
    shutil.copytree(root / "tracked", tmp_path / "tracked")
    for s in cohort.subjects:  # as tracked without --myocardium-label
        shutil.rmtree(tmp_path / "tracked" / s.name / "epicardium")
    outcome = run_wall_maps(tmp_path / "tracked", cohort.atlas, cohort.faces,
                            synthetic_landmarks(cohort.atlas), tmp_path / "wall")  # fmt: skip
    assert len(outcome.failures) == 2
    assert all("--myocardium-label" in reason for reason in outcome.failures.values())
    with pytest.raises(CohortError, match="stores no subject"):
        load_wall_cycles(tmp_path / "wall")
    with pytest.raises(CohortError, match="wall.json"):
        load_wall_cycles(tmp_path)


def test_the_epicardial_image_is_the_filled_union_of_cavity_and_myocardium(tmp_path):
    labels = np.zeros((9, 9, 9), dtype=np.int64)
    labels[1:8, 1:8, 1:8] = 2
    labels[3:6, 3:6, 3:6] = 1
    labels[4, 4, 4] = 0  # an unlabelled voxel inside the cavity
    image = LabelImage(labels, np.eye(4), tmp_path / "x.nii.gz", 3)
    union = epicardial_image(image, 1, 2)
    assert (union.labels == 2).sum() == 7**3 and set(np.unique(union.labels)) == {0, 2}
    with pytest.raises(ImageError, match="frame 3: myocardium label 5 is absent"):
        epicardial_image(image, 1, 5)
    with pytest.raises(ImageError, match="must differ"):
        epicardial_image(image, 2, 2)
    with pytest.raises(ImageError, match="myocardium_label"):
        epicardial_image(image, 1, -2)


def test_the_command_tracks_the_epicardium_and_measures_the_wall(cohort_folders, tmp_path):
    root, cohort = cohort_folders["root"], cohort_folders["cohort"]
    name = cohort.subjects[0].name
    (tmp_path / "meshes").mkdir()
    (tmp_path / "images").mkdir()
    for source, target in ((root / "meshes" / f"{name}_ed.vtk", tmp_path / "meshes"),
                           (root / "images" / f"{name}.nii.gz", tmp_path / "images")):  # fmt: skip
        (target / source.name).write_bytes(source.read_bytes())
    atlas = tmp_path / "atlas.vtk"
    write_mesh(atlas, cohort.atlas, cohort.faces)
    landmarks = tmp_path / "atlas.json"
    lm = synthetic_landmarks(cohort.atlas)
    landmarks.write_text(json.dumps({"apex": lm.apex.tolist(), "base_centre": lm.base.tolist(),
                                     "septal_point": lm.septum.tolist()}))  # fmt: skip
    status, _, stderr = run_cli("track", tmp_path / "meshes", tmp_path / "images", "--label", 1,
                                "--myocardium-label", 2, "--vertices", 800, "-o",
                                tmp_path / "tracked", "--jobs", 1, "--no-progress")  # fmt: skip
    assert status == 0, stderr
    assert len(list((tmp_path / "tracked" / name / "epicardium").glob("frame_*.vtk"))) == 4
    status, stdout, stderr = run_cli("wall", tmp_path / "tracked", "--atlas", atlas, "--aha",
                                     landmarks, "-o", tmp_path / "wall", "--jobs", 1,
                                     "--no-progress")  # fmt: skip
    assert status == 0, stderr
    assert "1 subject(s): 1 measured" in stdout
    assert (tmp_path / "wall" / "wall_segments.csv").is_file()
    for flags, what in ((("--myocardium-label", 1), "--myocardium-label"),
                        (("--epicardia", tmp_path), "--epicardia")):  # fmt: skip
        status, _, stderr = run_cli("track", tmp_path / "meshes", tmp_path / "images", "--label",
                                    1, *flags, "-o", tmp_path / "t2")  # fmt: skip
        assert status == 2 and what in stderr


def test_a_cine_series_moves_the_epicardium_with_the_endocardium(tmp_path):
    """The epicardium's points are moved by the registrations of the wall's voxels: at ES
    they lie near the true epicardium (measured 0.56 mm off it, 3.3 mm unmoved; 1.8 mm with
    the endocardium's voxels alone, the design's alternative), and the endocardium near
    its own (0.43 mm; 0.42 mm tracked alone). Four frames of 3 mm voxels, ES at frame 2;
    a subject without an ED epicardium is named."""
    pytest.importorskip("SimpleITK")
    from ladders.study.imaging import render_cine
    from ladders.study.surface_queries import closest_points
    from ladders.study.tracking import CineTrackingSettings
    from ladders.study.wall import true_endocardium

    cohort = make_synthetic_cohort(1, n_vertices=241)
    params, ed = cohort.subjects[0].parameters, np.asarray(cohort.subjects[0].ed, float)
    voxel, low = 3.0, np.array([-50.0, -50.0, -16.0])
    shape = tuple(int(n) for n in np.ceil((np.array([50.0, 50.0, 92.0]) - low) / voxel) + 1)
    affine = np.diag([voxel, voxel, voxel, 1.0])
    affine[:3, 3] = low
    fractions = cycle_fraction(np.arange(4) / 4, 0.5)
    series = [render_cine(params, affine, shape, f, noise=0.0, supersample=1) for f in fractions]
    epi_v, epi_f = true_epicardium(params, 0.0, n_around=24, n_rings=12)
    for folder in ("meshes", "epicardia"):
        (tmp_path / folder).mkdir()
    for name in ("a", "b"):
        write_series(tmp_path / "images" / f"{name}.nii.gz", series, affine)
        write_mesh(tmp_path / "meshes" / f"{name}_ed.vtk", ed, cohort.faces)
    write_mesh(tmp_path / "epicardia" / "a_ed.vtk", epi_v, epi_f)
    settings = CineTrackingSettings(control_point_spacing=20.0, sampling_percentage=0.05,
                                    iterations=15, seed=0)  # fmt: skip
    outcome = track_cohort(tmp_path / "meshes", tmp_path / "images", tmp_path / "tracked", 0,
                           settings, jobs=1, progress=False, epicardia=tmp_path / "epicardia")  # fmt: skip
    status = {r["subject"]: r for r in outcome.records}
    assert status["a"]["status"] == "ok" and "no ED epicardium" in status["b"]["error"]
    moved = read_mesh(tmp_path / "tracked" / "a" / "epicardium" / "frame_02.vtk")[0]
    wall = epi_v[:, 2] > 0.0  # the wall, not the cap
    true_epi = true_epicardium(params, 1.0, n_around=240, n_rings=120)
    off, still = (closest_points(x[wall], *true_epi)[1].mean() for x in (moved, epi_v))
    assert off < 1.0 and off < 0.3 * still, (off, still)
    theta, phi, faces = lv_grid(*grid_shape(241))
    endo = read_mesh(tmp_path / "tracked" / "a" / "frame_02.vtk")[0]
    true_endo = true_endocardium(params, theta, phi, 1.0)
    assert closest_points(endo, true_endo, faces)[1].mean() < 0.7
    record = json.loads((tmp_path / "tracked" / "a.json").read_text())
    assert record["fingerprint"]["epicardium_sha256"] and record["epicardium"]["ed_mesh"]
    from ladders.study.tracking import track_cine, wall_mask

    endo_only = wall_mask(shape, affine, ed, settings.mask_distance)  # the design's alternative
    behind = track_cine(np.stack(series), affine, np.concatenate([ed, epi_v]), settings,
                        mask=endo_only)[2, len(ed):]  # fmt: skip
    assert closest_points(behind[wall], *true_epi)[1].mean() > 2.0 * off


def test_the_mesh_step_writes_the_epicardium_beside_the_endocardium(cohort_folders, tmp_path):
    from ladders.study.imaging import mesh_label_images

    root, cohort = cohort_folders["root"], cohort_folders["cohort"]
    name = cohort.subjects[0].name
    series = root / "images" / f"{name}.nii.gz"
    outcome = mesh_label_images([series], 1, tmp_path, frames=(0, 2), progress=False,
                                myocardium_label=2, jobs=1)  # fmt: skip
    assert [r["status"] for r in outcome.records] == ["ok", "ok"]
    for phase in ("ed", "es"):
        epi, _ = read_mesh(tmp_path / "epicardium" / f"{name}_{phase}.vtk")
        endo, _ = read_mesh(tmp_path / f"{name}_{phase}.vtk")
        assert np.ptp(epi[:, 0]) > np.ptp(endo[:, 0]) + 10.0  # a wall around the cavity
        record = json.loads((tmp_path / f"{name}_{phase}.json").read_text())
        assert record["epicardium"]["myocardium_label"] == 2
    again = mesh_label_images([series], 1, tmp_path, frames=(0, 2), progress=False,
                              myocardium_label=2, jobs=1)  # fmt: skip
    assert [r["status"] for r in again.records] == ["skipped", "skipped"]
    from ladders.study.cohort.mesh_folder import scan_mesh_folder

    _, subjects, _ = scan_mesh_folder(tmp_path)  # what correspond reads: not the epicardia
    assert list(subjects) == [name] and sorted(subjects[name]) == ["ed", "es"]
    (tmp_path / "epicardium" / f"{name}_es.vtk").unlink()
    again = mesh_label_images([series], 1, tmp_path, frames=(0, 2), progress=False,
                              myocardium_label=2, jobs=1)  # fmt: skip
    assert [r["status"] for r in again.records] == ["skipped", "ok"]
    failed = mesh_label_images([series], 1, tmp_path / "x", frames=(0, 2), progress=False,
                               myocardium_label=3, jobs=1)  # fmt: skip
    assert all("myocardium label 3 is absent" in r["error"] for r in failed.records)
    with pytest.raises(ValueError, match="myocardium_label"):
        mesh_label_images([series], 1, tmp_path / "y", frames=(0, 2), myocardium_label=1)


def _wall_folder(folder, atlas, faces, region, seed=0, n=10, n_frames=8):
    """Wall maps of ``n`` subjects as ``symladders wall`` stores them: the patients (first
    half) thicken by 20 % instead of 40 % in ``region``, everyone with noise."""
    from ladders.study.wall import WallMaps

    rng = np.random.default_rng(seed)
    folder.mkdir()
    write_mesh(folder / "atlas.vtk", atlas, faces)
    t = np.arange(n_frames) / n_frames
    shape = np.sin(np.pi * t)[:, None] ** 2
    names = [f"s{i}" for i in range(n)]
    for i, name in enumerate(names):
        gain = np.where(region & (i < n // 2), 0.2, 0.4)
        thickness = 9.0 * (1.0 + gain[None, :] * shape) + rng.normal(0, 0.1, (n_frames, len(atlas)))
        strain = -0.2 * shape + rng.normal(0, 0.01, (n_frames, len(atlas)))
        maps = WallMaps(thickness, strain, strain, np.zeros(thickness.shape, bool))
        np.savez(folder / f"{name}.npz", **maps.as_arrays(), fingerprint="x")
    (folder / "wall.json").write_text(json.dumps({"subjects": {s: "computed" for s in names}}))
    return names


def test_cycle_analyze_tests_a_wall_measure_of_the_wall_maps(tmp_path):
    from ladders.study.sequences import compare_cycles

    cohort = make_synthetic_cohort(1, n_vertices=241)
    region = cohort.atlas[:, 0] > 10.0
    names = _wall_folder(tmp_path / "wall", cohort.atlas, cohort.faces, region)
    cycles = load_wall_cycles(tmp_path / "wall")
    labels = np.arange(len(names)) < len(names) // 2
    tests = compare_cycles(cycles, labels, 500, np.random.default_rng(0), measure="radial")
    found = tests.peak.p_fwer < 0.05
    assert found[region].mean() > 0.9 and found[~region].mean() < 0.05
    assert tests.unit == "percent"
    np.testing.assert_allclose(tests.peaks[~labels][:, region].mean(), 40.0, atol=1.0)
    with pytest.raises(ValueError, match="need a cycle study"):
        compare_cycles(cycles, labels, 50, np.random.default_rng(0), measure="normal")
    groups = tmp_path / "groups.csv"
    groups.write_text("subject,group\n" + "".join(
        f"{s},{'patients' if p else 'controls'}\n" for s, p in zip(names, labels)))  # fmt: skip
    status, stdout, stderr = run_cli("cycle-analyze", tmp_path / "wall", "--groups", groups,
                                     "--compare", "patients", "controls", "--measure",
                                     "thickening", "--permutations", 200)  # fmt: skip
    assert status == 0, stderr
    table = (tmp_path / "wall" / "analysis" / "cycle_vertices.csv").read_text().splitlines()
    assert table[0].startswith("contrast,vertex,peak_group1_mm,peak_group2_mm")
    status, _, stderr = run_cli("cycle-analyze", tmp_path / "wall", "--groups", groups,
                                "--measure", "normal")  # fmt: skip
    assert status == 2 and "cycle_study.json" in stderr
