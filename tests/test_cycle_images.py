"""The whole-cycle cohort written as 4-D label and cine series, its frames and its truth."""

from __future__ import annotations

import json

import nibabel as nib
import numpy as np
import pytest

from ladders.study.cli import main
from ladders.study.errors import CohortError
from ladders.study.imaging import extract_surface
from ladders.study.imaging.label_images import read_label_series
from ladders.study.meshes.mesh_io import read_mesh
from ladders.study.population import cycle_grid, make_two_group_cycles, write_cycle_cohort
from ladders.study.preparation.surface_distance import distances_to_surface
from ladders.study.sequences import read_tracked_frames


@pytest.fixture(scope="module")
def cycles():
    return make_two_group_cycles(n_subjects=6, n_frames=6, n_vertices=241, seed=3)


def test_label_series_render_the_true_frames(cycles, tmp_path):
    folder = write_cycle_cohort(cycles, tmp_path, "labels", 1.5, 4.0)
    record = json.loads((folder / "cycle.json").read_text())
    assert record["n_frames"] == 6 and record["es_frame"] == int(np.argmax(cycles.fractions))
    frames = read_tracked_frames(folder / "frames")
    assert list(frames) == list(cycles.names)
    name = cycles.names[1]
    series = read_label_series(folder / "images" / f"{name}.nii.gz")
    assert len(series) == 6
    affine, shape = cycle_grid(cycles.frames[1, 0], 1.5, 4.0)
    assert np.allclose(series[0].affine, affine) and series[0].labels.shape == shape
    for t in (0, record["es_frame"]):
        truth, _ = read_mesh(frames[name][t])
        assert np.allclose(truth, cycles.frames[1, t], atol=1e-6)
        vertices, faces, _ = extract_surface(series[t], 1)
        d = distances_to_surface(truth, vertices, faces)
        assert np.median(d) < 1.0  # mm, on a 1.5 x 1.5 x 4 mm grid
    volumes = [np.count_nonzero(s.labels == 1) for s in series]
    assert np.argmin(volumes) == record["es_frame"]  # the cavity is smallest at ES


def test_valve_planes_are_the_true_rims_and_the_track_table(cycles, tmp_path):
    """``valve_planes.csv``: every frame's rim lies on its plane, the normal points away
    from the apex, the plane descends in systole, and the table is ``--cut-planes``'s."""
    from ladders.study.imaging.plane_table import planes_by_image, read_plane_table
    from ladders.study.population import cycle_valve_planes, valve_planes
    from ladders.study.volume import boundary_vertices

    folder = write_cycle_cohort(cycles, tmp_path, "none", 1.5, 8.0, frames=False)
    table = planes_by_image(read_plane_table(folder / "valve_planes.csv"))
    assert list(table) == list(cycles.names)
    given = cycle_valve_planes(cycles)  # what track_cohort takes in Python
    assert list(given) == list(table)
    for name in table:
        assert list(given[name]) == list(table[name])
        assert np.allclose(list(given[name].values()), list(table[name].values()), atol=1e-5)
    rim = boundary_vertices(cycles.faces)
    for i, name in enumerate(cycles.names):
        planes = valve_planes(cycles.frames[i], cycles.faces)
        assert list(table[name]) == [str(t) for t in range(len(cycles.fractions))]
        assert np.allclose([table[name][str(t)] for t in range(len(planes))], planes, atol=1e-5)
        for t, plane in enumerate(planes):
            off = (cycles.frames[i, t, rim] - plane[:3]) @ plane[3:]
            assert np.abs(off).max() < 1e-6 * np.ptp(cycles.frames[i, t])  # the rim is planar
            assert ((cycles.frames[i, t] - plane[:3]) @ plane[3:]).max() < 1e-4  # apex side
        es = int(np.argmax(cycles.fractions))
        assert planes[es, 2] < planes[0, 2] - 5.0  # the base descends towards the apex
    with pytest.raises(CohortError, match="frames: expected"):
        valve_planes(cycles.frames[0, 0], cycles.faces)


def test_cine_series_are_intensities_with_tagging(cycles, tmp_path):
    from ladders.study.imaging.cine import TagGrid

    small = make_two_group_cycles(n_subjects=2, n_frames=3, n_vertices=241, seed=3)
    folder = write_cycle_cohort(small, tmp_path, "cine", 3.0, 8.0, tagging=TagGrid(),
                                rng=np.random.default_rng(0), frames=False)  # fmt: skip
    img = nib.load(str(folder / "images" / f"{small.names[0]}.nii.gz"))
    data = np.asarray(img.dataobj)
    assert data.dtype == np.float32 and data.shape[-1] == 3
    labels = np.asarray(small.render_labels(0, img.affine, data.shape[:3], 0))
    blood, wall = (np.median(data[..., 0][labels == k]) for k in (1, 2))
    assert blood > 2.5 * wall  # bright blood against a dark myocardium, tags and noise aside
    assert not (folder / "frames").exists()
    with pytest.raises(CohortError, match="tagging: only with images='cine'"):
        write_cycle_cohort(cycles, tmp_path / "x", "labels", tagging=TagGrid())
    with pytest.raises(CohortError, match="images: expected one of"):
        write_cycle_cohort(cycles, tmp_path / "x", "movie")


@pytest.mark.parametrize("given, axes", [([], [0, 1]), (["2d"], [0, 1]), (["3d"], [0, 1, 2])])
def test_cli_tagging_across_the_long_axis(tmp_path, given, axes):
    out = tmp_path / "cohort"
    argv = ["cohort", "--cycle", "3", "--subjects", "2", "--vertices", "241", "-o", str(out),
            "--images", "cine", "--voxel", "4,4", "--tagging", *given]  # fmt: skip
    assert main(argv) == 0
    assert json.loads((out / "cycle.json").read_text())["tagging"]["axes"] == axes


def test_cli_writes_the_cycle_cohort_and_refuses_what_it_cannot_do(tmp_path, capsys):
    out = tmp_path / "cohort"
    argv = ["cohort", "--cycle", "5", "--subjects", "6", "--vertices", "241", "-o", str(out)]
    assert main(argv + ["--voxel", "2,6"]) == 0
    text = capsys.readouterr().out
    assert "through 5 frames" in text and "planted: hypokinesia" in text
    assert len(list((out / "images").glob("*.nii.gz"))) == 6
    assert json.loads((out / "cycle.json").read_text())["voxel_mm"] == [2.0, 2.0, 6.0]
    for extra, message in ((["--pose"], "--pose: not with --cycle"),
                           (["--remesh", "2"], "--remesh: not with --cycle"),
                           (["--ext", "ply"], "--ext: not with --cycle"),
                           (["--noise-length", "5"], "--noise-length: not with --cycle"),
                           (["--tagging"], "--tagging: only with --images cine"),
                           (["--tagging", "3d"], "--tagging: only with --images cine"),
                           (["--voxel", "2"], "expected IN_PLANE,THICKNESS")):  # fmt: skip
        assert main(argv + extra) == 2
        assert message in capsys.readouterr().err


def test_cli_writes_the_ed_landmarks_that_correspond_reads(tmp_path, capsys):
    """``--landmarks`` with ``--cycle``: one row per subject (and the atlas's), the apex and
    septal point on the subject's true ED surface and near its ED label image's, the apex
    the ED point farthest from the base along the long axis, the base-plane centre on the
    base's height; ``correspond --landmarks`` reads the table and, the turn about the long
    axis fixed, gives back every subject's ED vertices in its own frame."""
    from ladders.study.preparation.landmarks import read_landmarks

    out, thickness = tmp_path / "cohort", 6.0
    argv = ["cohort", "--cycle", "3", "--subjects", "2", "--vertices", "241", "--voxel",
            f"2,{thickness:g}", "--landmarks", "-o", str(out)]  # fmt: skip
    assert main(argv) == 0
    assert f"landmarks: {out / 'landmarks.csv'}" in capsys.readouterr().out
    table = read_landmarks(out / "landmarks.csv")
    names = sorted(p.name.removesuffix("_ed.vtk") for p in out.glob("*_ed.vtk"))
    assert len(names) == 2 and list(table) == ["atlas", *names]
    assert json.loads((out / "cycle.json").read_text())["landmarks"] == "landmarks.csv"
    for name in names:
        lm = table[name]
        ed, faces = read_mesh(out / f"{name}_ed.vtk")
        frame0, _ = read_mesh(out / "frames" / name / "frame_00.vtk")
        assert np.allclose(ed, frame0, atol=1e-6)  # the ED mesh is the ED image's surface
        on = distances_to_surface(np.stack([lm.apex, lm.septum]), ed, faces)
        assert on.max() < 1e-3  # mm: on the true ED surface
        height = (ed - lm.apex) @ lm.long_axis
        assert height.min() > -1e-6  # no ED point lies beyond the apex, seen from the base
        assert abs(height.max() - np.linalg.norm(lm.base - lm.apex)) < 0.5  # the base's height
        series = read_label_series(out / "images" / f"{name}.nii.gz")
        vertices, image_faces, _ = extract_surface(series[0], 1)
        near = distances_to_surface(np.stack([lm.apex, lm.septum]), vertices, image_faces)
        assert near.max() < thickness / 2  # in the ED label image's world frame
    cor = tmp_path / "corresponded"
    argv = ["correspond", "--atlas", str(out / "atlas.vtk"), "--meshes", str(out), "-o",
            str(cor), "--landmarks", str(out / "landmarks.csv"), "--jobs", "1", "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    assert f"landmarks {out / 'landmarks.csv'}" in capsys.readouterr().out
    for name in names:
        record = json.loads((cor / "correspondence" / f"{name}.json").read_text())
        assert np.allclose(record["landmarks"]["subject"], table[name].as_array())
        back = np.linalg.inv(np.asarray(record["transform"]["matrix"]))
        v, _ = read_mesh(cor / f"{name}_ed.vtk")
        truth, _ = read_mesh(out / f"{name}_ed.vtk")
        error = np.linalg.norm(v @ back[:3, :3].T + back[:3, 3] - truth, axis=1)
        assert error.mean() < 1.0  # mm: vertex i is the same material point again
