"""The two-group synthetic cohort: AHA segments, the planted abnormality, noise, groups table."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ladders.study.cohort import (
    AHA_SEGMENTS,
    MotionAbnormality,
    make_synthetic_cohort,
    planted_modulation,
    read_cohort,
    read_groups,
    segment_of,
    segment_weights,
    smooth_normal_noise,
)
from ladders.study.cohort.groups_table import groups_csv
from ladders.study.cohort.synthetic_lv import grid_shape, lv_grid, lv_shapes
from ladders.study.errors import CohortError
from ladders.study.population import (
    GROUPS_FILE,
    PATIENTS,
    REGION_FILE,
    make_two_group_cohort,
    read_planted_region,
    write_two_group_cohort,
)

THETA, PHI, FACES = lv_grid(*grid_shape(1009))


def _polar(points):
    return np.hypot(points[:, 0], points[:, 1]), np.arctan2(points[:, 1], points[:, 0])


def test_every_segment_is_on_the_mesh_and_every_vertex_in_one():
    seg = segment_of(THETA, PHI)
    assert set(np.unique(seg)) == set(range(1, 18))
    # anterior segments are centred at +y, the septum at -x
    u = 1 - np.cos(THETA)
    x, y = np.sin(THETA) * np.cos(PHI), np.sin(THETA) * np.sin(PHI)
    assert np.mean(y[seg == 7]) > 0.5 * np.abs(x[seg == 7]).mean()
    assert np.mean(x[seg == 14]) < 0
    assert u[seg == 17].max() < 0.1 + 1e-12 and u[seg == 1].min() >= 0.7 - 1e-12


def test_sharp_weights_are_the_segment_indicator():
    for segments in [(1,), (7, 8, 13, 14), (17,), (6, 12, 16)]:
        w = segment_weights(THETA, PHI, segments, 0.0, 0.0)
        expected = np.isin(segment_of(THETA, PHI), segments)
        # vertices exactly on a boundary may fall on either side; none lies on one here
        assert np.mean((w >= 0.5) == expected) > 0.99, segments


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.integers(1, 17), min_size=1, max_size=6),
    st.floats(0.0, 0.1),
    st.floats(0.0, 20.0),
)
def test_weights_are_a_partition_of_unity_like_indicator(segments, th, ta):
    w = segment_weights(THETA, PHI, segments, th, ta)
    assert np.all((w >= 0) & (w <= 1))
    everything = segment_weights(THETA, PHI, range(1, 18), th, ta)
    np.testing.assert_allclose(everything, 1.0, atol=1e-12)  # adjacent segments join, no dip


def test_weight_is_one_half_on_a_boundary_with_an_unnamed_segment():
    theta = np.arccos(1 - np.array([0.55, 0.55, 0.55]))  # mid ring
    phi = np.radians([120.0, 90.0, 180.0])  # boundary 1/2 of mid sectors, centre of 7, far
    w = segment_weights(theta, phi, (7,), 0.05, 10.0)
    np.testing.assert_allclose(w, [0.5, 1.0, 0.0], atol=1e-12)


def test_bad_segments_raise():
    with pytest.raises(CohortError, match="segments"):
        MotionAbnormality(segments=(0, 18))
    with pytest.raises(CohortError, match="kind"):
        MotionAbnormality(kind="dyskinesia")
    with pytest.raises(CohortError, match="magnitude"):
        MotionAbnormality(magnitude=1.5)


def test_hypokinesia_scales_the_radial_and_longitudinal_motion_inside_the_region():
    params = make_synthetic_cohort(1, seed=3).subjects[0].parameters
    ab = MotionAbnormality("hypokinesia", (7, 8, 13, 14), 0.4)
    mod = planted_modulation(ab, THETA, PHI)
    ed, es = lv_shapes(params, THETA, PHI)
    _, es_p = lv_shapes(params, THETA, PHI, mod)
    w = segment_weights(THETA, PHI, ab.segments)
    rho, rho_c, rho_p = _polar(ed)[0], _polar(es)[0], _polar(es_p)[0]
    inside = (w == 1.0) & (rho > 1.0)
    np.testing.assert_allclose(rho[inside] - rho_p[inside], 0.6 * (rho - rho_c)[inside], rtol=1e-10)
    np.testing.assert_allclose(ed[inside, 2] - es_p[inside, 2], 0.6 * (ed - es)[inside, 2],
                               rtol=1e-10, atol=1e-12)  # fmt: skip
    outside = w == 0.0
    np.testing.assert_array_equal(es[outside], es_p[outside])


def test_twist_only_rotates_about_the_long_axis_and_is_nearly_tangential():
    params = make_synthetic_cohort(1, seed=1).subjects[0].parameters
    ab = MotionAbnormality("twist", (7, 8, 13, 14), 5.0)
    _, es = lv_shapes(params, THETA, PHI)
    _, es_p = lv_shapes(params, THETA, PHI, planted_modulation(ab, THETA, PHI))
    w = segment_weights(THETA, PHI, ab.segments)
    (r_c, a_c), (r_p, a_p) = _polar(es), _polar(es_p)
    np.testing.assert_allclose(r_p, r_c, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(es_p[:, 2], es[:, 2])
    moved = r_c > 1.0
    turn = np.degrees((a_p - a_c + np.pi) % (2 * np.pi) - np.pi)
    np.testing.assert_allclose(turn[moved], 5.0 * w[moved], atol=1e-9)
    # the change of position is tangent to the end-systolic surface: small normal part
    import trimesh

    normals = trimesh.Trimesh(es, FACES, process=False).vertex_normals
    change = es_p - es
    big = np.linalg.norm(change, axis=1) > 0.5
    normal_part = np.abs(np.einsum("ij,ij->i", change[big], normals[big]))
    assert np.median(normal_part / np.linalg.norm(change[big], axis=1)) < 0.15


def test_two_group_cohort_plants_the_effect_in_the_patients_only():
    data = make_two_group_cohort(n_subjects=10, patient_fraction=0.3, seed=5)
    base = make_synthetic_cohort(10, seed=5)
    assert data.labels.sum() == 3
    for label, s, b in zip(data.labels, data.cohort.subjects, base.subjects):
        np.testing.assert_array_equal(s.ed, b.ed)
        if label:
            assert np.abs(s.es - b.es).max() > 1.0
            unaffected = data.region.weight == 0.0
            np.testing.assert_array_equal(s.es[unaffected], b.es[unaffected])
        else:
            np.testing.assert_array_equal(s.es, b.es)
    again = make_two_group_cohort(n_subjects=10, patient_fraction=0.3, seed=5)
    assert again.groups == data.groups
    null = make_two_group_cohort(n_subjects=10, abnormality=None, seed=5)
    assert null.region is None
    np.testing.assert_array_equal(null.cohort.es, base.es)


def test_segmentation_noise_is_normal_smooth_and_of_the_requested_rms():
    atlas = make_synthetic_cohort(0).atlas
    rng = np.random.default_rng(0)
    noisy = smooth_normal_noise(atlas, FACES, 0.8, rng, length=10.0)
    import trimesh

    normals = trimesh.Trimesh(atlas, FACES, process=False).vertex_normals
    d = noisy - atlas
    along = np.einsum("ij,ij->i", d, normals)
    np.testing.assert_allclose(np.sqrt(np.mean(along**2)), 0.8, rtol=1e-10)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), np.abs(along), atol=1e-12)
    edges = np.concatenate([FACES[:, [0, 1]], FACES[:, [1, 2]]])
    assert np.corrcoef(along[edges[:, 0]], along[edges[:, 1]])[0, 1] > 0.9  # smooth
    np.testing.assert_array_equal(smooth_normal_noise(atlas, FACES, 0.0, rng), atlas)


def test_groups_table_round_trip_and_errors(tmp_path):
    groups = {"a": "patients", "b": "controls", "c 1": "patients"}
    path = tmp_path / "g.csv"
    path.write_text(groups_csv(groups))
    assert read_groups(path) == groups
    path.write_text("Subject, Group\nx,A\ny,B\n")  # any letter case, spaces
    assert read_groups(path) == {"x": "A", "y": "B"}
    for text, match in [
        ("subject,kind\nx,A\n", "line 1: missing column 'group'"),
        ("Subject,Group,age\nx,A,3\n", "line 1, column 'age': not used"),
        ("subject,group\nx,A\nx,B\n", "line 3, column 'subject': a second row for subject 'x'"),
        ("subject,group\nx,\n", "line 2, column 'group': empty value"),
        ("", "empty"),
    ]:
        path.write_text(text)
        with pytest.raises(CohortError, match=match):
            read_groups(path)
    with pytest.raises(CohortError, match="cannot be read"):
        read_groups(tmp_path / "missing.csv")


def test_written_cohort_reads_back_with_its_groups_and_truth(tmp_path):
    data = make_two_group_cohort(n_subjects=6, n_vertices=241, seed=2, noise=0.3)
    write_two_group_cohort(data, tmp_path / "c")
    cohort = read_cohort(tmp_path / "c")
    np.testing.assert_allclose(cohort.es, data.cohort.es, atol=1e-9)
    assert read_groups(tmp_path / "c" / GROUPS_FILE) == data.groups
    region = read_planted_region(tmp_path / "c" / REGION_FILE)
    np.testing.assert_allclose(region.weight, data.region.weight)
    assert PATIENTS in data.groups.values()
    write_two_group_cohort(data, tmp_path / "r", remesh_factor=1.5, pose=True)
    from ladders.study import read_mesh

    v, f = read_mesh(tmp_path / "r" / "synthetic_000_ed.vtk")
    assert len(f) != len(data.cohort.faces)
    assert set(AHA_SEGMENTS) == set(range(1, 18))
