"""Heat-kernel smoothing on a mesh: closed forms on the sphere and the plane, invariants, bad input."""

import functools

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from ladders.statistics import SurfaceSmoother, fwhm_to_time, smooth_surface_data

R = 30.0
SPHERES = {s: trimesh.creation.icosphere(subdivisions=s, radius=R) for s in (2, 3, 4)}
SPHERE = SPHERES[3]


@functools.cache
def _sphere_smoother(sub: int, fwhm: float) -> SurfaceSmoother:
    """The dense kernel on the two coarser spheres, the sparse exponential on the finest."""
    return SurfaceSmoother(SPHERES[sub].vertices, SPHERES[sub].faces, fwhm, dense_max=1000)


def _harmonics(v):
    """Zonal harmonics of degree 1, 2, 3 (up to a factor) at the points ``v`` of radius R."""
    z = v[:, 2]
    return {1: z, 2: 3 * z**2 - R**2, 3: z * (5 * z**2 - 3 * R**2)}


def _plane(n=121, half=60.0):
    xs = np.linspace(-half, half, n)
    x, y = np.meshgrid(xs, xs)
    v = np.c_[x.ravel(), y.ravel(), np.zeros(n * n)]
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = (
        idx[:-1, :-1].ravel(),
        idx[1:, :-1].ravel(),
        idx[:-1, 1:].ravel(),
        idx[1:, 1:].ravel(),
    )
    return v, np.r_[np.c_[a, b, d], np.c_[a, d, c]]


def _open_cup():
    """The lower two thirds of a sphere: a surface with a boundary, like a ventricle."""
    m = SPHERE
    keep = m.vertices[:, 2] < 0.4 * R
    faces = m.faces[keep[m.faces].all(axis=1)]
    used = np.unique(faces)
    index = np.full(len(m.vertices), -1)
    index[used] = np.arange(len(used))
    return m.vertices[used], index[faces]


def test_fwhm_to_time_is_half_the_variance():
    sigma = 10.0 / np.sqrt(8 * np.log(2))
    assert fwhm_to_time(10.0) == pytest.approx(sigma**2 / 2, rel=1e-14)


@pytest.mark.parametrize("degree", [1, 2, 3])
def test_spherical_harmonics_decay_by_their_eigenvalue(degree):
    fwhm = 20.0
    expected = np.exp(-fwhm_to_time(fwhm) * degree * (degree + 1) / R**2)
    errors = []
    for sub, m in SPHERES.items():
        g = _harmonics(m.vertices)[degree]
        u = _sphere_smoother(sub, fwhm)(g)
        # the map stays the harmonic, scaled by the exponential of its eigenvalue
        factor = (u @ g) / (g @ g)
        assert np.abs(u - factor * g).max() < 0.01 * np.abs(g).max()
        errors.append(abs(factor - expected))
    assert errors[-1] < 3e-3 * expected
    if degree > 1:  # degree 1 is exact to round-off on every icosphere level
        # the cotangent Laplacian's eigenvalues converge at second order in the edge length
        slopes = np.diff(np.log(errors)) / np.log(0.5)
        assert slopes.min() > 1.6, slopes


@pytest.mark.parametrize("fwhm", [8.0, 14.0])
def test_a_spike_on_the_plane_spreads_to_the_requested_width(fwhm):
    v, f = _plane()
    smoother = SurfaceSmoother(v, f, fwhm)
    spike = np.zeros(len(v))
    spike[len(v) // 2] = 1.0 / smoother.mass[len(v) // 2]
    u = smoother(spike)
    w = smoother.mass * u
    assert w.sum() == pytest.approx(1.0, abs=1e-10)
    for axis in (0, 1):
        variance = (w * v[:, axis] ** 2).sum()
        assert np.sqrt(8 * np.log(2) * variance) == pytest.approx(fwhm, rel=1e-3)
    # the profile is the Gaussian's: half the peak at half the width
    row = np.flatnonzero(np.abs(v[:, 1]) < 1e-9)
    profile = np.interp(fwhm / 2, v[row, 0][v[row, 0] >= 0], u[row][v[row, 0] >= 0])
    assert profile / u.max() == pytest.approx(0.5, abs=0.02)


def test_constants_and_the_area_weighted_sum_are_kept_across_a_boundary():
    v, f = _open_cup()
    smoother = SurfaceSmoother(v, f, 15.0)
    np.testing.assert_allclose(smoother(np.full(len(v), 3.5)), 3.5, rtol=1e-12)
    x = np.random.default_rng(0).standard_normal((4, len(v)))
    u = smoother(x)
    np.testing.assert_allclose(u @ smoother.mass, x @ smoother.mass, atol=1e-9 * len(v))
    assert u.std(axis=1).max() < 0.5 * x.std(axis=1).min()


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), fwhm=st.floats(2.0, 40.0), scale=st.floats(-5.0, 5.0))
def test_linear_and_within_the_data_range(seed, fwhm, scale):
    m = SPHERES[2]
    rng = np.random.default_rng(seed)
    x, y = rng.standard_normal((2, len(m.vertices)))
    smoother = SurfaceSmoother(m.vertices, m.faces, fwhm)
    np.testing.assert_allclose(smoother(x + scale * y), smoother(x) + scale * smoother(y),
                               atol=1e-10)  # fmt: skip
    u = smoother(x)  # the icosphere's cotangent weights are positive: a maximum principle
    assert u.max() <= x.max() + 1e-10 and u.min() >= x.min() - 1e-10


@pytest.mark.parametrize("fwhm", [4.0, 25.0])
def test_the_dense_kernel_equals_the_sparse_exponential(fwhm):
    v, f = _open_cup()
    x = np.random.default_rng(3).standard_normal((3, len(v)))
    dense = SurfaceSmoother(v, f, fwhm)
    sparse = SurfaceSmoother(v, f, fwhm, dense_max=0)
    assert dense._kernel is not None and sparse._kernel is None
    np.testing.assert_allclose(dense(x), sparse(x), atol=1e-10)


def test_batches_equal_the_loop():
    x = np.random.default_rng(1).standard_normal((2, 3, len(SPHERE.vertices)))
    smoother = SurfaceSmoother(SPHERE.vertices, SPHERE.faces, 12.0)
    batch = smoother(x)
    loop = np.array([[smoother(x[i, j]) for j in range(3)] for i in range(2)])
    np.testing.assert_allclose(batch, loop, atol=1e-12)


def test_a_mask_smooths_its_own_surface_and_leaves_the_rest():
    v, f = SPHERE.vertices, SPHERE.faces
    mask = v[:, 2] < 0.4 * R
    x = np.random.default_rng(2).standard_normal(len(v))
    x[~mask] = np.nan  # e.g. a rotation undefined near the axis
    u = smooth_surface_data(x, v, f, 15.0, mask=mask)
    cup_v, cup_f = _open_cup()
    np.testing.assert_allclose(u[mask], smooth_surface_data(x[mask], cup_v, cup_f, 15.0),
                               atol=1e-12)  # fmt: skip
    assert np.isnan(u[~mask]).all()


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda v, f: SurfaceSmoother(v, f, 0.0), "fwhm"),
        (lambda v, f: SurfaceSmoother(v, f, np.nan), "fwhm"),
        (lambda v, f: SurfaceSmoother(v[:, :2], f, 5.0), "vertices"),
        (lambda v, f: SurfaceSmoother(v, f + len(v), 5.0), "faces"),
        (lambda v, f: SurfaceSmoother(v, f.astype(float), 5.0), "faces"),
        (lambda v, f: SurfaceSmoother(v, f, 5.0, mask=np.ones(3, bool)), "mask"),
        (lambda v, f: SurfaceSmoother(v, f, 5.0, mask=np.zeros(len(v), bool)), "mask"),
        (lambda v, f: SurfaceSmoother(v, f, 5.0)(np.zeros(len(v) + 1)), "values"),
        (lambda v, f: SurfaceSmoother(v, f, 5.0, dense_max=-1), "dense_max"),
        (lambda v, f: SurfaceSmoother(v, f, 5.0, dense_max=2.5), "dense_max"),
        (lambda v, f: SurfaceSmoother(v, f, 5.0)(np.full(len(v), np.nan)), "values"),
    ],
)
def test_bad_input_names_the_argument(call, match):
    with pytest.raises(ValueError, match=match):
        call(SPHERE.vertices, SPHERE.faces)
