"""The generic Fréchet/Karcher mean: closed forms on S^2, H^2, SPD, flat spaces, geomstats."""

import numpy as np
import pytest
import scipy.linalg

from ladders import FrechetMeanResult, frechet_mean
from manifolds import (
    Connection,
    Euclidean,
    Hyperbolic,
    Hypersphere,
    LDDMMLandmarks,
    ManifoldError,
    SPDMatrices,
)


def ring(polar_angle, n, lift):
    """``n`` points at ``polar_angle`` from the pole, equally spaced in longitude."""
    phi = 2 * np.pi * np.arange(n) / n
    s, c = lift(polar_angle)
    return np.stack([s * np.cos(phi), s * np.sin(phi), np.full(n, c)], axis=1)


def test_sphere_points_symmetric_about_a_pole_have_the_pole_as_mean():
    pts = ring(0.6, 5, lambda t: (np.sin(t), np.cos(t)))
    res = frechet_mean(Hypersphere(2), pts, tol=1e-13)
    assert isinstance(res, FrechetMeanResult) and res.converged
    np.testing.assert_allclose(res.mean, [0, 0, 1], atol=1e-12)
    # the Fréchet function there is the squared polar angle
    np.testing.assert_allclose(res.variances[-1], 0.6**2, rtol=1e-10)
    assert res.gradient_norms[-1] <= 1e-13 < res.gradient_norms[0]


def test_hyperbolic_points_symmetric_about_the_origin_have_it_as_mean():
    pts = ring(0.9, 4, lambda t: (np.sinh(t), np.cosh(t)))[:, [2, 0, 1]]  # x0 = cosh
    res = frechet_mean(Hyperbolic(2), pts, tol=1e-13)
    assert res.converged
    np.testing.assert_allclose(res.mean, [1, 0, 0], atol=1e-12)


@pytest.mark.parametrize("space_name", ["sphere", "hyperbolic"])
def test_two_weighted_points_have_their_mean_on_the_geodesic(space_name):
    rng = np.random.default_rng(0)
    space = Hypersphere(2) if space_name == "sphere" else Hyperbolic(2)
    a = space.random_point(rng)
    b = space.exp(a, space.random_tangent(a, rng, scale=1.0))
    res = frechet_mean(space, np.stack([a, b]), [0.3, 0.7], tol=1e-13)
    np.testing.assert_allclose(res.mean, space.exp(a, 0.7 * space.log(a, b)), atol=1e-11)


def test_commuting_spd_matrices_have_the_log_euclidean_mean():
    rng = np.random.default_rng(1)
    q = np.linalg.qr(rng.standard_normal((3, 3)))[0]
    diag = np.exp(rng.normal(0, 0.7, (6, 3)))
    pts = np.einsum("ij,nj,kj->nik", q, diag, q)
    w = rng.uniform(0.5, 2, 6)
    expected = q @ np.diag(np.exp(w @ np.log(diag) / w.sum())) @ q.T
    res = frechet_mean(SPDMatrices(3), pts, w, tol=1e-12)
    assert res.converged
    np.testing.assert_allclose(res.mean, expected, rtol=1e-10)
    mean_log = q @ np.diag(w @ np.log(diag) / w.sum()) @ q.T
    np.testing.assert_allclose(scipy.linalg.logm(res.mean), mean_log, atol=1e-10)


def test_flat_space_mean_is_the_weighted_average_after_one_step():
    rng = np.random.default_rng(2)
    pts, w = rng.standard_normal((7, 4)), rng.uniform(0, 1, 7)
    res = frechet_mean(Euclidean(4), pts, w, tol=1e-12)
    assert res.converged and res.n_iter == 1
    np.testing.assert_allclose(res.mean, w @ pts / w.sum(), rtol=1e-13)


class Translations(Connection):
    """A space with exp and log but no metric: the array norm measures convergence."""

    point_shape = (2,)

    def exp(self, point, tangent):
        return np.asarray(point) + tangent

    def log(self, point, other):
        return np.asarray(other) - point

    def random_point(self, rng, n_samples=None):
        return rng.standard_normal(self.point_shape)

    def random_tangent(self, point, rng, scale=1.0):
        return scale * rng.standard_normal(self.point_shape)


def test_a_connection_without_metric_and_without_batching():
    pts = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 4.0]])
    calls = []
    res = frechet_mean(Translations(), pts, callback=lambda i, x, g: calls.append((i, g)))
    np.testing.assert_allclose(res.mean, [2 / 3, 4 / 3])
    assert [i for i, _ in calls] == [0, 1]


def test_lddmm_landmark_mean_converges():
    rng = np.random.default_rng(3)
    space = LDDMMLandmarks(12, 2, sigma=0.6, alpha=0.05, control_points="dense", max_iter=300)
    base = space.random_point(rng)
    pts = np.stack([space.exp(base, space.random_tangent(base, rng, 0.15)) for _ in range(3)])
    res = frechet_mean(space, pts, tol=1e-3, max_iter=5)
    assert res.converged, res.message
    assert res.gradient_norms[-1] < 0.05 * res.gradient_norms[0]
    assert res.variances[-1] < res.variances[0]


def test_not_converged_is_reported():
    pts = ring(0.6, 5, lambda t: (np.sin(t), np.cos(t)))
    res = frechet_mean(Hypersphere(2), pts, max_iter=1, tol=1e-15)
    assert not res.converged and res.n_iter == 1 and "max_iter" in res.message


@pytest.mark.parametrize(
    "points, weights, match",
    [
        (np.zeros((0, 3)), None, "n >= 1"),
        (np.ones((2, 4)), None, "points"),
        (np.array([[0, 0, 1.0], [np.nan, 0, 0]]), None, "NaN"),
        (np.array([[0, 0, 1.0], [0, 1.0, 0]]), [1.0], "weights"),
        (np.array([[0, 0, 1.0], [0, 1.0, 0]]), [1.0, -1.0], "weights"),
    ],
)
def test_bad_input_is_refused(points, weights, match):
    with pytest.raises(ManifoldError, match=match):
        frechet_mean(Hypersphere(2), points, weights)


def test_space_must_be_a_connection():
    with pytest.raises(TypeError, match="space"):
        frechet_mean("sphere", np.zeros((1, 3)))


@pytest.mark.parametrize("key", ["S2", "H2", "SPD3"])
def test_agrees_with_geomstats_frechet_mean(key):
    pytest.importorskip("manifolds.interop.geomstats")  # aliases numpy.trapz for geomstats 2.8
    gs_geometry = pytest.importorskip("geomstats.geometry")
    from geomstats.geometry.hyperboloid import Hyperboloid
    from geomstats.geometry.hypersphere import Hypersphere as GsSphere
    from geomstats.geometry.spd_matrices import SPDMatrices as GsSPD
    from geomstats.learning.frechet_mean import FrechetMean

    assert gs_geometry is not None
    ours, theirs = {
        "S2": (Hypersphere(2), GsSphere(2)),
        "H2": (Hyperbolic(2), Hyperboloid(2)),
        "SPD3": (SPDMatrices(3), GsSPD(3)),
    }[key]
    rng = np.random.default_rng(4)
    base = ours.random_point(rng)
    pts = np.stack([ours.exp(base, ours.random_tangent(base, rng, scale=0.6)) for _ in range(8)])
    w = rng.uniform(0.2, 1.0, 8)
    estimator = FrechetMean(theirs)
    estimator.optimizer.epsilon = 1e-14
    estimator.optimizer.max_iter = 500
    estimator.fit(pts, weights=w)
    res = frechet_mean(ours, pts, w, tol=1e-13)
    assert res.converged
    np.testing.assert_allclose(res.mean, estimator.estimate_, atol=1e-8 * np.abs(res.mean).max())


def test_map_logs_computes_the_logs_the_callers_way():
    """A caller's ``map_logs`` (here, the points' logs in reverse order, put back) gives the
    same iteration; it is called once per evaluation with the iterate; a wrong count is
    refused."""
    space = Hypersphere(2)
    pts = ring(0.4, 5, lambda a: (np.sin(a), np.cos(a)))
    pts[0] = pts[0] + 0.1
    pts /= np.linalg.norm(pts, axis=1, keepdims=True)
    seen = []

    def reverse(x, points):
        seen.append(np.array(x))
        return [space.log(x, p) for p in points[::-1]][::-1]

    ref = frechet_mean(space, pts, tol=1e-12)
    res = frechet_mean(space, pts, tol=1e-12, map_logs=reverse)
    np.testing.assert_allclose(res.mean, ref.mean, atol=1e-14)
    assert res.n_iter == ref.n_iter and len(seen) == res.n_iter + 1
    np.testing.assert_array_equal(seen[0], pts[0])
    with pytest.raises(ManifoldError, match="map_logs: returned 4 logarithms for 5 points"):
        frechet_mean(space, pts, map_logs=lambda x, p: reverse(x, p)[:4])
