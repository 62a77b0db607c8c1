"""Normal wall motion: analytic surface pairs, and the group test of the transported wall motion."""

import csv

import meshio
import numpy as np
import pytest
import trimesh

from ladders.statistics import detection_power, dice
from ladders.study.area_strain import area_strain
from ladders.study.cohort import make_synthetic_cohort
from ladders.study.population import (
    TransportedMotion,
    compare_groups,
    make_two_group_cohort,
    normalize_motion,
    score_transports,
    scores_csv,
    scores_markdown,
    write_analysis,
)
from ladders.study.population.analysis_outputs import plot_pvalue_map
from ladders.study.population.transported_motion import wall_motion_on_atlas
from ladders.study.volume import boundary_vertices, enclosed_volume
from ladders.study.wall_motion import normal_wall_motion, outward_vertex_normals


def _sphere(radius, subdivisions=3):
    mesh = trimesh.creation.icosphere(subdivisions, radius=1.0)
    return np.asarray(mesh.vertices, float) * radius, np.asarray(mesh.faces, np.int64)


def _inscribed_gap(vertices, faces, radius):
    """How far inside the sphere of ``radius`` the flat triangles of its inscribed mesh dip."""
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1)[:, None]
    return radius - np.abs(np.einsum("ij,ij->i", n, a)).min()


def _open_cap(vertices, faces, z_min):
    """The faces whose centroid lies above ``z_min``, without the vertices left unused."""
    keep = faces[vertices[faces].mean(axis=1)[:, 2] > z_min]
    used, new = np.unique(keep, return_inverse=True)
    return vertices[used], new.reshape(-1, 3)


def _brute_force(v, f, tv, tf, max_distance):
    """Every (vertex, triangle) pair intersected, the nearest facing hit kept: the definition."""
    n = outward_vertex_normals(v, f)
    a, b, c = (tv[tf[:, i]] for i in range(3))
    facing = n @ (np.cross(b - a, c - a) * np.sign(enclosed_volume(tv, tf))).T > 0
    shape = (len(v), len(tf), 3)
    d = np.broadcast_to(n[:, None, :], shape)
    e1, e2 = np.broadcast_to(b - a, shape), np.broadcast_to(c - a, shape)
    p = np.cross(d, e2)
    det = np.einsum("kfi,kfi->kf", e1, p)
    ok = np.abs(det) > 1e-12 * np.einsum("kfi,kfi->kf", e1, e1)
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = v[:, None, :] - a[None]
    q = np.cross(s, e1)
    u = np.einsum("kfi,kfi->kf", s, p) * inv
    w = np.einsum("kfi,kfi->kf", d, q) * inv
    t = np.einsum("kfi,kfi->kf", e2, q) * inv
    inside = ok & (u >= -1e-9) & (w >= -1e-9) & (u + w <= 1 + 1e-9)
    size = np.where(inside & facing & (np.abs(t) <= max_distance), np.abs(t), np.inf)
    nearest = np.argmin(size, axis=1)
    hit = np.isfinite(size.min(axis=1))
    return np.where(hit, t[np.arange(len(v)), nearest], np.nan), hit


# --- the measure on analytic pairs -------------------------------------------------------------


def test_concentric_spheres_move_by_the_difference_of_the_radii():
    """Sphere of radius 10 to one of radius 7 (another triangulation): ``t = 7 - 10``."""
    v, f = _sphere(10.0, 3)
    tv, tf = _sphere(7.0, 4)
    gap = _inscribed_gap(tv, tf, 7.0)  # the target's flat triangles lie up to this inside r
    assert 0 < gap < 0.01
    result = normal_wall_motion(v, f, tv, tf)
    assert result.hit.all() and result.hit_fraction == 1.0
    assert np.abs(result.distance - (7.0 - 10.0)).max() <= gap + 1e-3
    radius = np.linalg.norm(result.points, axis=1)  # the points lie on the target
    assert radius.min() >= 7.0 - gap - 1e-9 and radius.max() <= 7.0 + 1e-9
    assert np.allclose(result.distance, np.einsum("ij,ij->i", result.points - v, result.normals))
    # and back out: radius 7 to radius 10
    back = normal_wall_motion(tv, tf, v, f)
    assert np.abs(back.distance - 3.0).max() <= _inscribed_gap(v, f, 10.0) + 1e-3


def test_a_surface_offset_along_its_normals_moves_by_the_offset():
    v, f = _sphere(10.0, 3)
    ellipsoid = v * [1.0, 0.8, 1.6]
    normals = outward_vertex_normals(ellipsoid, f)
    for offset in (1.5, -1.5):
        result = normal_wall_motion(ellipsoid, f, ellipsoid + offset * normals, f)
        assert result.hit.all()
        np.testing.assert_allclose(result.distance, offset, atol=1e-9)
        np.testing.assert_allclose(result.points, ellipsoid + offset * normals, atol=1e-9)


def test_a_shifted_sphere_gives_the_analytic_distance_along_each_normal():
    """Sphere of radius R shifted by ``s``: ``t = s.u - R + sqrt(R^2 - |s|^2 + (s.u)^2)``."""
    v, f = _sphere(10.0, 4)
    shift = np.array([0.6, -0.3, 1.2])
    result = normal_wall_motion(v, f, v + shift, f)
    u = v / 10.0
    su = u @ shift
    expected = su - 10.0 + np.sqrt(100.0 - shift @ shift + su**2)
    assert result.hit.all()
    assert np.abs(result.distance - expected).max() <= _inscribed_gap(v, f, 10.0) + 1e-3
    pole = np.argmax(su)  # where the normal is along the shift, t is the shift's length
    assert abs(result.distance[pole] - np.linalg.norm(shift)) < 0.01


def test_orientation_of_either_mesh_does_not_matter():
    v, f = _sphere(10.0, 3)
    tv, tf = _sphere(8.5, 4)
    tv = tv * [1.0, 1.1, 0.9]
    reference = normal_wall_motion(v, f, tv, tf)
    for faces, target_faces in ((f, tf[:, ::-1]), (f[:, ::-1], tf), (f[:, ::-1], tf[:, ::-1])):
        other = normal_wall_motion(v, faces, tv, target_faces)
        np.testing.assert_allclose(other.distance, reference.distance, rtol=0, atol=1e-10)
        np.testing.assert_array_equal(other.hit, reference.hit)
        np.testing.assert_allclose(other.normals, reference.normals, atol=1e-12)


def test_the_opposite_wall_is_never_chosen_even_when_nearer():
    """A thin shell (outer radius 10.6, inner 9.8) around a sphere of radius 10: the inner
    wall is 0.2 inward, but it faces the other way; the outer wall, 0.6 outward, is the answer."""
    ov, of = _sphere(10.6, 4)
    iv, if_ = _sphere(9.8, 4)
    shell_v = np.vstack([ov, iv])
    shell_f = np.vstack([of, if_[:, ::-1] + len(ov)])  # inner wall facing the centre
    assert enclosed_volume(shell_v, shell_f) > 0
    v, f = _sphere(10.0, 3)
    result = normal_wall_motion(v, f, shell_v, shell_f)
    assert result.hit.all()
    assert np.abs(result.distance - 0.6).max() <= _inscribed_gap(ov, of, 10.6) + 1e-3
    # the closest point of the shell would have been the inner wall
    closest, _, _ = trimesh.proximity.closest_point(
        trimesh.Trimesh(shell_v, shell_f, process=False), v
    )
    assert np.linalg.norm(closest, axis=1).max() < 9.81
    # a shrunk ventricle: the far wall across the cavity is never taken either
    far = normal_wall_motion(v, f, 0.9 * v, f, max_distance=50.0)
    assert far.hit.all() and np.abs(far.distance + 1.0).max() < 0.01


def test_past_the_rim_of_an_open_target_the_closest_point_is_taken_and_marked():
    v, f = _sphere(10.0, 3)
    cup_v, cup_f = _open_cap(v, f, -5.0)  # open at the bottom
    tv, tf = _open_cap(*_sphere(9.0, 4), 2.0)  # a smaller cap: directions with z/|x| > ~0.22
    result = normal_wall_motion(cup_v, cup_f, tv, tf)
    height = cup_v[:, 2] / np.linalg.norm(cup_v, axis=1)
    assert not result.hit[height < 0.15].any()
    assert result.hit[height > 0.35].all()
    assert np.abs(result.distance[height > 0.35] + 1.0).max() < 0.01
    # a miss moves to the target's rim (the closest point of a cap seen from below it)
    rim = boundary_vertices(tf)
    edges = np.sort(np.concatenate([tf[:, [0, 1]], tf[:, [1, 2]], tf[:, [2, 0]]]), axis=1)
    edges, counts = np.unique(edges, axis=0, return_counts=True)
    edges = edges[counts == 1]
    assert set(edges.ravel()) == set(rim)
    a, b = tv[edges[:, 0]], tv[edges[:, 1]]
    for point in result.points[~result.hit]:
        s = np.clip(np.einsum("ei,ei->e", point - a, b - a) / ((b - a) ** 2).sum(1), 0, 1)
        assert np.min(np.linalg.norm(a + s[:, None] * (b - a) - point, axis=1)) < 1e-9
    np.testing.assert_allclose(
        result.distance, np.einsum("ij,ij->i", result.points - cup_v, result.normals), atol=1e-12
    )


def test_a_hit_far_beyond_the_closest_point_is_a_detour_and_takes_the_closest_point():
    """A sphere of radius 10 with a hole at its top, and a cap of radius 20 above it facing the
    same way: through the hole a normal line meets the far cap, about 10 away, while the hole's
    rim is about 2 away. With ``max_detour`` those vertices take the closest point."""
    v, f = _sphere(10.0, 3)
    keep = f[v[f].mean(axis=1)[:, 2] < 9.8]
    used, new = np.unique(keep, return_inverse=True)
    lower_v, lower_f = v[used], new.reshape(-1, 3)
    cap_v, cap_f = _open_cap(*_sphere(20.0, 4), 19.5)
    tv = np.vstack([lower_v, cap_v])
    tf = np.vstack([lower_f, cap_f + len(lower_v)])
    plain = normal_wall_motion(v, f, tv, tf, max_distance=15.0)
    guarded = normal_wall_motion(v, f, tv, tf, max_distance=15.0, max_detour=2.0)
    through = plain.hit & (np.abs(plain.distance) > 5.0)
    assert through.sum() >= 3 and np.abs(plain.distance[through] - 10.0).max() < 0.5
    gap = trimesh.proximity.closest_point(trimesh.Trimesh(tv, tf, process=False), v)[1]
    assert (gap[through] < 3.0).all()
    assert not guarded.hit[through].any()
    moved = np.linalg.norm(guarded.points - v, axis=1)  # the closest point (ties: any of them)
    np.testing.assert_allclose(moved[through], gap[through], atol=1e-9)
    np.testing.assert_array_equal(guarded.hit[~through], plain.hit[~through])
    np.testing.assert_allclose(guarded.points[~through], plain.points[~through], atol=1e-12)
    with pytest.raises(ValueError, match="max_detour"):
        normal_wall_motion(v, f, tv, tf, max_detour=-1.0)


def test_matches_the_all_pairs_definition_on_irregular_surfaces():
    """The candidate pruning loses no triangle: same answer as every (vertex, triangle) pair."""
    cohort = make_synthetic_cohort(2, n_vertices=241)
    rng = np.random.default_rng(3)
    faces = cohort.faces
    for subject in cohort.subjects:
        bumpy = subject.es + rng.normal(0.0, 0.8, subject.es.shape)
        for target, limit in ((subject.es, 25.0), (bumpy, 25.0), (bumpy, 2.5), (subject.ed, 60.0)):
            result = normal_wall_motion(cohort.atlas, faces, target, faces, max_distance=limit)
            expected, hit = _brute_force(cohort.atlas, faces, target, faces, limit)
            np.testing.assert_array_equal(result.hit, hit)
            np.testing.assert_allclose(result.distance[hit], expected[hit], rtol=0, atol=1e-9)


def _sphere_with_a_lid(radius: float, height: float):
    """An icosphere cut above ``height`` and closed by a fan: a few large triangles, as the
    flat lid a label image leaves at the base."""
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=radius)
    v, f = np.array(sphere.vertices), np.array(sphere.faces)
    f = f[~(v[f][:, :, 2] > height).all(axis=1)]
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    key = {tuple(e) for e in edges}
    rim = [e for e in edges if (e[1], e[0]) not in key]
    centre = len(v)
    v = np.vstack([v, v[np.unique(np.ravel(rim))].mean(axis=0)])
    return v, np.vstack([f, [[b, a, centre] for a, b in rim]])


def test_large_triangles_lose_no_hit():
    """A lid of large triangles is paired with every line: same answer as every pair."""
    tv, tf = _sphere_with_a_lid(30.0, 18.0)
    a, b, c = (tv[tf[:, i]] for i in range(3))
    centre = (a + b + c) / 3
    radius = np.sqrt(np.max([((p - centre) ** 2).sum(1) for p in (a, b, c)], axis=0))
    assert (radius > 4 * np.median(radius)).sum() >= 5  # the pruning's large class is used
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=26.0)
    v, f = np.array(sphere.vertices), np.array(sphere.faces)
    for limit in (10.0, 40.0):
        result = normal_wall_motion(v, f, tv, tf, max_distance=limit)
        expected, hit = _brute_force(v, f, tv, tf, limit)
        np.testing.assert_array_equal(result.hit, hit)
        np.testing.assert_allclose(result.distance[hit], expected[hit], rtol=0, atol=1e-9)
        assert (np.linalg.norm(result.points[hit], axis=1) < 28.0).any()  # some met the lid


def test_bad_arguments_are_named():
    v, f = _sphere(10.0, 1)
    with pytest.raises(ValueError, match="max_distance"):
        normal_wall_motion(v, f, v, f, max_distance=0.0)
    with pytest.raises(ValueError, match="target"):
        normal_wall_motion(v, f, v[:, :2], f)
    with pytest.raises(ValueError, match="displacement"):
        wall_motion_on_atlas(v, f, np.zeros((2, len(v) + 1, 3)))
    with pytest.raises(ValueError, match="displacement"):
        wall_motion_on_atlas(v, f, np.full((1, len(v), 3), np.nan))


# --- the wall motion of a transported motion -----------------------------------------------------


def _sphere_motion(displacements):
    v, f = _sphere(10.0, 3)
    d = np.stack(displacements(v))
    strain = np.stack([area_strain(v, v + di, f) for di in d])
    names = tuple(f"s{i}" for i in range(len(d)))
    return TransportedMotion("test", "lddmm", 1.0, names, v, f, d, strain)


def test_tangential_motion_has_no_wall_motion_and_radial_motion_all_of_it():
    axes = np.array([[0.3, -0.2, 1.0], [1.0, 0.0, 0.0]])

    def displacements(v):
        u = v / np.linalg.norm(v, axis=1)[:, None]
        out = []
        for axis in axes:  # a tangent field of the sphere, largest magnitude 1
            twist = np.cross(axis / np.linalg.norm(axis), v)
            out.append(twist / np.linalg.norm(twist, axis=1).max())
        return out + [1.2 * u, -0.8 * u]

    motion = _sphere_motion(displacements)
    wall = motion.wall_motion
    normals = outward_vertex_normals(motion.atlas, motion.faces)
    along = np.einsum("nkd,kd->nk", motion.displacement, normals)
    # tangential: both the normal component and the wall motion vanish (to the mesh's
    # flatness, 0.045 here), although the vertices move by up to 1
    gap = _inscribed_gap(motion.atlas, motion.faces, 10.0)
    assert np.linalg.norm(motion.displacement[:2], axis=2).max() == pytest.approx(1.0)
    assert np.abs(along[:2]).max() < 0.01
    assert np.abs(wall[:2]).max() < gap < 0.05
    # radial: the wall motion is the displacement's magnitude, with its sign
    np.testing.assert_allclose(wall[2], 1.2, atol=2e-3)
    np.testing.assert_allclose(wall[3], -0.8, atol=2e-3)
    assert motion.wall_motion_hit.all()


def _cohort_motion(data):
    c = data.cohort
    d = np.stack([s.es - s.ed for s in c.subjects])
    strain = np.stack([area_strain(s.ed, s.es, c.faces) for s in c.subjects])
    ratios = np.array([enclosed_volume(s.es, c.faces) / enclosed_volume(s.ed, c.faces)
                       for s in c.subjects])  # fmt: skip
    names = tuple(s.name for s in c.subjects)
    return TransportedMotion(
        "pole_ladder", "lddmm", 1.0, names, c.atlas, c.faces, d, strain, volume_ratio=ratios
    )


@pytest.fixture(scope="module")
def planted():
    """12 subjects of 241 vertices, 6 patients with the default hypokinesia."""
    data = make_two_group_cohort(12, n_vertices=241, seed=0)
    return data, _cohort_motion(data)


def test_wall_motion_is_the_projection_onto_each_subjects_surface(planted):
    data, motion = planted
    wall = motion.wall_motion
    assert wall.shape == motion.strain.shape and wall.dtype == np.float64
    for i in (0, 7):
        surface = motion.atlas + motion.displacement[i]
        expected = normal_wall_motion(motion.atlas, motion.faces, surface, motion.faces)
        np.testing.assert_array_equal(wall[i], expected.distance)
    # the ventricle contracts: most vertices move inward
    assert np.median(wall) < -2.0 and motion.wall_motion_hit.mean() > 0.7
    # subset: the same rows (computed already, or not)
    order = list(reversed(motion.subjects[:5]))
    rows = [motion.subjects.index(s) for s in order]
    np.testing.assert_array_equal(motion.subset(order).wall_motion, wall[rows])
    fresh = _cohort_motion(data).subset(order)
    np.testing.assert_array_equal(fresh.wall_motion, wall[rows])


def test_normalised_motion_has_the_rescaled_surfaces_wall_motion(planted):
    _, motion = planted
    small = motion.subset(motion.subjects[:4])
    ratios = 1.0 - 0.5 * (1.0 - small.volume_ratio)  # half the ejection fraction
    scaled, scales = normalize_motion(small, ratios)
    assert np.all((scales > 0.2) & (scales < 0.9))
    expected, _ = wall_motion_on_atlas(
        small.atlas, small.faces, small.displacement * scales[:, None, None]
    )
    np.testing.assert_array_equal(scaled.wall_motion, expected)
    # less motion, less wall motion, where the wall moves
    moving = np.abs(small.wall_motion) > 1.0
    assert np.all(np.abs(scaled.wall_motion[moving]) < np.abs(small.wall_motion[moving]))


def test_the_wall_motion_test_finds_the_planted_hypokinesia(planted):
    data, motion = planted
    c = compare_groups(motion, data.labels, n_permutations=200, rng=np.random.default_rng(0))
    affected = data.region.affected
    found = c.detected(0.05, "wall_motion")
    assert c.wall_motion.kind == "t" and c.wall_motion.n_permutations == 200
    assert detection_power(found, affected) >= 0.5
    assert dice(found, affected) >= 0.6
    assert (found & ~affected).sum() <= 0.05 * (~affected).sum()
    # hypokinesia: the patients' wall moves less far inward (t > 0), about half as far
    core = data.region.weight > 0.99
    patients, controls = c.group_mean(0, "wall_motion"), c.group_mean(1, "wall_motion")
    assert np.all(c.wall_motion.statistic[found] > 0)
    assert controls[core].mean() < -2.0
    assert 0.4 < patients[core].mean() / controls[core].mean() < 0.8
    # drawn after the other tests: they are those of the same seed's earlier comparisons
    again = compare_groups(motion, data.labels, n_permutations=200, rng=np.random.default_rng(0))
    np.testing.assert_array_equal(again.wall_motion.p_fwer, c.wall_motion.p_fwer)
    with pytest.raises(ValueError, match="test"):
        c.detected(0.05, "wall")
    with pytest.raises(ValueError, match="quantity"):
        c.group_mean(0, "normal")


def test_under_the_null_the_wall_motion_test_is_finite_and_quiet():
    data = make_two_group_cohort(12, n_vertices=241, seed=4, abnormality=None)
    motion = _cohort_motion(data)
    c = compare_groups(motion, data.labels, n_permutations=200, rng=np.random.default_rng(1))
    test = c.wall_motion
    assert np.all(np.isfinite(motion.wall_motion))
    assert np.all(np.isfinite(test.statistic)) and np.all(np.isfinite(test.p_uncorrected))
    assert np.all((test.p_fwer >= 1 / 201) & (test.p_fwer <= 1.0))
    assert c.detected(0.05, "wall_motion").sum() <= 0.05 * test.statistic.size


def test_scores_and_outputs_carry_the_wall_motion(planted, tmp_path):
    data, motion = planted
    scores, comparisons = score_transports(
        [motion], data.labels, data.region.affected, np.random.default_rng(0), n_permutations=200
    )
    s, c = scores[0], comparisons[0]
    found = c.detected(0.05, "wall_motion")
    assert s.wall_power == detection_power(found, data.region.affected) >= 0.5
    assert s.wall_dice == dice(found, data.region.affected)
    header = scores_csv(scores).splitlines()[0].split(",")
    assert header[:6] == ["name", "method", "label", "deformation", "alpha2", "power"]
    assert header[-2:] == ["wall_power", "wall_dice"]
    table = scores_markdown(scores).splitlines()
    column = table[0].split("|").index(" wall-motion power / Dice ")
    assert table[2].split("|")[column].strip() == f"{s.wall_power:.2f} / {s.wall_dice:.2f}"

    paths = write_analysis(tmp_path, comparisons, c, 0.05, data.region.weight, scores,
                           "truth", "header", figures=False)  # fmt: skip
    with open(paths["tests.csv"]) as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0])[-1] == "wall_motion_vertices_significant"
    assert int(rows[0]["wall_motion_vertices_significant"]) == found.sum()
    summary = paths["summary.md"].read_text()
    assert "(wall motion)" in summary and "wall-motion power" in summary
    vtu = meshio.read(tmp_path / "maps" / "lddmm_pole_ladder_alpha2=1.vtu")
    np.testing.assert_allclose(vtu.point_data["wall_motion_t"], c.wall_motion.statistic)
    np.testing.assert_allclose(vtu.point_data["wall_motion_p_fwer"], c.wall_motion.p_fwer)
    np.testing.assert_array_equal(vtu.point_data["wall_motion_significant"], found.astype(float))
    np.testing.assert_allclose(
        vtu.point_data["mean_wall_motion_patients"], motion.wall_motion[data.labels].mean(0)
    )
    figure = plot_pvalue_map(c, tmp_path / "p.png", data.region.weight)  # five panels
    assert figure.stat().st_size > 0


def test_the_volume_normalisation_reaches_large_scales_and_names_a_lost_motion(planted):
    """A transported motion eight times too small is scaled back (within [0, 16]); one
    forty times too small has lost the motion: refused, naming the subject."""
    from dataclasses import replace

    from ladders.study.errors import CohortError

    _, motion = planted
    small = motion.subset(motion.subjects[:3])
    shrunk = replace(small, displacement=small.displacement / 8.0)
    _, scales = normalize_motion(shrunk, small.volume_ratio)
    _, direct = normalize_motion(small, small.volume_ratio)
    np.testing.assert_allclose(scales, 8.0 * direct, rtol=1e-6)
    lost = replace(small, displacement=small.displacement / 40.0)
    with pytest.raises(CohortError, match=f"subject {small.subjects[0]}'s transported motion"):
        normalize_motion(lost, small.volume_ratio)


def test_the_motion_without_transport_is_normalised_on_the_atlas(planted):
    """S' - S applied to the atlas is scaled to the subject's own volume change there."""
    from dataclasses import replace

    _, motion = planted
    small = replace(motion, method="none").subset(motion.subjects[:3])
    scaled, scales = normalize_motion(small)
    v0 = enclosed_volume(small.atlas, small.faces)
    for d, ratio in zip(scaled.displacement, small.volume_ratio):
        assert abs(enclosed_volume(small.atlas + d, small.faces) / v0 - ratio) < 1e-6
    assert np.any(np.abs(scales - 1.0) > 0.01)  # the atlas is not each subject's anatomy
