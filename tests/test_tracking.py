"""``symladders track`` against the truth: a synthetic ventricle's label series of known motion.

The subject's true ED surface is the ED mesh (it is in correspondence with its own
truth); its label series is rendered from the known motion on a 2 mm grid, and every
tracked frame is compared with the true moved vertices (``motion_forward``). The
error is split along the true surface's normals (what a surface shows) and along the
wall (what it does not show: the twist above all): the normal part must be a
fraction of a voxel, and the tracked mesh must match the true motion without its
twist within a voxel: what is left along the wall is the twist and the non-affine
part of the motion along the wall, which no surface shows.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from ladders.study.cohort import cycle_fraction, make_synthetic_cohort, motion_forward
from ladders.study.imaging import (
    LabelImage,
    MeshingSettings,
    extract_surface,
    read_label_image,
    render_labels,
    short_axis_affine,
    write_label_image,
    write_series,
)
from ladders.study.meshes import read_mesh, write_mesh
from ladders.study.preparation.alignment import SimilarityTransform
from ladders.study.tracking import (
    SeriesError,
    TrackingSettings,
    check_field_of_view,
    combine_weight,
    find_series,
    open_series,
    track_cohort,
    track_surfaces,
)
from ladders.study.wall_motion import outward_vertex_normals

from .cli_runner import run_cli

VOXEL = 2.0  # mm
N_FRAMES = 5
MESHING = MeshingSettings(n_vertices=800)
#: Normal error of the tracked vertices: a quarter of a voxel (the surfaces' own accuracy).
NORMAL_TOL = 0.25 * VOXEL
#: Error against the true motion without its twist: a voxel (what the surfaces resolve); the
#: rest along the wall is the non-affine motion along it, which no surface shows either.
UNTWISTED_TOL = 1.0 * VOXEL


@pytest.fixture(scope="module")
def subject():
    """The subject, its grid, its frames (labels, true vertices, valve planes, surfaces)."""
    cohort = make_synthetic_cohort(1, n_vertices=241)
    s = cohort.subjects[0]
    params, faces, ed = s.parameters, cohort.faces, np.asarray(s.ed, float)
    low, high = ed.min(0) - 15.0, ed.max(0) + 6.0
    shape = tuple(int(n) for n in np.ceil((high - low) / VOXEL))
    affine = short_axis_affine(low, VOXEL, VOXEL)
    fractions = [float(cycle_fraction(t / N_FRAMES)) for t in range(N_FRAMES)]
    truth = [motion_forward(params, ed, f) for f in fractions]
    untwisted = dataclasses.replace(params, apex_rotation=0.0, base_rotation=0.0)
    labels = [render_labels(params, affine, shape, f) for f in fractions]
    planes = {str(t): (0.0, 0.0, float(v[:, 2].max()), 0.0, 0.0, 1.0) for t, v in enumerate(truth)}
    return {
        "params": params, "faces": faces, "ed": ed, "affine": affine, "shape": shape,
        "fractions": fractions, "truth": truth, "labels": labels, "planes": planes,
        "untwisted": [motion_forward(untwisted, ed, f) for f in fractions],
    }  # fmt: skip


@pytest.fixture(scope="module")
def surfaces(subject, tmp_path_factory):
    path = write_series(tmp_path_factory.mktemp("series") / "s.nii.gz", subject["labels"],
                        subject["affine"])  # fmt: skip
    out = []
    for t in range(N_FRAMES):
        settings = dataclasses.replace(MESHING, cut_plane=subject["planes"][str(t)])
        v, f, _ = extract_surface(read_label_image(path, t), 1, settings)
        out.append((v, f))
    return out


def _errors(subject, tracked, t):
    """Mean normal and tangential error at frame ``t`` (mm), and against the untwisted truth."""
    true = subject["truth"][t]
    error = tracked[t] - true
    normals = outward_vertex_normals(true, subject["faces"])
    normal = np.einsum("kd,kd->k", error, normals)
    tangential = np.linalg.norm(error - normal[:, None] * normals, axis=1)
    untwisted = np.linalg.norm(tracked[t] - subject["untwisted"][t], axis=1)
    return np.abs(normal).mean(), tangential.mean(), untwisted.mean()


@pytest.fixture(scope="module")
def chain(subject, surfaces):
    return track_surfaces(subject["ed"], subject["faces"], surfaces,
                          TrackingSettings(refine_ed=False))  # fmt: skip


@pytest.fixture(scope="module")
def refined(subject, surfaces):
    return track_surfaces(subject["ed"], subject["faces"], surfaces,
                          TrackingSettings(refine_ed=True))  # fmt: skip


def test_projection_recovers_the_normal_motion_and_all_but_the_twist(subject, chain):
    assert chain.vertices.shape == (N_FRAMES, len(subject["ed"]), 3)
    assert chain.vertices.dtype == np.float64
    es = int(np.argmax(subject["fractions"]))
    motion = np.linalg.norm(subject["truth"][es] - subject["ed"], axis=1).mean()
    normal, tangential, untwisted = _errors(subject, chain.vertices, es)
    print(f"ES (frame {es}): motion {motion:.2f}, normal error {normal:.2f}, tangential "
          f"{tangential:.2f}, against the untwisted truth {untwisted:.2f} mm")  # fmt: skip
    assert normal < NORMAL_TOL
    assert untwisted < UNTWISTED_TOL and untwisted < tangential  # the twist is missed
    assert tangential < 0.3 * motion  # most of the motion along the wall is recovered
    for t in range(N_FRAMES):
        assert _errors(subject, chain.vertices, t)[0] < NORMAL_TOL


def test_tracked_meshes_stay_on_the_frame_surfaces(chain):
    for t, q in enumerate(chain.quality):
        assert q["mean_distance"] < 0.05 * VOXEL if t else q["mean_distance"] < 0.25 * VOXEL
        if t:
            assert q["hit_fraction"] > 0.85 and q["kept_faces"] > 0.5


def test_refine_ed_limits_the_drift_at_the_last_frame(subject, chain, refined):
    last = N_FRAMES - 1
    plain = np.linalg.norm(chain.vertices[last] - subject["truth"][last], axis=1).mean()
    better = np.linalg.norm(refined.vertices[last] - subject["truth"][last], axis=1).mean()
    print(f"last frame: error {plain:.2f} frame to frame, {better:.2f} with refine_ed")
    assert better <= plain
    assert _errors(subject, refined.vertices, last)[0] < NORMAL_TOL
    q = refined.quality[last]
    assert q["weight_ed"] == combine_weight(last, N_FRAMES) and q["drift_rms"] > 0
    assert q["mean_distance"] < 0.05 * VOXEL


def _normal_motion_error(subject, tracked):
    """Mean absolute error of the normal motion from frame 0, frames 1.. (mm)."""
    true, faces = subject["truth"], subject["faces"]
    normals = outward_vertex_normals(true[0], faces)
    return np.array([
        np.abs(np.einsum("kd,kd->k", (tracked[t] - tracked[0]) - (true[t] - true[0]), normals)).mean()
        for t in range(1, N_FRAMES)
    ])  # fmt: skip


def test_project_ed_measures_the_motion_between_surfaces_extracted_alike(subject, surfaces):
    """An ED mesh 0.5 mm off the frames' surfaces (corresponded on another extraction): moved
    onto frame 0's surface first, its offset stays out of the motion; kept, it is in every frame."""
    ed, faces = subject["ed"], subject["faces"]
    offset = ed + 0.5 * outward_vertex_normals(ed, faces)
    kept = track_surfaces(offset, faces, surfaces,
                          TrackingSettings(project_ed=False, refine_ed=False))  # fmt: skip
    moved = track_surfaces(offset, faces, surfaces, TrackingSettings(refine_ed=False))
    assert np.array_equal(kept.vertices[0], offset)
    assert moved.quality[0]["mean_distance"] < 1e-6
    assert abs(moved.quality[0]["onto_surface_rms"] - 0.5) < 0.25 * VOXEL
    with_offset, without = (
        _normal_motion_error(subject, kept.vertices),
        _normal_motion_error(subject, moved.vertices),
    )
    print(f"normal motion error per frame: {np.round(with_offset, 2)} kept, "
          f"{np.round(without, 2)} moved onto frame 0's surface")  # fmt: skip
    assert (with_offset > 0.3).all()  # the offset, in every frame
    assert (without < with_offset - 0.2).all() and (without < NORMAL_TOL).all()


def test_registration_follows_the_surfaces(subject, surfaces):
    settings = TrackingSettings(method="registration", refine_ed=False)
    out = track_surfaces(subject["ed"], subject["faces"], surfaces[:2], settings)
    for t in (1,):
        assert out.quality[t]["mean_distance"] < 0.25 * VOXEL
        assert _errors(subject, out.vertices, t)[0] < NORMAL_TOL


def test_track_surfaces_refuses_a_surface_far_from_the_mesh(subject, surfaces):
    v, f = surfaces[1]
    with pytest.raises(ValueError, match="frame 1: the mesh is farther than crop_distance"):
        track_surfaces(subject["ed"], subject["faces"], [surfaces[0], (v + 60.0, f)])


# bad input: one line naming the culprit ------------------------------------------------


def _labels(shape=(6, 6, 6)):
    labels = np.zeros(shape, np.int16)
    labels[2:4, 2:4, 2:4] = 1
    return labels


def test_a_3d_image_is_not_a_series(tmp_path):
    path = write_label_image(tmp_path / "case.nii.gz", _labels(), np.eye(4))
    with pytest.raises(SeriesError, match=r"case.nii.gz: a 3-D image, not a series"):
        open_series(path)


def test_missing_and_duplicated_frames_are_named(tmp_path):
    for t in (0, 1, 3):
        write_label_image(tmp_path / "gap" / f"frame_{t:02d}.nii.gz", _labels(), np.eye(4))
    with pytest.raises(SeriesError, match=r"gap: frame\(s\) 2 missing"):
        open_series(tmp_path / "gap")
    for name in ("frame_00", "frame_1", "frame_01"):
        write_label_image(tmp_path / "dup" / f"{name}.nii.gz", _labels(), np.eye(4))
    with pytest.raises(SeriesError, match=r"dup: frame 1 given twice"):
        open_series(tmp_path / "dup")


def test_frames_on_different_grids_are_refused(tmp_path):
    shifted = np.eye(4)
    shifted[:3, 3] = 1.0
    write_label_image(tmp_path / "s" / "frame_00.nii.gz", _labels(), np.eye(4))
    write_label_image(tmp_path / "s" / "frame_01.nii.gz", _labels(), shifted)
    with pytest.raises(SeriesError, match=r"frame_01.nii.gz: its grid differs from frame_00"):
        open_series(tmp_path / "s")
    series = open_series(write_series(tmp_path / "ok.nii.gz", [_labels()] * 2, np.eye(4)))
    assert series.n_frames == 2 and series.frame(1).frame == 1


def test_all_frames_read_at_once_equal_the_frames_read_one_by_one(tmp_path):
    moved = np.roll(_labels(), 1, axis=0)
    for name in ("four_d.nii.gz", "folder"):
        if name == "folder":
            for t, labels in enumerate((_labels(), moved, _labels())):
                write_label_image(tmp_path / name / f"frame_{t:02d}.nii.gz", labels, np.eye(4))
        else:
            write_series(tmp_path / name, [_labels(), moved, _labels()], np.eye(4))
        series = open_series(tmp_path / name)
        frames = series.frames()
        assert [f.frame for f in frames] == [0, 1, 2]
        for t, image in enumerate(frames):
            np.testing.assert_array_equal(image.labels, series.frame(t).labels)
            np.testing.assert_array_equal(image.affine, series.frame(t).affine)
        np.testing.assert_array_equal(frames[1].labels, moved)


def test_an_ed_mesh_outside_the_field_of_view_is_refused(tmp_path, subject):
    series = open_series(
        write_series(tmp_path / "s.nii.gz", subject["labels"][:2], subject["affine"])
    )
    check_field_of_view(subject["ed"], series)
    with pytest.raises(
        SeriesError, match=r"ED mesh: 241 of 241 vertices lie outside the field of view"
    ):
        check_field_of_view(subject["ed"] + 500.0, series)


def test_two_series_for_one_subject(tmp_path):
    write_series(tmp_path / "a.nii.gz", [_labels()] * 2, np.eye(4))
    write_label_image(tmp_path / "a" / "frame_00.nii.gz", _labels(), np.eye(4))
    assert "two series" in find_series(tmp_path)["a"]


# the batch: resumable, a failing subject recorded ---------------------------------------


def test_track_cohort_records_failures_and_resumes(tmp_path, subject):
    meshes, images, out = tmp_path / "meshes", tmp_path / "images", tmp_path / "tracked"
    meshes.mkdir()
    labels = subject["labels"][:3]
    # "good" was corresponded: its mesh is in the atlas's frame, its record has the transform
    turn = np.radians(30.0)
    rotation = np.array(
        [[np.cos(turn), -np.sin(turn), 0], [np.sin(turn), np.cos(turn), 0], [0, 0, 1]]
    )
    transform = SimilarityTransform(rotation, np.array([5.0, -3.0, 2.0]))
    (meshes / "correspondence").mkdir()
    (meshes / "correspondence" / "good.json").write_text(
        json.dumps({"transform": transform.as_dict()})
    )
    write_mesh(meshes / "good_ed.vtk", transform.apply(subject["ed"]), subject["faces"])
    for name in ("absent", "lonely"):
        write_mesh(meshes / f"{name}_ed.vtk", subject["ed"], subject["faces"])
    write_series(images / "good.nii.gz", labels, subject["affine"])
    broken = [lab.copy() for lab in labels]
    broken[2][broken[2] == 1] = 2
    write_series(images / "absent.nii.gz", broken, subject["affine"])
    settings = TrackingSettings(meshing=MESHING, refine_ed=False)
    planes = {"good": subject["planes"]}
    outcome = track_cohort(meshes, images, out, 1, settings, cut_planes=planes, jobs=1,
                           progress=False)  # fmt: skip
    status = {r["subject"]: r for r in outcome.records}
    assert status["good"]["status"] == "ok" and status["good"]["frames"] == 3
    assert "frame 2: label 1 is absent" in status["absent"]["error"]
    assert "no label series" in status["lonely"]["error"]
    assert sorted(p.name for p in (out / "good").iterdir()) == [f"frame_0{t}.vtk" for t in range(3)]
    assert not (out / "absent").exists()
    frame0, frame2 = (read_mesh(out / "good" / f"frame_0{t}.vtk")[0] for t in (0, 2))
    given = transform.apply(subject["ed"])  # frame 0: the ED mesh moved onto its surface,
    assert np.linalg.norm(frame0 - given, axis=1).mean() < 0.25 * VOXEL  # in the atlas's frame
    error = np.linalg.norm(transform.inverse().apply(frame2) - subject["truth"][2], axis=1).mean()
    motion = np.linalg.norm(subject["truth"][2] - subject["ed"], axis=1).mean()
    assert error < 0.3 * motion
    record = json.loads((out / "good.json").read_text())
    assert record["status"] == "ok" and len(record["quality"]) == 3 and record["versions"]
    assert record["fingerprint"]["series_sha256"] and record["settings"]["method"] == "projection"
    assert record["base_anchors"] is True  # a plane for every frame: the base's height anchored
    csv = (out / "tracking.csv").read_text().splitlines()
    assert csv[0] == "subject,status,frames,mean_distance,error" and len(csv) == 4
    again = track_cohort(
        meshes, images, out, 1, settings, cut_planes=planes, jobs=1, progress=False
    )
    assert {r["subject"]: r["status"] for r in again.records}["good"] == "skipped"


def test_the_command_tracks_and_names_the_broken_subject(tmp_path, subject):
    meshes, images, out = tmp_path / "meshes", tmp_path / "images", tmp_path / "out"
    meshes.mkdir()
    for name in ("good", "flat"):
        write_mesh(meshes / f"{name}_ed.vtk", subject["ed"], subject["faces"])
    write_series(images / "good.nii.gz", subject["labels"][:3], subject["affine"])
    write_label_image(images / "flat.nii.gz", subject["labels"][0], subject["affine"])
    table = tmp_path / "planes.csv"
    table.write_text("image,frame,x,y,z,nx,ny,nz\n" + "".join(
        f"good,{t},{','.join(str(x) for x in p)}\n" for t, p in subject["planes"].items()
        if int(t) < 3))  # fmt: skip
    argv = ("track", meshes, images, "--label", 1, "-o", out, "--vertices", 800,
            "--cut-planes", table, "--jobs", 1, "--no-progress")  # fmt: skip
    status, stdout, stderr = run_cli(*argv)
    assert status == 1, stderr
    assert "1 tracked" in stdout and "1 failed" in stdout
    assert "flat" in stderr and "a 3-D image, not a series" in stderr
    assert len(list((out / "good").glob("frame_*.vtk"))) == 3
    status, stdout, _ = run_cli(*argv)
    assert status == 1 and "1 already done" in stdout
    status, _, stderr = run_cli("track", meshes, images, "-o", out)
    assert status == 2 and "--label" in stderr


#: Short-axis slices for the valve-plane anchors: the base's height falls within a slice.
SLICE = 8.0


def _basal_bias(subject, tracked, es_fraction):
    """Mean error along the long axis (mm) at ES of the basal tenth of the tracked vertices."""
    truth = motion_forward(subject["params"], tracked[0], es_fraction)
    height = subject["ed"][:, 2] / subject["params"].long_axis
    return float((tracked[1] - truth)[height > 0.9, 2].mean())


@pytest.fixture(scope="module")
def slice_offsets(subject):
    """ED and ES of the subject on stacks of 8 mm slices shifted by 0, 2, 4 and 6 mm: the
    basal bias along the long axis at ES without and with the true valve planes."""
    es = int(np.argmax(subject["fractions"]))
    frames = (0, es)
    planes = np.array([subject["planes"][str(t)] for t in frames])
    ed = subject["ed"]
    out = {"plain": [], "anchored": []}
    for offset in (0.0, 2.0, 4.0, 6.0):
        low = ed.min(0) - np.array([15.0, 15.0, 15.0 + offset])
        affine = short_axis_affine(low, VOXEL, SLICE)
        shape = tuple(int(n) for n in np.ceil((ed.max(0) + 6.0 - low) / [VOXEL, VOXEL, SLICE]))
        surfaces = []
        for t, plane in zip(frames, planes):
            labels = render_labels(subject["params"], affine, shape, subject["fractions"][t])
            settings = dataclasses.replace(MESHING, cut_plane=tuple(plane))
            v, f, _ = extract_surface(LabelImage(labels, affine, Path("synthetic")), 1, settings)
            surfaces.append((v, f))
        for key, base in (("plain", None), ("anchored", planes)):
            tracked = track_surfaces(ed, subject["faces"], surfaces,
                                     TrackingSettings(refine_ed=False), base_planes=base)  # fmt: skip
            out[key].append(_basal_bias(subject, tracked.vertices, subject["fractions"][es]))
    return {k: np.array(v) for k, v in out.items()}


def test_valve_planes_anchor_the_base_whatever_the_slices(slice_offsets):
    """On 8 mm slices the rim of a frame's surface lies at a slice's edge, below the base:
    without the valve planes in the fit the rim pulls the basal vertices down; with the
    true plane of every frame the base follows its true height wherever the slices fall."""
    plain, anchored = slice_offsets["plain"], slice_offsets["anchored"]
    print(f"basal bias along the axis at ES (mm): plain {plain.round(2)}, anchored "
          f"{anchored.round(2)}")  # fmt: skip
    assert np.abs(plain).min() > 2.0
    assert np.abs(anchored).max() < 1.0


def test_bad_base_planes_are_named(subject, surfaces):
    ed, faces = subject["ed"], subject["faces"]
    good = np.array([subject["planes"][str(t)] for t in range(N_FRAMES)])
    for planes, match in (
        (good[:2], "expected one plane .* per frame"),
        (np.where(np.arange(6) == 2, np.nan, good), "not finite"),
        (np.c_[good[:, :3], np.zeros((N_FRAMES, 3))], "frame 0: the normal is zero"),
    ):
        with pytest.raises(ValueError, match="base_planes: " + match):
            track_surfaces(ed, faces, surfaces, TrackingSettings(), base_planes=planes)
    with pytest.raises(ValueError, match="base_planes: only with method='projection'"):
        track_surfaces(ed, faces, surfaces, TrackingSettings(method="registration"),
                       base_planes=good)  # fmt: skip
