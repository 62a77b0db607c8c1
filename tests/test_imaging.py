"""Label images to meshes: accuracy on analytic shapes, the world frame, bad inputs, batches."""

import csv
import hashlib
import json
from dataclasses import replace

import nibabel as nib
import numpy as np
import pytest
import trimesh

from ladders.convergence import loglog_slope
from ladders.study.cli import main
from ladders.study.imaging import (
    ImageError,
    LabelImage,
    MeshingSettings,
    extract_surface,
    mesh_label_images,
    read_label_image,
    short_axis_affine,
    voxelize,
    write_label_image,
)
from ladders.study.preparation.surface_distance import surface_distances
from ladders.study.volume import enclosed_volume

SPHERE = trimesh.creation.icosphere(4, radius=12.0)


def _grid(h: float, half: float = 16.0):
    n = int(np.ceil(2 * half / h))
    affine = np.diag([h, h, h, 1.0])
    affine[:3, 3] = -half + h / 2
    return affine, (n, n, n)


def _mesh_of(vertices, faces, affine, shape, settings, path="x.nii.gz"):
    from pathlib import Path

    labels = voxelize(vertices, faces, affine, shape, label=3)
    return extract_surface(LabelImage(labels.astype(np.int64), affine, Path(path)), 3, settings)


def test_the_error_shrinks_with_the_voxel_at_a_measured_order():
    spacings, errors, volumes = [2.0, 1.0, 0.5], [], []
    for h in spacings:
        affine, shape = _grid(h)
        settings = MeshingSettings(n_vertices=None)  # mask smoothing of half a voxel
        v, f, report = _mesh_of(SPHERE.vertices, SPHERE.faces, affine, shape, settings)
        assert report.closed and report.non_manifold_edges == 0
        errors.append(
            surface_distances(v, f, SPHERE.vertices, SPHERE.faces)["mean_surface_distance"]
        )
        volumes.append(abs(enclosed_volume(v, f) / SPHERE.volume - 1))
    slope = loglog_slope(np.array(spacings), np.array(errors))
    assert slope > 0.8, (errors, slope)  # first order or better in the voxel size
    assert errors[-1] < 0.1 and volumes[-1] < 0.01


def test_ellipsoid_volume_at_1mm():
    ellipsoid = trimesh.creation.icosphere(4, radius=1.0)
    axes = np.array([14.0, 9.0, 6.0])
    v = ellipsoid.vertices * axes
    affine, shape = _grid(1.0)
    mesh_v, mesh_f, report = _mesh_of(
        v, ellipsoid.faces, affine, shape, MeshingSettings(n_vertices=None)
    )
    exact = 4.0 / 3.0 * np.pi * axes.prod()
    assert enclosed_volume(mesh_v, mesh_f) == pytest.approx(exact, rel=0.02)
    assert abs(report.shrinkage) < 0.01  # Taubin smoothing keeps the volume


@pytest.mark.parametrize("tilt, flip", [(0.0, False), (25.0, False), (25.0, True)])
def test_a_mesh_comes_back_where_the_affine_puts_it(tmp_path, tilt, flip):
    rotation = trimesh.transformations.rotation_matrix(0.4, [1.0, 2.0, 0.5])[:3, :3]
    placed = SPHERE.vertices * [1.0, 0.8, 1.3] @ rotation.T + [40.0, -25.0, 10.0]
    affine = short_axis_affine(
        [40.0 - 20 * (-1 if flip else 1), -45.0, -10.0], 1.0, 1.5, tilt, flip
    )
    affine[:3, 3] = placed.mean(axis=0) - affine[:3, :3] @ np.array([20.0, 20.0, 14.0])
    labels = voxelize(placed, SPHERE.faces, affine, (40, 40, 28), label=7)
    path = write_label_image(tmp_path / "placed.nii.gz", labels, affine)
    image = read_label_image(path)
    np.testing.assert_allclose(image.affine, affine, atol=1e-5)
    v, f, report = extract_surface(image, 7, MeshingSettings(n_vertices=1500))
    d = surface_distances(v, f, placed, SPHERE.faces)
    assert d["mean_surface_distance"] < 0.3 and d["hausdorff"] < 2.0
    assert enclosed_volume(v, f) > 0  # outward normals, also through a flip
    assert report.n_vertices <= 1600


def _write(path, data, affine=None, codes=(1, 1)):
    img = nib.Nifti1Image(data, None)
    img.set_sform(np.eye(4) if affine is None else affine, code=codes[0])
    img.set_qform(None, code=0)
    if codes[1] and affine is None:
        img.set_qform(np.eye(4), code=codes[1])
    nib.save(img, str(path))
    return path


def test_the_cut_removes_the_lid_a_label_makes_at_its_base():
    """A half ball cut at z = 0 in 8 mm slices: its label ends with a lid below the base."""
    from ladders.study.imaging import close_surface, cut_at_plane

    base = (0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    open_v, open_f = cut_at_plane(SPHERE.vertices, SPHERE.faces, base)
    closed_v, closed_f = close_surface(open_v, open_f)
    # slice centres at z = -6 (inside) and +2 (outside): the lid falls near z = -2
    affine = short_axis_affine([-16.5, -16.5, -22.0], 1.5, 8.0)
    settings = MeshingSettings(n_vertices=None, cut_plane=base)

    def mesh(**changes):
        return _mesh_of(closed_v, closed_f, affine, (23, 23, 4), replace(settings, **changes))

    kept = mesh(cut_margin=0.0)  # the plane alone does not cross the surface
    assert kept[2].closed and kept[2].faces_cut == 0
    assert "does not cross" in kept[2].describe()
    former = mesh()  # the default: half a slice below the base
    v, f, report = mesh(cut_margin=0.0, lid_angle=45.0)  # the lid removed by its normals
    for mesh_ in (former, (v, f, report)):
        assert not mesh_[2].closed and mesh_[2].boundary_loops == 1 and mesh_[2].faces_cut > 0
    assert former[0][:, 2].max() <= -4.0 + 1.0
    # the lid removal keeps the wall up to the lid's rounded edge (the lid near z = -2)
    assert v[:, 2].max() > former[0][:, 2].max() + 1.0
    assert v[:, 2].max() < 0.0
    lid = surface_distances(kept[0], kept[1], open_v, open_f)
    cut = surface_distances(v, f, open_v, open_f)
    below = surface_distances(*former[:2], open_v, open_f)
    assert cut["mean_surface_distance"] < 0.8 * lid["mean_surface_distance"]
    # less of the true wall missing than with the margin (true surface to the mesh)
    assert cut["mean_b_to_a"] < below["mean_b_to_a"]


def test_lid_removal_keeps_a_wall_that_crosses_the_plane():
    """An open cylinder wall crossing the plane: nothing faces the plane, nothing goes but the cut."""
    from ladders.study.imaging import remove_lid

    angle = np.linspace(0.0, 2.0 * np.pi, 40, endpoint=False)
    z = np.linspace(-10.0, 0.0, 11)
    v = np.array([[10 * np.cos(a), 10 * np.sin(a), h] for h in z for a in angle])
    f = []
    for i in range(len(z) - 1):
        for j in range(40):
            a, b = i * 40 + j, i * 40 + (j + 1) % 40
            f += [[a, b, b + 40], [a, b + 40, a + 40]]
    f = np.array(f)
    out_v, out_f = remove_lid(v, f, (0, 0, 0, 0, 0, 1), depth=5.0, angle=45.0)
    assert len(out_f) == len(f) and len(out_v) == len(v)


def test_the_cut_margin_is_measured_along_the_normal_in_voxel_widths():
    from ladders.study.imaging.surface_extraction import _shifted_plane

    settings = MeshingSettings(cut_plane=(1.0, 2.0, 3.0, 0.0, 0.0, 2.0), cut_margin=0.5)
    stack = short_axis_affine([0.0, 0.0, 0.0], 1.5, 8.0)
    np.testing.assert_allclose(_shifted_plane(settings, stack), (1, 2, -1, 0, 0, 1))
    tilted = short_axis_affine([0.0, 0.0, 0.0], 1.5, 8.0, tilt_deg=30.0, flip=True)
    width = 1.5 * np.sin(np.radians(30)) + 8.0 * np.cos(np.radians(30))
    np.testing.assert_allclose(_shifted_plane(settings, tilted)[2], 3.0 - 0.5 * width)
    with pytest.raises(ValueError, match="cut_margin"):
        MeshingSettings(cut_margin=-1.0)
    with pytest.raises(ValueError, match="lid_angle"):
        MeshingSettings(lid_angle=90.0)
    with pytest.raises(ValueError, match="lid_depth"):
        MeshingSettings(lid_depth=float("nan"))


def test_bad_images_are_refused_naming_the_file(tmp_path):
    ball = np.zeros((12, 12, 12), np.int16)
    ball[3:9, 3:9, 3:9] = 2
    with pytest.raises(ImageError, match=r"label 5 is absent.*labels present: \[2\]"):
        extract_surface(read_label_image(_write(tmp_path / "a.nii.gz", ball)), 5)
    with pytest.raises(ImageError, match="not integers"):
        read_label_image(_write(tmp_path / "p.nii.gz", ball * 0.3))
    series = np.stack([ball, ball], axis=-1)
    with pytest.raises(ImageError, match="4-D series of 2 frames"):
        read_label_image(_write(tmp_path / "s.nii.gz", series))
    with pytest.raises(ImageError, match="frame 4 out of range"):
        read_label_image(tmp_path / "s.nii.gz", frame=4)
    assert read_label_image(tmp_path / "s.nii.gz", frame=1).frame == 1
    singular = np.diag([1.0, 1.0, 0.0, 1.0])
    with pytest.raises(ImageError, match="singular affine"):
        read_label_image(_write(tmp_path / "z.nii.gz", ball, singular))
    with pytest.raises(ImageError, match="no affine"):
        read_label_image(_write(tmp_path / "n.nii.gz", ball, codes=(0, 0)))
    (tmp_path / "broken.nii.gz").write_bytes(b"not an image")
    with pytest.raises(ImageError, match="broken.nii.gz: cannot be read"):
        read_label_image(tmp_path / "broken.nii.gz")


def test_a_batch_goes_on_past_a_failure_records_it_and_resumes(tmp_path):
    ball = np.zeros((16, 16, 16), np.int16)
    ball[4:12, 4:12, 4:12] = 1
    small = ball.copy()
    small[5:11, 5:11, 5:11] = 1
    small[4, :, :] = 0
    images = tmp_path / "images"
    images.mkdir()
    _write(images / "c1_ed.nii.gz", ball)
    _write(images / "c1_es.nii.gz", small)
    _write(images / "c2_ed.nii.gz", ball)
    _write(images / "c2_es.nii.gz", ball[:15])  # another grid than its ED
    _write(images / "c3_ed.nii.gz", ball * 2)  # label 1 absent
    _write(images / "c4.nii.gz", np.stack([ball, small, small], axis=-1))  # a 4-D series
    files = sorted(images.iterdir())
    out = mesh_label_images(files, 1, tmp_path / "meshes", frames=(0, 2), progress=False, jobs=1)
    status = {r["mesh"]: r["status"] for r in out.records}
    assert status == {"c1_ed.vtk": "ok", "c1_es.vtk": "ok", "c2_ed.vtk": "failed",
                      "c2_es.vtk": "failed", "c3_ed.vtk": "failed", "c4_ed.vtk": "ok",
                      "c4_es.vtk": "ok"}  # fmt: skip
    errors = {r["mesh"]: r["error"] for r in out.failed}
    assert "different grids" in errors["c2_es.vtk"] and "label 1 is absent" in errors["c3_ed.vtk"]
    record = json.loads((tmp_path / "meshes" / "c4_es.json").read_text())
    assert record["frame"] == 2 and record["label"] == 1 and record["spacing_mm"] == [1.0] * 3
    assert record["sha256"] == hashlib.sha256((images / "c4.nii.gz").read_bytes()).hexdigest()
    assert record["settings"] == MeshingSettings().as_dict()
    with open(tmp_path / "meshes" / "meshing.csv") as fh:
        assert len(list(csv.DictReader(fh))) == 7
    again = mesh_label_images(files, 1, tmp_path / "meshes", frames=(0, 2), progress=False, jobs=1)
    assert [r["status"] for r in again.records if r["status"] != "failed"] == ["skipped"] * 4
    # the command line: exit status 1 with the failures named, the other meshes written
    code = main(["mesh", *map(str, files), "--label", "1", "--frames", "0,2", "-o",
                 str(tmp_path / "cli"), "--no-progress", "--jobs", "1"])  # fmt: skip
    assert code == 1 and (tmp_path / "cli" / "c4_es.vtk").is_file()
    assert main(["mesh", str(images / "missing.nii.gz"), "--label", "1"]) == 2
    # the lid removal on the command line, recorded with the mesh; a bad angle refused
    lid = ["mesh", str(images / "c1_ed.nii.gz"), "--label", "1", "--cut-plane", "0,0,10,0,0,1",
           "--cut-margin", "0", "--lid-angle", "45", "-o", str(tmp_path / "lid"),
           "--no-progress", "--jobs", "1"]  # fmt: skip
    assert main(lid) == 0
    settings = json.loads((tmp_path / "lid" / "c1_ed.json").read_text())["settings"]
    assert settings["lid_angle"] == 45.0 and settings["cut_margin"] == 0.0
    assert main([*lid[:-6], "--lid-angle", "95", *lid[-4:]]) == 2
