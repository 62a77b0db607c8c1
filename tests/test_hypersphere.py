"""Hypersphere: generic contract plus closed-form checks."""

import numpy as np
import pytest

from manifolds.errors import CutLocusError, ManifoldError, NotOnManifoldError, NotTangentError
from manifolds.hypersphere import Hypersphere
from manifolds.testing import ConnectionContract, assert_curvature_matches_distance_expansion


def unit_tangent(space, x, rng):
    v = space.random_tangent(x, rng)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


class TestHypersphere2(ConnectionContract):
    space = Hypersphere(2)
    far_scale = 2.5
    tangent_scale = 0.8


class TestHypersphere5(ConnectionContract):
    space = Hypersphere(5)
    far_scale = 2.5
    tangent_scale = 1.0

    def test_dist_is_arccos_of_dot(self):
        rng = np.random.default_rng(10)
        x = self.space.random_point(rng, 50)
        angles = rng.uniform(0.1, 3.0, 50)
        y = np.cos(angles)[:, None] * x + np.sin(angles)[:, None] * unit_tangent(self.space, x, rng)
        np.testing.assert_allclose(self.space.dist(x, y), angles, rtol=1e-13)
        np.testing.assert_allclose(self.space.dist(x, y), np.arccos((x * y).sum(-1)), rtol=1e-12)
        np.testing.assert_allclose(
            np.linalg.norm(self.space.log(x, y), axis=-1), angles, rtol=1e-13
        )

    def test_exp_of_tiny_vector_is_accurate(self):
        rng = np.random.default_rng(11)
        x = self.space.random_point(rng)
        e = unit_tangent(self.space, x, rng)
        for t in (1e-5, 1e-9, 1e-13, 1e-200):
            # Taylor series exact to double precision at these sizes.
            expected = (1.0 - t * t / 2) * x + (1.0 - t * t / 6) * t * e
            np.testing.assert_allclose(self.space.exp(x, t * e), expected, rtol=0, atol=3e-16)
        np.testing.assert_array_equal(self.space.exp(x, np.zeros(6)), x)

    def test_log_of_nearby_point_keeps_relative_accuracy(self):
        # arccos(<x, y>) would lose about half the digits here (relative error ~1e-2).
        rng = np.random.default_rng(12)
        x = self.space.random_point(rng)
        e = unit_tangent(self.space, x, rng)
        for t in (1e-4, 1e-6, 1e-8):
            y = np.cos(t) * x + np.sin(t) * e
            v = self.space.log(x, y)
            assert np.linalg.norm(v - t * e) / t < 1e-7
        np.testing.assert_array_equal(self.space.log(x, x), np.zeros(6))

    def test_log_near_pi(self):
        rng = np.random.default_rng(13)
        x = self.space.random_point(rng)
        e = unit_tangent(self.space, x, rng)
        t = np.pi - 1e-4
        y = np.cos(t) * x + np.sin(t) * e
        np.testing.assert_allclose(self.space.log(x, y), t * e, rtol=0, atol=1e-11)


class TestHypersphereSpecific:
    space = Hypersphere(2)

    def test_cut_locus_raises(self):
        x = np.array([0.0, 0.0, 1.0])
        near = np.array([1e-12, 0.0, -1.0])
        near /= np.linalg.norm(near)
        for y in (-x, near):
            with pytest.raises(CutLocusError, match="antipodal"):
                self.space.log(x, y)
            with pytest.raises(CutLocusError):
                self.space.midpoint(x, y)
            with pytest.raises(CutLocusError, match="end"):
                self.space.parallel_transport(x, y, np.array([1.0, 0.0, 0.0]))
        # The distance is still defined at the cut locus.
        np.testing.assert_allclose(self.space.dist(x, -x), np.pi, rtol=1e-15)

    def test_off_manifold_raises_naming_argument(self):
        x = np.array([1.0, 0.0, 0.0])
        with pytest.raises(NotOnManifoldError, match="other"):
            self.space.log(x, 2 * x)
        with pytest.raises(NotOnManifoldError, match="point"):
            self.space.exp(1.01 * x, np.array([0.0, 1.0, 0.0]))
        with pytest.raises(NotOnManifoldError, match="center"):
            self.space.symmetry(np.zeros(3), x)
        with pytest.raises(ManifoldError, match="end"):
            self.space.parallel_transport(x, np.array([0.0, np.inf, 0.0]), x)
        assert not self.space.belongs(1.001 * x)
        assert self.space.belongs(1.001 * x, atol=1e-2)
        np.testing.assert_array_equal(self.space.belongs(np.stack([x, 3 * x])), [True, False])

    def test_non_tangent_raises(self):
        x = np.array([1.0, 0.0, 0.0])
        with pytest.raises(NotTangentError, match="tangent"):
            self.space.exp(x, np.array([0.1, 1.0, 0.0]))
        assert not self.space.is_tangent(x, np.array([0.1, 1.0, 0.0]))

    def test_sectional_curvature_is_one(self):
        rng = np.random.default_rng(20)
        x = self.space.random_point(rng, 10)
        u, v = self.space.random_tangent(x, rng), self.space.random_tangent(x, rng)
        r = self.space.curvature(x, u, v, v)
        inner = self.space.inner
        k = inner(x, r, u) / (inner(x, u, u) * inner(x, v, v) - inner(x, u, v) ** 2)
        np.testing.assert_allclose(k, 1.0, rtol=1e-12)
        zero = self.space.curvature_derivative(x, u, v, u, v)
        assert zero.shape == x.shape and not zero.any()

    def test_curvature_matches_distance_expansion(self):
        rng = np.random.default_rng(21)
        assert_curvature_matches_distance_expansion(Hypersphere(4), rng, rtol=1e-3, sign=1)

    def test_transport_closed_form(self):
        rng = np.random.default_rng(22)
        x = self.space.random_point(rng, 20)
        y = self.space.exp(x, self.space.random_tangent(x, rng, scale=1.5))
        e = self.space.log(x, y)
        theta = np.linalg.norm(e, axis=-1, keepdims=True)
        e /= theta
        # The normal of the great circle plane is parallel along it.
        normal = np.cross(x, e)
        np.testing.assert_allclose(
            self.space.parallel_transport(x, y, normal), normal, rtol=0, atol=1e-14
        )
        # The unit velocity goes to the unit velocity at the end.
        velocity_end = -np.sin(theta) * x + np.cos(theta) * e
        np.testing.assert_allclose(
            self.space.parallel_transport(x, y, e), velocity_end, rtol=0, atol=1e-14
        )

    def test_batch_broadcasting(self):
        rng = np.random.default_rng(23)
        x = self.space.random_point(rng)
        v = self.space.random_tangent(np.broadcast_to(x, (2, 4, 3)), rng)
        y = self.space.random_point(rng, 4)
        out = self.space.exp(x, v)
        assert out.shape == (2, 4, 3)
        np.testing.assert_allclose(out[1, 2], self.space.exp(x, v[1, 2]), rtol=0, atol=1e-15)
        logs = self.space.log(x, y)
        assert logs.shape == (4, 3)
        np.testing.assert_allclose(logs[3], self.space.log(x, y[3]), rtol=0, atol=1e-15)
        u = self.space.random_tangent(x, rng)
        moved = self.space.parallel_transport(x, y, u)
        np.testing.assert_allclose(
            moved[0], self.space.parallel_transport(x, y[0], u), rtol=0, atol=1e-15
        )
        assert self.space.dist(x, y).shape == (4,)

    def test_random_tangent_scale(self):
        rng = np.random.default_rng(24)
        x = self.space.random_point(rng, 4000)
        v = self.space.random_tangent(x, rng, scale=0.3)
        assert np.all(self.space.is_tangent(x, v, atol=1e-14))
        np.testing.assert_allclose(np.mean(np.sum(v**2, -1)), 0.09, rtol=0.05)
