"""Study preparation: alignment, units, correspondence of a folder of segmentations, atlas."""

import json

import numpy as np
import pytest

from ladders.study import read_cohort, write_mesh
from ladders.study.cohort.synthetic_lv import make_synthetic_cohort
from ladders.study.preparation import (
    CorrespondenceSettings,
    SimilarityTransform,
    UnitsError,
    check_units_and_pose,
    correspond_cohort,
    correspond_mesh,
    estimate_atlas,
    icp_align,
    meshes_correspond,
    procrustes,
    random_rigid_transform,
    remesh,
    surface_distances,
    vertex_error_components,
)
from ladders.study.preparation.correspondence import QUALITY_DISTANCES
from manifolds.lddmm import RegistrationSettings

from .vtp_writer import vtp_bytes

FAST = CorrespondenceSettings(
    registration=RegistrationSettings(sigma=20.0, control_points="grid", max_iter=100, ftol=1e-8),
    sigma_w=8.0,
)


@pytest.fixture(scope="module")
def cohort():
    return make_synthetic_cohort(3, n_vertices=150, seed=0)


def rms(a, b):
    return float(np.sqrt(((a - b) ** 2).sum(1).mean()))


# ------------------------------------------------------------------ alignment
@pytest.mark.parametrize("scale", [False, True])
def test_procrustes_recovers_a_known_motion(scale, cohort):
    rng = np.random.default_rng(0)
    motion = random_rigid_transform(rng, 180.0, 100.0)
    if scale:
        motion = SimilarityTransform(motion.rotation, motion.translation, 1.7)
    est = procrustes(cohort.atlas, motion.apply(cohort.atlas), scale=scale)
    np.testing.assert_allclose(est.matrix, motion.matrix, atol=1e-8)
    assert np.linalg.det(est.rotation) > 0


def test_procrustes_never_returns_a_reflection(cohort):
    mirrored = cohort.atlas * [1, 1, -1]
    est = procrustes(cohort.atlas, mirrored)
    np.testing.assert_allclose(np.linalg.det(est.rotation), 1.0)


def test_transform_algebra_and_round_trip():
    rng = np.random.default_rng(1)
    a, b = random_rigid_transform(rng, 90, 5), random_rigid_transform(rng, 90, 5)
    pts = rng.standard_normal((10, 3))
    np.testing.assert_allclose(a.compose(b).apply(pts), a.apply(b.apply(pts)), atol=1e-12)
    np.testing.assert_allclose(a.inverse().apply(a.apply(pts)), pts, atol=1e-12)
    back = SimilarityTransform.from_dict(json.loads(json.dumps(a.as_dict())))
    np.testing.assert_allclose(back.matrix, a.matrix, atol=1e-14)
    with pytest.raises(ValueError, match="matrix"):
        SimilarityTransform.from_matrix(np.diag([1.0, 1.0, -1.0, 1.0]))


def test_icp_recovers_a_rigid_motion_of_a_remeshed_copy():
    subject = make_synthetic_cohort(1, n_vertices=400, seed=3).subjects[0]
    faces = make_synthetic_cohort(0, n_vertices=400).faces
    v, f = remesh(subject.ed, faces, 1500)
    motion = random_rigid_transform(np.random.default_rng(2), 180.0, 80.0)
    est, distance = icp_align(motion.apply(v), f, subject.ed, faces)
    # the subject's harmonics make it asymmetric: the motion is determined
    error = est.compose(motion)
    assert error.rotation_angle() < 1.0 and np.linalg.norm(error.translation) < 0.5
    assert distance < 0.2


# ------------------------------------------------------------------ units
def test_units_in_metres_are_detected_and_named(cohort):
    meshes = {
        s.name: {"ed": (s.ed, cohort.faces), "es": (s.es, cohort.faces)} for s in cohort.subjects
    }
    meshes["synthetic_001"] = {p: (v * 1e-3, f) for p, (v, f) in meshes["synthetic_001"].items()}
    with pytest.raises(UnitsError, match=r"synthetic_001:ed: size .*likely in m\b"):
        check_units_and_pose(cohort.atlas, cohort.faces, meshes)
    report = check_units_and_pose(cohort.atlas, cohort.faces, meshes, units="auto")
    assert report.factors == {"synthetic_000": 1.0, "synthetic_001": 1000.0, "synthetic_002": 1.0}
    assert report.assumed_units["synthetic_001"] == "m"
    check_units_and_pose(cohort.atlas, cohort.faces, meshes, allow_scale=True)
    with pytest.raises(UnitsError, match="units"):
        check_units_and_pose(cohort.atlas, cohort.faces, meshes, units="inch")


def test_a_centimetre_cohort_and_a_far_pose_are_refused(cohort):
    s = cohort.subjects[0]
    cm = {s.name: {"ed": (s.ed / 10, cohort.faces)}}
    with pytest.raises(UnitsError, match="likely in cm"):
        check_units_and_pose(cohort.atlas, cohort.faces, cm)
    moved = random_rigid_transform(np.random.default_rng(0), 0.0, 0.0)
    far = {s.name: {"ed": (moved.apply(s.ed) + [500.0, 0, 0], cohort.faces)}}
    with pytest.raises(UnitsError, match="far from the atlas's pose"):
        check_units_and_pose(cohort.atlas, cohort.faces, far)
    check_units_and_pose(cohort.atlas, cohort.faces, far, allow_pose=True)


# ------------------------------------------------------------------ correspondence
def test_correspond_mesh_lands_the_atlas_on_the_surface(cohort):
    s = cohort.subjects[0]
    v, f = remesh(s.ed, cohort.faces, 500)
    out = correspond_mesh(
        cohort.atlas, cohort.faces, v, f, FAST, transform=SimilarityTransform.identity()
    )
    before = surface_distances(cohort.atlas, cohort.faces, v, f)
    q = out.quality
    assert out.vertices.shape == cohort.atlas.shape
    assert q["distance_after"] < 0.2 * q["distance_before"]
    assert q["mean_surface_distance"] < 0.25 * before["mean_surface_distance"]
    assert rms(out.vertices, s.ed) < 0.6 * rms(cohort.atlas, s.ed)


@pytest.fixture(scope="module")
def segmentations(cohort, tmp_path_factory):
    """The cohort remeshed, moved rigidly, one subject in metres, and one unreadable subject."""
    root = tmp_path_factory.mktemp("segmentations")
    src = root / "seg"
    src.mkdir()
    rng = np.random.default_rng(0)
    motions = {}
    for i, s in enumerate(cohort.subjects):
        motions[s.name] = random_rigid_transform(rng, 180.0, 50.0)
        factor = 1e-3 if i == 1 else 1.0
        for phase, v in (("ed", s.ed), ("es", s.es)):
            rv, rf = remesh(v, cohort.faces, 400)
            write_mesh(src / f"{s.name}_{phase}.ply", motions[s.name].apply(rv) * factor, rf)
    for phase in ("ed", "es"):
        (src / f"broken_{phase}.ply").write_text("not a mesh")
    write_mesh(root / "atlas.vtk", cohort.atlas, cohort.faces)
    return root, motions


def test_correspond_cohort_writes_what_the_study_reads(cohort, segmentations):
    root, motions = segmentations
    with pytest.raises(UnitsError, match="synthetic_001"):
        correspond_cohort(root / "atlas.vtk", root / "seg", root / "out", FAST)
    seen = []
    out = correspond_cohort(root / "atlas.vtk", root / "seg", root / "out", FAST, units="auto",
                            progress=lambda i, n, name, rec: seen.append((i, n, name)))  # fmt: skip
    assert out.failed == ["broken"] and len(out.computed) == 4 and seen[-1][:2] == (4, 4)
    assert out.units["synthetic_001"] == "m"
    corresponded = read_cohort(root / "out")  # the atlas, ED and ES in correspondence
    assert [s.name for s in corresponded.subjects] == [s.name for s in cohort.subjects]
    for s, original in zip(corresponded.subjects, cohort.subjects):
        record = json.loads((root / "out" / "correspondence" / f"{s.name}.json").read_text())
        assert record["status"] == "ok" and record["unit_factor"] in (1.0, 1000.0)
        for phase in ("ed", "es"):
            assert record[phase]["mean_surface_distance"] < 0.6  # mm, on 150-vertex meshes
        # the recorded transform maps the input (in mm) onto the corresponded meshes' frame
        transform = SimilarityTransform.from_dict(record["transform"])
        ed_in = transform.apply(motions[s.name].apply(original.ed))
        assert (
            surface_distances(s.ed, cohort.faces, ed_in, cohort.faces)["mean_surface_distance"]
            < 0.6
        )
    quality = (root / "out" / "quality.csv").read_text().splitlines()
    assert quality[1].startswith('broken,ed,failed,True,"MeshFolderError')
    assert len(quality) == 1 + 2 * 4


def test_correspond_cohort_resumes(segmentations):
    root, _ = segmentations
    out = correspond_cohort(root / "atlas.vtk", root / "seg", root / "out", FAST, units="auto")
    assert sorted(out.reused) == ["synthetic_000", "synthetic_001", "synthetic_002"]
    assert out.computed == ["broken"]  # failed subjects are retried
    # other thresholds of inspection reuse every result and flag again from their quality
    strict = FAST.replace(flag_hausdorff=1e-9, flag_mean_distance=1e-9)
    flagged = correspond_cohort(
        root / "atlas.vtk", root / "seg", root / "out", strict, units="auto"
    )
    assert sorted(flagged.reused) == sorted(out.reused)
    assert all(r["flagged"] for r in flagged.quality if r["status"] == "ok")
    other = FAST.replace(sigma_w=7.0)
    again = correspond_cohort(root / "atlas.vtk", root / "seg", root / "out", other, units="auto")
    assert again.reused == []


def test_a_reused_record_of_an_older_quality_gets_the_current_distances(segmentations):
    root, _ = segmentations
    args = (root / "atlas.vtk", root / "seg", root / "out", FAST)
    correspond_cohort(*args, units="auto")
    path = root / "out" / "correspondence" / "synthetic_000.json"
    record = json.loads(path.read_text())
    expected = {p: {k: record[p][k] for k in QUALITY_DISTANCES} for p in ("ed", "es")}
    for phase in ("ed", "es"):  # as written before the rim-aware distances
        del record[phase]["beyond_rim_fraction"]
        record[phase]["hausdorff"] = -1.0
    path.write_text(json.dumps(record))
    again = correspond_cohort(*args, units="auto")
    assert sorted(again.reused) == ["synthetic_000", "synthetic_001", "synthetic_002"]
    stored = json.loads(path.read_text())
    for phase in ("ed", "es"):
        for k in QUALITY_DISTANCES:  # from the stored meshes (written in float32)
            assert stored[phase][k] == pytest.approx(expected[phase][k], abs=1e-4), (phase, k)
    rows = [r for r in again.quality if r["subject"] == "synthetic_000"]
    assert [r["hausdorff"] for r in rows] == pytest.approx(
        [expected[r["phase"]]["hausdorff"] for r in rows], abs=1e-4
    )


def test_any_atlas_format_and_a_failure_leaves_no_earlier_meshes(cohort, tmp_path):
    s = cohort.subjects[0]
    (tmp_path / "seg").mkdir()
    for phase, v in (("ed", s.ed), ("es", s.es)):
        write_mesh(tmp_path / "seg" / f"{s.name}_{phase}.obj", *remesh(v, cohort.faces, 400))
    (tmp_path / "atlas.vtp").write_bytes(vtp_bytes(cohort.atlas, cohort.faces, points_type="f8"))
    out = correspond_cohort(tmp_path / "atlas.vtp", tmp_path / "seg", tmp_path / "out", FAST)
    assert out.failed == [] and out.flagged == []  # .vtp is read, not written: .vtk instead
    assert sorted(p.name for p in (tmp_path / "out").glob("*.vtk")) == [
        "atlas.vtk", f"{s.name}_ed.vtk", f"{s.name}_es.vtk"
    ]  # fmt: skip
    (tmp_path / "seg" / f"{s.name}_ed.obj").write_text("not a mesh")  # the input changes
    again = correspond_cohort(tmp_path / "atlas.vtp", tmp_path / "seg", tmp_path / "out", FAST)
    assert again.failed == [s.name] and again.flagged == [f"{s.name} ed", f"{s.name} es"]
    assert not list((tmp_path / "out").glob(f"{s.name}_*"))  # the study cannot read stale ones


def test_without_alignment_the_pose_is_checked(cohort, segmentations, tmp_path):
    root, _ = segmentations
    settings = FAST.replace(alignment="none")
    with pytest.raises(UnitsError, match="far from the atlas's pose"):
        correspond_cohort(root / "atlas.vtk", root / "seg", tmp_path, settings, units="auto")


# ------------------------------------------------------------------ atlas
def test_atlas_of_corresponding_meshes_is_their_karcher_mean(cohort):
    meshes = [(s.ed, cohort.faces) for s in cohort.subjects]
    res = estimate_atlas(meshes, FAST, initial="mean", tol=0.05, max_iter=8)
    assert res.corresponding and res.converged, res.message
    assert res.gradient_norms[-1] < res.gradient_norms[0]
    assert res.objectives[-1] <= res.objectives[0]
    mean = np.mean(
        [procrustes(s.ed, cohort.subjects[0].ed).apply(s.ed) for s in cohort.subjects], 0
    )
    assert rms(res.vertices, mean) < 2.0  # near the mean shape, not at a subject


@pytest.mark.filterwarnings("ignore::manifolds.errors.ConvergenceWarning")
def test_atlas_of_remeshed_meshes_approaches_the_generating_template(cohort):
    rng = np.random.default_rng(5)
    meshes = []
    for s in cohort.subjects:
        v, f = remesh(s.ed, cohort.faces, 400)
        meshes.append((random_rigid_transform(rng, 30.0, 10.0).apply(v), f))
    start = (cohort.subjects[0].ed, cohort.faces)
    res = estimate_atlas(meshes, FAST, initial=start, tol=0.05, max_iter=4)
    assert not res.corresponding and len(res.objectives) == res.n_iter + 1
    assert res.objectives[-1] < res.objectives[0]
    mean_start = np.mean([rms(start[0], s.ed) for s in cohort.subjects])
    mean_atlas = np.mean([
        surface_distances(res.vertices, cohort.faces, s.ed, cohort.faces)["mean_surface_distance"]
        for s in cohort.subjects
    ])  # fmt: skip
    assert mean_atlas < mean_start


@pytest.mark.filterwarnings("ignore::manifolds.errors.ConvergenceWarning")
def test_atlas_surface_term_on_request_and_its_iterates(cohort):
    meshes = [(s.ed, cohort.faces) for s in cohort.subjects]
    seen = []
    res = estimate_atlas(meshes, FAST, max_iter=1, surface_term=True,
                         checkpoint=lambda it, v: seen.append((it, v.shape)))  # fmt: skip
    assert not res.corresponding and seen == [(0, cohort.atlas.shape), (1, cohort.atlas.shape)]
    v, f = remesh(cohort.subjects[0].ed, cohort.faces, 300)
    with pytest.raises(ValueError, match="surface_term: False needs meshes"):
        estimate_atlas([*meshes, (v, f)], surface_term=False)
    assert meshes_correspond(meshes) and not meshes_correspond([*meshes, (v, f)])


def test_atlas_bad_input():
    with pytest.raises(ValueError, match="no mesh"):
        estimate_atlas([])
    c = make_synthetic_cohort(2, n_vertices=150, seed=0)
    v, f = remesh(c.subjects[0].ed, c.faces, 300)
    with pytest.raises(ValueError, match="'mean' needs meshes in correspondence"):
        estimate_atlas([(c.subjects[1].ed, c.faces), (v, f)], initial="mean")


def test_vertex_error_splits_a_twist_and_an_inflation():
    import trimesh

    sphere = trimesh.creation.icosphere(3)
    truth, faces = 10.0 * np.asarray(sphere.vertices), np.asarray(sphere.faces)
    # an inflation moves every vertex along its normal by 0.1
    inflated = vertex_error_components(truth, 1.01 * truth, faces)
    assert abs(inflated["total"] - 0.1) < 1e-12
    assert abs(inflated["normal"] - 0.1) < 1e-3 and inflated["tangential"] < 5e-3
    # a small twist about z slides vertices along the surface, circumferentially
    angle = 0.01
    rot = np.array(
        [[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]]
    )
    twisted = vertex_error_components(truth, truth @ rot.T, faces)
    assert twisted["normal"] < 0.01 * twisted["total"]
    assert abs(twisted["circumferential"] - twisted["tangential"]) < 1e-3 * twisted["total"]
    for parts in (inflated, twisted):
        assert np.isclose(parts["normal"] ** 2 + parts["tangential"] ** 2, parts["total"] ** 2)
