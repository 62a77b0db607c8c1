"""Hyperbolic space (hyperboloid model): generic contract plus closed-form checks."""

import numpy as np
import pytest

from manifolds.errors import ManifoldError, NotOnManifoldError, NotTangentError
from manifolds.hyperbolic import Hyperbolic, minkowski_inner
from manifolds.testing import ConnectionContract, assert_curvature_matches_distance_expansion


def unit_tangent(space, x, rng):
    v = space.random_tangent(x, rng)
    return v / np.sqrt(minkowski_inner(v, v))[..., None]


def lift(z):
    """Point of the hyperboloid above ``z`` in ``R^n``."""
    return np.concatenate([np.sqrt(1 + np.sum(z**2, -1, keepdims=True)), z], -1)


class TestHyperbolic2(ConnectionContract):
    space = Hyperbolic(2)
    far_scale = 4.0
    far_rtol = 1e-6  # coordinates ~e^8: the hyperboloid loses ~eps x_0^2 relative


class TestHyperbolic3(ConnectionContract):
    space = Hyperbolic(3)
    far_scale = 6.0
    far_rtol = 1e-6  # coordinates ~e^8: the hyperboloid loses ~eps x_0^2 relative
    tangent_scale = 1.0

    def test_dist_is_arccosh(self):
        rng = np.random.default_rng(10)
        x = self.space.random_point(rng, 50)
        t = rng.uniform(0.2, 4.0, 50)
        y = np.cosh(t)[:, None] * x + np.sinh(t)[:, None] * unit_tangent(self.space, x, rng)
        np.testing.assert_allclose(self.space.dist(x, y), t, rtol=1e-11)
        np.testing.assert_allclose(
            self.space.dist(x, y), np.arccosh(-minkowski_inner(x, y)), rtol=1e-9
        )
        np.testing.assert_allclose(self.space.norm(x, self.space.log(x, y)), t, rtol=1e-11)

    def test_exp_and_log_of_tiny_vectors(self):
        # arccosh(-<x, y>_L) would be off by ~1e-8 absolute for t = 1e-9; the
        # attainable error is the round-off of the coordinates of y (~1e-15 here).
        rng = np.random.default_rng(11)
        x = self.space.random_point(rng)
        e = unit_tangent(self.space, x, rng)
        for t in (1e-5, 1e-9, 1e-200):
            expected = (1.0 + t * t / 2) * x + (1.0 + t * t / 6) * t * e
            y = self.space.exp(x, t * e)
            np.testing.assert_allclose(y, expected, rtol=1e-15, atol=1e-300)
            if t > 1e-100:
                assert np.linalg.norm(self.space.log(x, y) - t * e) < 1e-14
        np.testing.assert_array_equal(self.space.log(x, x), np.zeros(4))


class TestHyperbolicSpecific:
    space = Hyperbolic(3)

    def test_belongs(self):
        rng = np.random.default_rng(0)
        x = self.space.random_point(rng, 5)
        assert np.all(self.space.belongs(x))
        assert not np.any(self.space.belongs(-x))  # lower sheet
        assert not np.any(self.space.belongs(1.01 * x))
        assert not self.space.belongs(np.zeros(4))
        assert not self.space.belongs(np.ones(3))  # wrong shape
        far = lift(np.array([300.0, -200.0, 100.0]))  # distance ~ 6.6 from the origin
        assert self.space.belongs(far)
        assert self.space.belongs(1.001 * x[0], atol=1e-2)

    def test_bad_input_raises_naming_argument(self):
        x = lift(np.array([0.3, 0.1, -0.2]))
        with pytest.raises(NotOnManifoldError, match="other"):
            self.space.log(x, -x)
        with pytest.raises(NotOnManifoldError, match="point"):
            self.space.exp(np.array([1.0, 1.0, 0.0, 0.0]), np.zeros(4))
        with pytest.raises(ManifoldError, match="end.*NaN"):
            self.space.parallel_transport(x, np.full(4, np.nan), np.zeros(4))
        with pytest.raises(NotTangentError, match="tangent"):
            self.space.exp(x, x)
        with pytest.raises(ManifoldError, match="u"):
            self.space.inner(x, np.zeros(3), np.zeros(4))

    def test_sectional_curvature_is_minus_one(self):
        rng = np.random.default_rng(20)
        x = self.space.random_point(rng, 10)
        u, v = self.space.random_tangent(x, rng), self.space.random_tangent(x, rng)
        r = self.space.curvature(x, u, v, v)
        inner = self.space.inner
        k = inner(x, r, u) / (inner(x, u, u) * inner(x, v, v) - inner(x, u, v) ** 2)
        np.testing.assert_allclose(k, -1.0, rtol=1e-10)
        zero = self.space.curvature_derivative(x, u, v, u, v)
        assert zero.shape == x.shape and not zero.any()

    def test_curvature_matches_distance_expansion(self):
        rng = np.random.default_rng(21)
        assert_curvature_matches_distance_expansion(self.space, rng, rtol=1e-3, sign=-1)

    def test_transport_closed_form(self):
        rng = np.random.default_rng(22)
        x = self.space.random_point(rng, 20)
        y = self.space.exp(x, self.space.random_tangent(x, rng, scale=1.5))
        e = self.space.log(x, y)
        theta = self.space.norm(x, e)[:, None]
        e /= theta
        # Components orthogonal to the geodesic are unchanged (the ambient vector is fixed).
        n = self.space.random_tangent(x, rng)
        n -= self.space.inner(x, n, e)[:, None] * e
        np.testing.assert_allclose(self.space.parallel_transport(x, y, n), n, rtol=0, atol=1e-13)
        velocity_end = np.sinh(theta) * x + np.cosh(theta) * e
        np.testing.assert_allclose(
            self.space.parallel_transport(x, y, e), velocity_end, rtol=0, atol=1e-12
        )

    def test_symmetry_and_midpoint_closed_forms(self):
        rng = np.random.default_rng(23)
        m, z = self.space.random_point(rng, 6), self.space.random_point(rng, 6)
        by_maps = self.space.exp(m, -self.space.log(m, z))
        np.testing.assert_allclose(self.space.symmetry(m, z), by_maps, rtol=1e-11)
        half = self.space.exp(m, 0.5 * self.space.log(m, z))
        np.testing.assert_allclose(self.space.midpoint(m, z), half, rtol=1e-11)
        np.testing.assert_allclose(self.space.midpoint(z, m), half, rtol=1e-11)

    def test_batch_broadcasting(self):
        rng = np.random.default_rng(24)
        x = self.space.random_point(rng)
        v = self.space.random_tangent(np.broadcast_to(x, (3, 2, 4)), rng)
        out = self.space.exp(x, v)
        assert out.shape == (3, 2, 4)
        np.testing.assert_allclose(out[2, 1], self.space.exp(x, v[2, 1]), rtol=1e-15)
        y = self.space.random_point(rng, 5)
        u = self.space.random_tangent(x, rng)
        moved = self.space.parallel_transport(x, y, u)
        assert moved.shape == (5, 4)
        np.testing.assert_allclose(moved[4], self.space.parallel_transport(x, y[4], u), rtol=1e-15)
        assert self.space.log(y, x).shape == (5, 4)

    def test_random_tangent_scale(self):
        rng = np.random.default_rng(25)
        x = self.space.random_point(rng, 4000)
        v = self.space.random_tangent(x, rng, scale=0.3)
        assert np.all(self.space.is_tangent(x, v, atol=1e-12))
        np.testing.assert_allclose(np.mean(minkowski_inner(v, v)), 0.09, rtol=0.05)
