"""Local area strain and area strain error (paper, Section 3)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay

from ladders.study.area_strain import area_strain, area_strain_error, cell_areas
from ladders.study.cohort.synthetic_lv import make_synthetic_cohort
from manifolds.errors import ManifoldError

COHORT = make_synthetic_cohort(n_subjects=3, grid=(12, 7), seed=11)

SQUARE = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
SQUARE_FACES = np.array([[0, 1, 2], [0, 2, 3]])


def random_rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q * np.linalg.det(q)


def test_hand_computed_square():
    moved = SQUARE.copy()
    moved[1] = [2.0, 0.0, 0.0]
    # Triangle 0 grows from area 1/2 to 1 (ratio -1), triangle 1 keeps its area (ratio 0).
    np.testing.assert_allclose(cell_areas(SQUARE, SQUARE_FACES), [0.5, 0.5])
    np.testing.assert_allclose(cell_areas(moved, SQUARE_FACES), [1.0, 0.5])
    las = area_strain(SQUARE, moved, SQUARE_FACES)
    np.testing.assert_allclose(las, [-0.5, -1.0, -0.5, 0.0], atol=1e-15)


def test_hand_computed_ase():
    np.testing.assert_allclose(area_strain_error([0.1, 0.2, 0.3], [0.1, -0.2, 0.0]), 0.5)
    assert area_strain_error([0.3, -0.1], [0.3, -0.1]) == 0.0


@settings(max_examples=30, deadline=None)
@given(st.floats(0.2, 3.0), st.integers(0, 2**32 - 1))
def test_uniform_scaling_gives_one_minus_s_squared(s, seed):
    rng = np.random.default_rng(seed)
    v = COHORT.ed[0]
    moved = s * v @ random_rotation(rng).T + rng.normal(size=3) * 10.0
    las = area_strain(v, moved, COHORT.faces)
    np.testing.assert_allclose(las, 1.0 - s**2, atol=1e-12 * max(1.0, s**2))


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_rigid_motion_gives_zero_strain(seed):
    rng = np.random.default_rng(seed)
    v = COHORT.es[1]
    moved = v @ random_rotation(rng).T + rng.normal(size=3) * 50.0
    np.testing.assert_allclose(area_strain(v, moved, COHORT.faces), 0.0, atol=1e-12)


@settings(max_examples=25, deadline=None)
@given(st.floats(0.3, 2.0), st.floats(0.3, 2.0), st.integers(0, 2**32 - 1))
def test_planar_linear_map_strain(p, q, seed):
    """An in-plane map diag(p, q) multiplies every planar cell's area by p q."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(size=(25, 2))
    faces = Delaunay(xy).simplices
    used = np.unique(faces)
    remap = np.full(len(xy), -1)
    remap[used] = np.arange(len(used))
    v = np.column_stack([xy[used], np.zeros(len(used))])
    f = remap[faces]
    keep = cell_areas(v, f) > 1e-6
    f = f[keep]
    v, f = v[np.unique(f)], np.searchsorted(np.unique(f), f)
    moved = v * np.array([p, q, 1.0])
    np.testing.assert_allclose(area_strain(v, moved, f), 1.0 - p * q, atol=1e-10)


def test_cohort_strain_is_a_contraction():
    """End-systole cells are smaller than end-diastole cells for the synthetic motion."""
    las = area_strain(COHORT.ed, COHORT.es, COHORT.faces)
    assert las.shape == (3, COHORT.n_vertices)
    assert np.all(las > 0.2) and np.all(las < 0.7)


def test_batch_matches_loop():
    las = area_strain(COHORT.ed, COHORT.es, COHORT.faces)
    for i in range(len(COHORT)):
        np.testing.assert_allclose(las[i], area_strain(COHORT.ed[i], COHORT.es[i], COHORT.faces))
    stacked = area_strain(
        COHORT.ed.reshape(3, 1, -1, 3), COHORT.es.reshape(3, 1, -1, 3), COHORT.faces
    )
    np.testing.assert_allclose(stacked[:, 0], las)
    atlas_las = area_strain(COHORT.atlas, COHORT.es[0], COHORT.faces)
    ase = area_strain_error(las, atlas_las)
    assert ase.shape == (3,)
    np.testing.assert_allclose(ase[1], np.sqrt(((las[1] - atlas_las) ** 2).sum()))


def test_ase_of_two_scalings():
    v = COHORT.atlas
    k = len(v)
    las_s = area_strain(v, 0.8 * v, COHORT.faces)
    las_t = area_strain(v, 0.9 * v, COHORT.faces)
    np.testing.assert_allclose(area_strain_error(las_s, las_t), np.sqrt(k) * (0.81 - 0.64))


def test_mismatched_vertex_counts():
    with pytest.raises(ManifoldError, match="vertices_deformed"):
        area_strain(COHORT.atlas, COHORT.atlas[:-1], COHORT.faces)


def test_faces_out_of_range():
    bad = COHORT.faces.copy()
    bad[3, 1] = COHORT.n_vertices
    with pytest.raises(ManifoldError, match=r"faces: vertex indices"):
        area_strain(COHORT.atlas, COHORT.atlas, bad)
    with pytest.raises(ManifoldError, match="faces"):
        area_strain(SQUARE, SQUARE, SQUARE_FACES - 1)
    with pytest.raises(ManifoldError, match="faces"):
        area_strain(SQUARE, SQUARE, SQUARE_FACES[:, :2])
    with pytest.raises(ManifoldError, match="faces"):
        area_strain(SQUARE, SQUARE, SQUARE_FACES + 0.5)


def test_degenerate_cell():
    v = SQUARE.copy()
    v[1] = [0.5, 0.5, 0.0]  # on the diagonal 0-2: triangle 0 collapses
    with pytest.raises(ManifoldError, match=r"vertices: 1 degenerate .* face 0"):
        area_strain(v, SQUARE, SQUARE_FACES)
    # A degenerate deformed cell is a legitimate strain of 1.
    np.testing.assert_allclose(area_strain(SQUARE, v, SQUARE_FACES), [0.5, 1.0, 0.5, 0.0])


def test_vertex_in_no_face_and_nan():
    v = np.vstack([SQUARE, [[5.0, 5.0, 5.0]]])
    with pytest.raises(ManifoldError, match="belong to no triangle"):
        area_strain(v, v, SQUARE_FACES)
    w = SQUARE.copy()
    w[2, 0] = np.nan
    with pytest.raises(ManifoldError, match="vertices_deformed: contains 1 NaN"):
        area_strain(SQUARE, w, SQUARE_FACES)


def test_ase_shape_errors():
    with pytest.raises(ManifoldError, match="las_atlas"):
        area_strain_error(np.zeros(5), np.zeros(4))
    with pytest.raises(ManifoldError, match="las_subject"):
        area_strain_error(0.0, np.zeros(4))
    with pytest.raises(ManifoldError, match="las_atlas"):
        area_strain_error(np.zeros((2, 4)), np.zeros((3, 4)))
