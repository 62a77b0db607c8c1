"""Synthetic left-ventricle cohort: determinism, correspondence, motion statistics, validity."""

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from ladders.study.cohort import Cohort, CohortError, Subject
from ladders.study.cohort.synthetic_lv import (
    SubjectParameters,
    SyntheticLVModel,
    grid_shape,
    lv_grid,
    lv_shapes,
    make_synthetic_cohort,
)

FULL = make_synthetic_cohort(seed=0)
GRID = (42, 24)


def rho(x):
    return np.hypot(x[..., 0], x[..., 1])


def long_axis(x):
    return x[..., 2].max(axis=-1) - x[..., 2].min(axis=-1)


def rotation_deg(ed, es):
    """Signed rotation of each vertex about +z from ed to es, in degrees."""
    cross = ed[..., 0] * es[..., 1] - ed[..., 1] * es[..., 0]
    dot = (ed[..., :2] * es[..., :2]).sum(axis=-1)
    return np.rad2deg(np.arctan2(cross, dot))


def test_default_cohort_size_and_shapes():
    assert len(FULL) == 138
    assert FULL.n_vertices == 1 + GRID[0] * GRID[1] == 1009
    assert FULL.faces.shape == (2 * GRID[0] * GRID[1] - GRID[0], 3)
    assert FULL.ed.shape == FULL.es.shape == (138, 1009, 3)
    assert FULL.atlas.shape == (1009, 3)
    assert len(set(FULL.names)) == 138


def test_same_seed_same_arrays_and_different_seed_differs():
    a = make_synthetic_cohort(6, seed=3)
    b = make_synthetic_cohort(6, seed=3)
    c = make_synthetic_cohort(6, seed=4)
    np.testing.assert_array_equal(a.ed, b.ed)
    np.testing.assert_array_equal(a.es, b.es)
    np.testing.assert_array_equal(a.faces, b.faces)
    for i in range(6):
        assert np.abs(a.ed[i] - c.ed[i]).max() > 0.5
    # The atlas depends on the model only, not on the seed.
    np.testing.assert_array_equal(a.atlas, c.atlas)


def test_generator_seed_is_reproducible():
    a = make_synthetic_cohort(3, seed=np.random.default_rng(5))
    b = make_synthetic_cohort(3, seed=np.random.default_rng(5))
    np.testing.assert_array_equal(a.es, b.es)


def test_subject_independent_of_cohort_size():
    small = make_synthetic_cohort(5, seed=0)
    np.testing.assert_array_equal(small.ed, FULL.ed[:5])
    np.testing.assert_array_equal(small.es, FULL.es[:5])
    assert small.names == FULL.names[:5]
    head = FULL.head(5)
    np.testing.assert_array_equal(head.es, small.es)


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 6))
def test_prefix_property(seed, n):
    small = make_synthetic_cohort(n, grid=(8, 4), seed=seed)
    large = make_synthetic_cohort(n + 3, grid=(8, 4), seed=seed)
    np.testing.assert_array_equal(small.ed, large.ed[:n])
    np.testing.assert_array_equal(small.es, large.es[:n])


def test_resolution():
    for n in (150, 241, 400, 1000, 2500):
        n_lon, n_lat = grid_shape(n)
        assert abs(1 + n_lon * n_lat - n) <= 0.1 * n
        assert 1.4 < n_lon / n_lat < 2.0
    fine = make_synthetic_cohort(2, n_vertices=1000)
    assert fine.n_vertices == 1 + np.prod(grid_shape(1000))
    # Finer grids sample the same surface: the base ring keeps its radius.
    np.testing.assert_allclose(rho(fine.atlas[-1]), rho(FULL.atlas[-1]), rtol=1e-12)
    np.testing.assert_allclose(long_axis(fine.atlas), long_axis(FULL.atlas), rtol=1e-12)


def test_motion_statistics_in_stated_ranges():
    ed, es = FULL.ed, FULL.es
    shortening = 1.0 - long_axis(es) / long_axis(ed)
    assert np.all((shortening >= 0.10) & (shortening <= 0.20))
    contraction = 1.0 - rho(es).sum(axis=1) / rho(ed).sum(axis=1)
    assert np.all((contraction >= 0.20) & (contraction <= 0.35))
    n_lon = GRID[0]
    base = rotation_deg(ed[:, -n_lon:], es[:, -n_lon:]).mean(axis=1)
    apex = rotation_deg(ed[:, 1 : 1 + n_lon], es[:, 1 : 1 + n_lon]).mean(axis=1)
    assert np.all(base < -1.0) and np.all(apex > 1.0)
    twist = apex - base
    assert np.all((twist > 3.0) & (twist < 16.0))
    # Ranges are used, not a single value: the cohort spreads over them.
    assert np.ptp(shortening) > 0.03 and np.ptp(contraction) > 0.04 and np.ptp(twist) > 3.0


def test_recorded_parameters_reproduce_shapes_and_lie_in_ranges():
    model = SyntheticLVModel()
    theta, phi, _ = lv_grid(*GRID)
    for s in FULL.subjects[:10]:
        ed, es = lv_shapes(s.parameters, theta, phi)
        np.testing.assert_array_equal(ed, s.ed)
        np.testing.assert_array_equal(es, s.es)
        p = s.parameters
        lo, hi = model.long_axis
        assert lo <= p.long_axis <= hi
        np.testing.assert_allclose(long_axis(s.ed), p.long_axis, rtol=1e-12)
        np.testing.assert_allclose(1 - long_axis(s.es) / long_axis(s.ed), p.longitudinal_shortening)
        assert p.harmonics.shape == (model.n_harmonics, 2)
        assert np.all(np.abs(p.harmonics[:, 0]) <= model.harmonic_amplitude / np.arange(1, 4))
        assert set(p.as_dict()) >= {"radius", "harmonics", "apex_rotation"}


def test_physiological_sizes():
    assert np.all((long_axis(FULL.ed) > 70.0) & (long_axis(FULL.ed) < 100.0))
    base_radius = rho(FULL.ed[:, -GRID[0] :]).mean(axis=1)
    assert np.all((base_radius > 16.0) & (base_radius < 34.0))
    # The cohort varies in eccentricity (ratio of long axis to radius).
    assert np.ptp(long_axis(FULL.ed) / base_radius) > 0.8


def test_atlas_is_mean_shape_and_differs_from_every_subject():
    theta, phi, _ = lv_grid(*GRID)
    atlas, _ = lv_shapes(SubjectParameters.mean(SyntheticLVModel()), theta, phi)
    np.testing.assert_array_equal(atlas, FULL.atlas)
    rms = np.sqrt(((FULL.ed - FULL.atlas) ** 2).sum(axis=-1).mean(axis=-1))
    assert rms.min() > 0.5
    assert np.sqrt(((FULL.es - FULL.atlas) ** 2).sum(axis=(1, 2))).min() > 1.0


def _boundary_edges(faces):
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    uniq, counts = np.unique(edges, axis=0, return_counts=True)
    assert counts.max() <= 2
    return uniq[counts == 1], len(uniq)


def test_meshes_are_valid_open_at_base():
    boundary, n_edges = _boundary_edges(FULL.faces)
    assert len(boundary) == GRID[0]
    # Topological disk: V - E + F = 1.
    assert FULL.n_vertices - n_edges + len(FULL.faces) == 1
    shapes = np.concatenate([FULL.atlas[None], FULL.ed, FULL.es])
    for x in shapes:
        mesh = trimesh.Trimesh(x, FULL.faces, process=False)
        assert mesh.area_faces.min() > 0.05 * np.median(mesh.area_faces)  # no degenerate cell
        assert mesh.is_winding_consistent
        z = x[np.unique(boundary), 2]
        np.testing.assert_allclose(z, x[:, 2].max(), atol=1e-9)  # base plane, z = max
        assert x[:, 2].min() == 0.0 and np.allclose(x[0], 0.0)  # apex at the origin
        assert np.count_nonzero(np.isclose(x[:, 2], x[:, 2].max())) == GRID[0]
        outward = (mesh.face_normals[:, :2] * mesh.triangles_center[:, :2]).sum(axis=1)
        assert np.all(outward > 0)


def test_faces_list_vertices_in_increasing_first_appearance():
    _, first = np.unique(FULL.faces.ravel(), return_index=True)
    assert np.all(np.diff(first) > 0)


def test_custom_model_controls_motion():
    model = SyntheticLVModel(
        longitudinal_shortening=(0.3, 0.3),
        radial_contraction=(0.1, 0.1),
        contraction_heterogeneity=(0.0, 0.0),
        contraction_gradient=(0.0, 0.0),
        apex_rotation=(0.0, 0.0),
        base_rotation=(0.0, 0.0),
    )
    c = make_synthetic_cohort(3, grid=(10, 5), model=model)
    np.testing.assert_allclose(c.es[..., 2], 0.7 * c.ed[..., 2])
    np.testing.assert_allclose(c.es[..., :2], 0.9 * c.ed[..., :2], atol=1e-12)


def test_bad_arguments():
    with pytest.raises(CohortError, match="n_subjects"):
        make_synthetic_cohort(-1)
    with pytest.raises(CohortError, match="n_vertices"):
        make_synthetic_cohort(2, n_vertices=5)
    with pytest.raises(CohortError, match="seed"):
        make_synthetic_cohort(2, seed=-3)
    with pytest.raises(CohortError, match="grid"):
        make_synthetic_cohort(2, grid=(2, 4))
    assert issubclass(CohortError, ValueError)


def test_cohort_validation():
    atlas, faces = FULL.atlas, FULL.faces
    with pytest.raises(CohortError, match="subject 'x' es: 1008 vertices"):
        Cohort(atlas, faces, [Subject("x", atlas, atlas[:-1])])
    with pytest.raises(CohortError, match="faces"):
        Cohort(atlas, faces + len(atlas))
    with pytest.raises(CohortError, match="NaN"):
        Cohort(atlas, faces, [Subject("y", np.full_like(atlas, np.nan), atlas)])


def test_cohort_figures_match_real_ventricles_and_the_paper():
    """Mesh resolution, sizes, ejection fraction and distances of the default cohort."""
    from ladders.study.cohort.cohort_statistics import cohort_statistics

    stats = cohort_statistics(FULL)
    assert stats.n_vertices >= 1000 and stats.mean_edge <= 4.0
    assert 80.0 <= stats.long_axis.mean() <= 90.0  # real ED long axis 80-90 mm
    assert 22.0 <= stats.radius.mean() <= 28.0  # real ED radius about 25 mm
    assert 0.50 <= stats.ejection_fraction.min() and stats.ejection_fraction.max() <= 0.66
    assert 0.55 <= stats.ejection_fraction.mean() <= 0.62
    # The paper's PDM-limit figures: atlas-ED 5.61 mm, atlas-ES 9.39 mm (per-vertex RMS).
    assert 4.5 <= stats.rms_atlas_ed.mean() <= 6.5
    assert 8.5 <= stats.rms_atlas_es.mean() <= 11.0


def test_cavity_volume_of_a_half_ellipsoid():
    from ladders.study.cohort.cohort_statistics import boundary_vertices, cavity_volume

    model = SyntheticLVModel(bulge=(0.0, 0.0), harmonic_amplitude=0.0)
    theta, phi, faces = lv_grid(120, 70, model)
    params = SubjectParameters.mean(model)
    ed, _ = lv_shapes(params, theta, phi)
    exact = 2.0 / 3.0 * np.pi * params.radius**2 * params.long_axis
    volume = cavity_volume(ed, faces, boundary_vertices(faces))
    np.testing.assert_allclose(volume, exact, rtol=2e-3)
    assert len(boundary_vertices(faces)) == 120
