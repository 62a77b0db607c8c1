"""Apex, base and septal point from a right-ventricle label: accuracy under a pose, the batch, the CLI."""

import csv
import json
from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from ladders.study.cohort.synthetic_lv import make_synthetic_cohort
from ladders.study.imaging import (
    ImageError,
    LabelImage,
    MeshingSettings,
    extract_surface,
    mesh_label_images,
    short_axis_affine,
    voxelize,
    write_label_image,
)
from ladders.study.imaging.rv_label import add_rv_label, voxel_centres
from ladders.study.imaging.septum import label_centroid, landmarks_from_labels, lv_apex_and_base
from ladders.study.imaging.surface_extraction import _shifted_plane
from ladders.study.meshes import read_mesh
from ladders.study.preparation.landmarks import axial_angle, check_landmarks, read_landmarks
from ladders.study.volume import boundary_vertices

from .cli_runner import run_cli

COHORT = make_synthetic_cohort(n_subjects=3, n_vertices=241, seed=3)
RIM = boundary_vertices(COHORT.faces)
assert (RIM == np.arange(len(COHORT.atlas) - len(RIM), len(COHORT.atlas))).all()  # the last ring
SPACING = 2.0  # mm, the voxel of the accuracy tests
POSES = {
    "identity": (Rotation.identity(), [0.0, 0.0, 0.0]),
    "oblique": (Rotation.from_euler("zyx", [35.0, -50.0, 20.0], degrees=True), [12.0, -7.0, 30.0]),
    "upside down": (Rotation.from_euler("xz", [150.0, -110.0], degrees=True), [-20.0, 15.0, 5.0]),
}


def _angle(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.degrees(np.arccos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1))))  # fmt: skip


def _section_centre(ring):
    """The centroid of the polygon ``ring`` (in order, in a plane ``z`` = constant)."""
    x, y = ring[:, 0], ring[:, 1]
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    area = cross.sum() / 2.0
    cx = ((x + np.roll(x, -1)) * cross).sum() / (6.0 * area)
    cy = ((y + np.roll(y, -1)) * cross).sum() / (6.0 * area)
    return np.array([cx, cy, ring[0, 2]])


def _orthogonal(u, axis):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return u - (u @ axis) * axis


def grid_around(points, spacing=(SPACING, SPACING, SPACING), tilt=20.0, margin=28.0):
    """``(affine, shape)`` of an oblique stack covering ``points`` with ``margin`` mm around."""
    affine = short_axis_affine([0.0, 0.0, 0.0], spacing[0], spacing[2], tilt_deg=tilt)
    affine[:3, :3] = affine[:3, :3] @ np.diag([1.0, spacing[1] / spacing[0], 1.0])
    index = (np.asarray(points) - affine[:3, 3]) @ np.linalg.inv(affine[:3, :3]).T
    pad = margin / np.asarray(spacing)
    low = np.floor(index.min(axis=0) - pad)
    shape = tuple(int(n) for n in np.ceil(index.max(axis=0) + pad) - low + 1)
    affine[:3, 3] = affine[:3, :3] @ low
    return affine, shape


class Posed:
    """One frame of a cohort subject moved by ``rotation`` and ``shift``, with its truth."""

    def __init__(self, vertices, rotation: Rotation, shift):
        self.rotation = rotation.as_matrix()
        self.shift = np.asarray(shift, float)
        self.vertices = vertices @ self.rotation.T + self.shift
        self.apex = self.vertices[0]  # the model's apex is vertex 0, at the origin
        self.base = self.rotation @ _section_centre(vertices[RIM]) + self.shift  # of the base
        self.top = self.rotation @ [0.0, 0.0, vertices[:, 2].max()] + self.shift
        self.axis = self.rotation @ [0.0, 0.0, 1.0]
        self.septum = self.rotation @ [-1.0, 0.0, 0.0]  # the cohort's septum is at -x

    @property
    def plane(self) -> tuple:
        """The valve plane: through the base, normal along the long axis towards the base."""
        return (*self.top, *self.axis)

    def image(self, spacing=(SPACING, SPACING, SPACING), tilt=20.0, rv_turn=0.0, grid=None):
        """``(labels, affine)``: the cavity (label 1) and an RV (label 2) on an oblique grid.

        ``rv_turn`` turns the RV about the long axis (degrees, from the septum); ``grid``
        is ``(affine, shape)`` (default: :func:`grid_around` the mesh).
        """
        affine, shape = grid or grid_around(self.vertices, spacing, tilt)
        labels = voxelize(self.vertices, COHORT.faces, affine, shape, label=1)
        turn = Rotation.from_rotvec(np.radians(rv_turn) * self.axis).as_matrix()
        labels = add_rv_label(labels, affine, self.apex, self.top, turn @ self.septum)
        return labels, affine


def _landmarks(posed: Posed, labels, affine, path="case_ed.nii.gz", n_vertices=1500,
               septum="insertion"):  # fmt: skip
    """The landmarks of the meshed cavity (``septum``: one way, or a tuple of ways, each
    taken from the same mesh), the mesh and the plane it was cut at."""
    image = LabelImage(np.asarray(labels, np.int64), affine, Path(path))
    settings = MeshingSettings(n_vertices=n_vertices, cut_plane=posed.plane)
    v, f, _ = extract_surface(image, 1, settings)
    plane = _shifted_plane(settings, affine)
    found = [landmarks_from_labels(v, f, image, 2, cut_plane=plane, septum=way)
             for way in ((septum,) if isinstance(septum, str) else septum)]  # fmt: skip
    return (found[0] if isinstance(septum, str) else found), v, f, plane


@pytest.mark.parametrize("pose", list(POSES))
@pytest.mark.parametrize("subject, phase", [(0, "ed"), (1, "es"), (2, "ed")])
def test_the_landmarks_follow_the_pose(pose, subject, phase):
    """On 2 mm voxels: septum within 1.5 degrees (3.5 by the RV's centroid), long axis
    within 2.5, apex within 2 voxels.

    Measured over the nine cases: septum 0.1-1.1 degrees by the insertion points'
    bisector, 0.2-2.0 by the RV's centroid; long axis 0.1-1.3 degrees, apex 0.4-2.0 mm,
    base-plane centre 1.3-1.5 mm from the base section's centre (mostly along the axis:
    the mesh is cut half a voxel below the valve plane).
    """
    s = COHORT.subjects[subject]
    posed = Posed(getattr(s, phase), *POSES[pose])
    labels, affine = posed.image()
    (lm, by_centroid), v, f, plane = _landmarks(posed, labels, affine, septum=("insertion", "centroid"))  # fmt: skip
    assert _angle(lm.long_axis, posed.base - posed.apex) < 2.5
    assert _angle(lm.septal_direction, _orthogonal(posed.septum, lm.long_axis)) < 1.5
    assert _angle(by_centroid.septal_direction, _orthogonal(posed.septum, lm.long_axis)) < 3.5
    np.testing.assert_array_equal(by_centroid.apex, lm.apex)  # only the septum differs
    assert np.linalg.norm(lm.apex - posed.apex) < 2 * SPACING
    # the base-plane centre: on the plane the mesh was cut at, within a voxel of the truth
    assert abs((lm.base - plane[:3]) @ np.asarray(plane[3:])) < 1e-9
    assert np.linalg.norm(lm.base - posed.base) < SPACING
    # the apex and the septal point lie on the mesh; the septal point at mid-height
    check_landmarks(lm, v, f, tolerance=1e-6, name="case")
    height = (lm.septum - lm.apex) @ lm.long_axis / np.linalg.norm(lm.base - lm.apex)
    assert height == pytest.approx(0.5, abs=1e-9)


@pytest.mark.parametrize("turn", [90.0, -60.0, 180.0])
def test_the_septal_direction_is_where_the_rv_is(turn):
    """The same LV with its RV turned about the long axis: the septal direction turns with it.

    Measured: within 0.6-0.8 degree of the turn (0.7-1.0 by the RV's centroid).
    """
    posed = Posed(COHORT.subjects[0].ed, *POSES["oblique"])
    both, *_ = _landmarks(posed, *posed.image(rv_turn=turn), septum=("insertion", "centroid"))
    for lm, tolerance in zip(both, (1.5, 3.5)):
        measured = axial_angle(lm.septal_direction, posed.septum, posed.axis)
        assert (measured - turn + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=tolerance)


def test_an_rv_thicker_on_one_side_moves_its_centroid_but_not_its_insertion_points():
    """More RV on one side of the septum (a second, thicker crescent over half the sector):
    the RV's edges, and so the bisector of its insertion points, stay; its centroid turns
    toward the thicker side.

    Measured: the bisector 0.69 degrees from the septum before, 0.62 after; the centroid's
    direction 1.8 before, 19.7 after.
    """
    posed = Posed(COHORT.subjects[0].ed, *POSES["oblique"])
    labels, affine = posed.image()
    side = Rotation.from_rotvec(np.radians(35.0) * posed.axis).as_matrix() @ posed.septum
    lopsided = add_rv_label(labels, affine, posed.apex, posed.top, side, wall=6.0,
                            thickness=22.0, half_angle=30.0)  # fmt: skip
    assert (lopsided == 2).sum() > 1.5 * (labels == 2).sum()

    def turns(rv_labels):  # of the two septal directions about the true axis, in degrees
        both = _landmarks(posed, rv_labels, affine, septum=("insertion", "centroid"))[0]
        return [axial_angle(lm.septal_direction, posed.septum, posed.axis) for lm in both]

    (before, centroid_before), (after, centroid_after) = turns(labels), turns(lopsided)
    assert abs(after) < 1.5 and abs(after - before) < 0.5
    assert 4.0 < centroid_after - centroid_before < 35.0  # toward the thicker side


def test_thick_slices_keep_the_septum_within_5_degrees():
    """A short-axis stack of 1.5 x 1.5 x 8 mm voxels along the long axis, tilted by 10 degrees.

    Measured: septum 3.1-3.2 degrees, long axis 0.1-3.6 degrees, apex 3.8-4.9 mm (the
    centre of a flat cap, up to half a slice from the true apex).
    """
    for subject, pose in ((0, "identity"), (1, "oblique"), (2, "upside down")):
        rotation, shift = POSES[pose]
        posed = Posed(COHORT.subjects[subject].es, Rotation.identity(), [0.0, 0.0, 0.0])
        labels, affine = posed.image(spacing=(1.5, 1.5, 8.0), tilt=10.0)
        # pose the image through its affine: the world moves, the voxels stay
        move = np.eye(4)
        move[:3, :3], move[:3, 3] = rotation.as_matrix(), shift
        moved = Posed(COHORT.subjects[subject].es, rotation, shift)
        lm, *_ = _landmarks(moved, labels, move @ affine)
        unmoved, *_ = _landmarks(posed, labels, affine)  # the landmarks move with the image
        np.testing.assert_allclose(lm.as_array(), unmoved.as_array() @ move[:3, :3].T + shift, atol=1e-6)  # fmt: skip
        assert _angle(lm.septal_direction, _orthogonal(moved.septum, lm.long_axis)) < 5.0
        assert _angle(lm.long_axis, moved.base - moved.apex) < 5.0
        assert np.linalg.norm(lm.apex - moved.apex) < 8.0  # within one slice


def test_the_rv_label_lies_against_the_septum_without_overlap():
    posed = Posed(COHORT.subjects[0].ed, *POSES["oblique"])
    labels, affine = posed.image()
    rv, lv = labels == 2, labels == 1
    assert rv.sum() > 500 and lv.sum() == (voxelize(posed.vertices, COHORT.faces, affine, labels.shape) == 1).sum()  # fmt: skip
    centres = voxel_centres(affine, labels.shape)
    gap = trimesh.Trimesh(posed.vertices, COHORT.faces, process=False)
    _, distance, _ = trimesh.proximity.closest_point(gap, centres[rv.ravel()])
    # the septal wall: 6 mm from the LV's voxel centres, which are within a voxel diagonal
    # of its surface (measured: 4.4 to 15.8 mm from the surface)
    assert 6.0 - np.sqrt(3) * SPACING < distance.min() and distance.max() < 16.0 + np.sqrt(3) * SPACING  # fmt: skip
    image = LabelImage(labels.astype(np.int64), affine, Path("x.nii.gz"))
    toward = _orthogonal(label_centroid(image, 2) - posed.apex, posed.axis)
    assert _angle(toward, _orthogonal(posed.septum, posed.axis)) < 3.0  # measured: 1.9
    with pytest.raises(ValueError, match="no voxel has the LV label 4"):
        add_rv_label(labels, affine, posed.apex, posed.top, posed.septum, lv_label=4, rv_label=5)
    with pytest.raises(ValueError, match="septal_direction: parallel"):
        add_rv_label(labels, affine, posed.apex, posed.top, posed.axis)
    with pytest.raises(ValueError, match="rv_label: must differ"):
        add_rv_label(labels, affine, posed.apex, posed.top, posed.septum, rv_label=1)


def test_an_absent_rv_or_one_on_the_axis_is_refused_naming_the_file_and_the_label():
    posed = Posed(COHORT.atlas, Rotation.identity(), [0.0, 0.0, 0.0])
    labels, affine = posed.image()
    image = LabelImage(np.where(labels == 2, 0, labels).astype(np.int64), affine, Path("c3_ed.nii.gz"))  # fmt: skip
    v, f, _ = extract_surface(image, 1, MeshingSettings(n_vertices=800, cut_plane=posed.plane))
    with pytest.raises(ImageError, match=r"^c3_ed.nii.gz: RV label 2 is absent \(no voxels\); labels present: \[1\]$"):  # fmt: skip
        landmarks_from_labels(v, f, image, 2)
    # an RV all around the LV (a full ring): its centroid is on the long axis
    ring = add_rv_label(image.labels, affine, posed.apex, posed.top, [1.0, 0, 0], half_angle=180)
    around = LabelImage(ring, affine, Path("ring.nii.gz"))
    with pytest.raises(ImageError, match="ring.nii.gz: RV label 2: the centroid of the RV lies on the LV's long axis"):  # fmt: skip
        landmarks_from_labels(v, f, around, 2)
    with pytest.raises(ValueError, match="rv_label: expected an int"):
        landmarks_from_labels(v, f, around, 2.0)
    with pytest.raises(ValueError, match="septum: expected one of"):
        landmarks_from_labels(v, f, image, 2, septum="middle")
    # nearly all around (340 degrees): a centroid off the axis, but no insertion points
    wide = add_rv_label(image.labels, affine, posed.apex, posed.top, [1.0, 0, 0], half_angle=170)
    nearly = LabelImage(wide, affine, Path("wide.nii.gz"))
    with pytest.raises(ImageError, match=r"wide.nii.gz: RV label 2: the RV goes round the LV's long axis over 3[3-6]\d degrees: no insertion points"):  # fmt: skip
        landmarks_from_labels(v, f, nearly, 2)
    assert landmarks_from_labels(v, f, nearly, 2, septum="centroid").septum.shape == (3,)


def test_a_closed_mesh_is_oriented_by_its_wider_end():
    """Without a cut plane the label's lid closes the mesh: the base is still found."""
    posed = Posed(COHORT.subjects[1].ed, *POSES["upside down"])
    labels, affine = posed.image()
    image = LabelImage(labels.astype(np.int64), affine, Path("x.nii.gz"))
    v, f, report = extract_surface(image, 1, MeshingSettings(n_vertices=1500))
    assert report.closed
    apex, base = lv_apex_and_base(v, f)
    assert np.linalg.norm(apex - posed.apex) < SPACING
    assert _angle(base - apex, posed.base - posed.apex) < 3.5
    lm = landmarks_from_labels(v, f, image, 2)
    assert _angle(lm.septal_direction, _orthogonal(posed.septum, lm.long_axis)) < 3.5


def _cohort_images(folder: Path) -> tuple[dict, Path]:
    """ED and ES images of the three subjects (the third without an RV), and a cut-plane table."""
    folder.mkdir(parents=True)
    truth, rows = {}, []
    for s, pose in zip(COHORT.subjects, POSES):
        frames = {phase: Posed(getattr(s, phase), *POSES[pose]) for phase in ("ed", "es")}
        grid = grid_around(np.vstack([p.vertices for p in frames.values()]), (2.0, 2.0, 3.0))
        for phase, posed in frames.items():
            labels, affine = posed.image(grid=grid)
            if s.name == "synthetic_002":
                labels = np.where(labels == 2, 0, labels)
            name = f"{s.name}_{phase}.nii.gz"
            write_label_image(folder / name, labels, affine)
            rows.append([name, *posed.plane])
            truth[s.name, phase] = posed
    table = folder.parent / "planes.csv"
    with open(table, "w", newline="") as fh:
        csv.writer(fh).writerows([["image", "x", "y", "z", "nx", "ny", "nz"], *rows])
    return truth, table


@pytest.fixture(scope="module")
def meshed(tmp_path_factory):
    root = tmp_path_factory.mktemp("septum")
    truth, planes = _cohort_images(root / "images")
    images = sorted((root / "images").iterdir())
    argv = ["mesh", *images, "--label", "1", "--rv-label", "2", "--cut-planes", planes,
            "-o", root / "meshes", "--vertices", "1200", "--jobs", "1", "--no-progress"]  # fmt: skip
    return root, truth, images, planes, run_cli(*argv), run_cli(*argv)


def test_the_cli_writes_the_landmark_table(meshed):
    root, truth, _, _, (status, out, err), _ = meshed
    assert status == 1  # the subject without an RV failed, the others are meshed
    failures = [ln for ln in err.splitlines() if ln.startswith("symladders mesh: failed")]
    assert len(failures) == 2 and all("RV label 2 is absent" in ln for ln in failures)
    assert "synthetic_002_ed.nii.gz" in failures[0] and "synthetic_002_es.nii.gz" in failures[1]
    assert f"landmarks of 2 subject(s) (apex, base, septum, from the ED meshes) in {root / 'meshes' / 'landmarks.csv'}" in out  # fmt: skip
    table = read_landmarks(root / "meshes" / "landmarks.csv")
    assert list(table) == ["synthetic_000", "synthetic_001"]
    assert not (root / "meshes" / "synthetic_002_ed.vtk").exists()
    for name, lm in table.items():
        posed = truth[name, "ed"]
        assert _angle(lm.septal_direction, _orthogonal(posed.septum, lm.long_axis)) < 5.0
        assert _angle(lm.long_axis, posed.base - posed.apex) < 5.0
        # the base-plane centre lies on the valve plane given, not on the plane the cut's
        # margin moved half a voxel below it, where the mesh's rim is
        point, normal = np.array(posed.plane[:3]), np.array(posed.plane[3:])
        normal /= np.linalg.norm(normal)
        assert abs((lm.base - point) @ normal) < 1e-6
        mesh_v, mesh_f = read_mesh(root / "meshes" / f"{name}_ed.vtk")
        assert ((mesh_v[boundary_vertices(mesh_f)] - point) @ normal).mean() < -1.0
        record = json.loads((root / "meshes" / f"{name}_ed.json").read_text())
        assert record["rv_label"] == 2
        np.testing.assert_allclose(record["landmarks"]["septum"], lm.septum, atol=1e-8)
        es = json.loads((root / "meshes" / f"{name}_es.json").read_text())["landmarks"]
        posed_es = truth[name, "es"]
        axis = np.subtract(es["base"], es["apex"])
        radial = _orthogonal(np.subtract(es["septum"], es["apex"]), axis)
        assert _angle(radial, _orthogonal(posed_es.septum, axis)) < 5.0
    with open(root / "meshes" / "meshing.csv") as fh:
        rows = {r["mesh"]: r for r in csv.DictReader(fh)}
    assert rows["synthetic_002_ed.vtk"]["status"] == "failed"
    assert "\n" not in rows["synthetic_002_ed.vtk"]["error"]


def test_a_rerun_reuses_the_meshes_and_keeps_their_landmarks(meshed):
    root, _, images, planes, (_, _, _), (status, out, _) = meshed
    assert status == 1 and "0 mesh(es) written, 4 already done, 2 failed" in out
    assert list(read_landmarks(root / "meshes" / "landmarks.csv")) == ["synthetic_000", "synthetic_001"]  # fmt: skip
    # without an RV label the same meshes are reused (no table); another RV label is not reused
    kwargs = dict(output=root / "meshes", settings=MeshingSettings(n_vertices=1200), jobs=1, progress=False)  # fmt: skip
    rows = list(csv.reader(planes.read_text().splitlines()))[1:]
    cuts = {r[0]: tuple(map(float, r[1:])) for r in rows}
    plain = mesh_label_images(images, 1, cut_planes=cuts, **kwargs)
    assert [r["status"] for r in plain.records].count("skipped") == 4
    assert plain.landmarks_file is None and plain.landmarks == {}
    again = mesh_label_images(images, 1, cut_planes=cuts, rv_label=2, **kwargs)
    assert set(again.landmarks) == {"synthetic_000", "synthetic_001"}
    # the septum taken another way is not reused, and the record says which way
    centroid = mesh_label_images(images, 1, cut_planes=cuts, rv_label=2, rv_septum="centroid",
                                 **kwargs)  # fmt: skip
    assert [r["status"] for r in centroid.records].count("ok") == 4
    assert json.loads((root / "meshes" / "synthetic_000_ed.json").read_text())["rv_septum"] == "centroid"  # fmt: skip
    back = mesh_label_images(images, 1, cut_planes=cuts, rv_label=2, **kwargs)
    assert [r["status"] for r in back.records].count("ok") == 4
    for name in again.landmarks:
        np.testing.assert_allclose(back.landmarks[name].as_array(), again.landmarks[name].as_array())  # fmt: skip
        assert not np.allclose(centroid.landmarks[name].septum, again.landmarks[name].septum)
    other = mesh_label_images(images[:2], 1, cut_planes=cuts, rv_label=3, **kwargs)
    assert [r["status"] for r in other.records] == ["failed", "failed"]
    assert "RV label 3 is absent" in other.records[0]["error"]
    # the table: no row for the image that failed now, the row of the mesh left untouched
    table = read_landmarks(root / "meshes" / "landmarks.csv")
    assert list(table) == ["synthetic_001"]
    np.testing.assert_allclose(table["synthetic_001"].as_array(), again.landmarks["synthetic_001"].as_array())  # fmt: skip


def test_rv_label_usage_errors(tmp_path):
    labels = np.zeros((8, 8, 8), np.int16)
    labels[2:6, 2:6, 2:6] = 1
    path = write_label_image(tmp_path / "a_ed.nii.gz", labels, np.eye(4))
    status, _, err = run_cli("mesh", path, "--label", "1", "--rv-label", "1", "-o", tmp_path / "o")
    assert status == 2 and "--rv-label 1: the right ventricle's label must differ" in err
    with pytest.raises(ValueError, match="rv_label: must differ"):
        mesh_label_images([path], 1, tmp_path / "o", rv_label=1, progress=False)
    with pytest.raises(ValueError, match="rv_label: expected an int"):
        mesh_label_images([path], 1, tmp_path / "o", rv_label="2", progress=False)
    with pytest.raises(ValueError, match="rv_septum: expected one of"):
        mesh_label_images([path], 1, tmp_path / "o", rv_label=2, rv_septum="mean", progress=False)  # fmt: skip
    status, _, err = run_cli("mesh", path, "--label", "1", "--rv-label", "2", "--rv-septum",
                             "mean", "-o", tmp_path / "o")  # fmt: skip
    assert status == 2 and "--rv-septum" in err
    assert not (tmp_path / "o").exists()  # refused before any output
