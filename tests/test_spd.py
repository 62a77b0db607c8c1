"""SPD matrices with the affine-invariant metric: contract plus closed-form checks."""

import numpy as np
import pytest
from scipy.linalg import expm, logm, sqrtm

from manifolds.errors import ManifoldError, NotOnManifoldError, NotTangentError
from manifolds.spd import SPDMatrices
from manifolds.testing import ConnectionContract, assert_curvature_matches_distance_expansion


class TestSPD2(ConnectionContract):
    space = SPDMatrices(2)
    far_scale = 4.0


class TestSPD3(ConnectionContract):
    space = SPDMatrices(3)
    far_scale = 4.0
    tangent_scale = 1.0
    rtol = 1e-9
    atol = 1e-9


class TestSPDSpecific:
    space = SPDMatrices(3)

    def test_maps_against_general_matrix_functions(self):
        rng = np.random.default_rng(0)
        p, q = self.space.random_point(rng), self.space.random_point(rng)
        v = self.space.random_tangent(p, rng)
        ph = np.real(sqrtm(p))
        pih = np.linalg.inv(ph)
        np.testing.assert_allclose(self.space.exp(p, v), ph @ expm(pih @ v @ pih) @ ph, rtol=1e-11)
        np.testing.assert_allclose(
            self.space.log(p, q), ph @ np.real(logm(pih @ q @ pih)) @ ph, rtol=1e-9, atol=1e-11
        )
        np.testing.assert_allclose(self.space.symmetry(p, q), p @ np.linalg.solve(q, p), rtol=1e-11)
        np.testing.assert_allclose(
            self.space.midpoint(p, q), ph @ np.real(sqrtm(pih @ q @ pih)) @ ph, rtol=1e-10
        )

    def test_exp_at_identity_is_expm(self):
        rng = np.random.default_rng(1)
        v = self.space.random_tangent(np.eye(3), rng, scale=2.0)
        np.testing.assert_allclose(self.space.exp(np.eye(3), v), expm(v), rtol=1e-12)

    def test_affine_invariance(self):
        rng = np.random.default_rng(2)
        p, q = self.space.random_point(rng, 4), self.space.random_point(rng, 4)
        a = rng.standard_normal((3, 3)) + 3 * np.eye(3)
        act = a @ p @ a.T, a @ q @ a.T
        np.testing.assert_allclose(self.space.dist(*act), self.space.dist(p, q), rtol=1e-10)
        np.testing.assert_allclose(
            self.space.log(*act), a @ self.space.log(p, q) @ a.T, rtol=1e-9, atol=1e-10
        )

    def test_non_spd_raises_naming_argument(self):
        p = np.diag([1.0, 2.0, 3.0])
        not_sym = p + np.triu(np.ones((3, 3)), 1)
        indefinite = np.diag([1.0, -2.0, 3.0])
        with pytest.raises(NotOnManifoldError, match="other.*symmetric"):
            self.space.log(p, not_sym)
        with pytest.raises(NotOnManifoldError, match="other.*positive definite"):
            self.space.log(p, indefinite)
        with pytest.raises(NotOnManifoldError, match="point.*positive definite"):
            self.space.exp(indefinite, p)
        with pytest.raises(NotOnManifoldError, match="center"):
            self.space.symmetry(indefinite, p)
        with pytest.raises(NotOnManifoldError, match="end"):
            self.space.parallel_transport(p, np.zeros((3, 3)), p)
        with pytest.raises(NotTangentError, match="tangent"):
            self.space.exp(p, not_sym)
        with pytest.raises(ManifoldError, match="point"):
            self.space.log(np.eye(2), p)
        np.testing.assert_array_equal(
            self.space.belongs(np.stack([p, not_sym, indefinite, np.full((3, 3), np.nan)])),
            [True, False, False, False],
        )

    def test_sectional_curvature_is_non_positive(self):
        rng = np.random.default_rng(3)
        p = self.space.random_point(rng, 20)
        u, v = self.space.random_tangent(p, rng), self.space.random_tangent(p, rng)
        inner = self.space.inner
        k = inner(p, self.space.curvature(p, u, v, v), u) / (
            inner(p, u, u) * inner(p, v, v) - inner(p, u, v) ** 2
        )
        assert np.all(k <= 1e-14)
        assert np.all(k >= -0.5 - 1e-12)  # bound of SPD(n) with this metric
        assert np.any(k < -1e-3)
        # Commuting directions span a flat.
        d = np.diag([1.0, 2.0, 3.0])
        r = self.space.curvature(d, np.diag([1.0, 0, 0]), np.diag([0, 1.0, 0]), np.eye(3))
        np.testing.assert_allclose(r, 0.0, atol=1e-15)
        zero = self.space.curvature_derivative(p, u, v, u, v)
        assert zero.shape == p.shape and not zero.any()

    def test_curvature_matches_distance_expansion(self):
        rng = np.random.default_rng(4)
        assert_curvature_matches_distance_expansion(self.space, rng, rtol=2e-3, sign=-1)

    def test_transport_matches_ode(self):
        # Along gamma(t) = Exp_P(t V), gamma' gamma^-1 = V P^-1 is constant and the
        # transport solves U' = (A U + U A^T) / 2 with A = V P^-1; integrate with RK4.
        rng = np.random.default_rng(5)
        p = self.space.random_point(rng)
        v = self.space.random_tangent(p, rng, scale=1.2)
        u = self.space.random_tangent(p, rng)
        a = v @ np.linalg.inv(p)

        def rhs(x):
            return 0.5 * (a @ x + x @ a.T)

        x, h = u.copy(), 1.0 / 200
        for _ in range(200):
            k1 = rhs(x)
            k2 = rhs(x + h / 2 * k1)
            k3 = rhs(x + h / 2 * k2)
            k4 = rhs(x + h * k3)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        q = self.space.exp(p, v)
        np.testing.assert_allclose(self.space.parallel_transport(p, q, u), x, rtol=1e-9, atol=1e-10)

    def test_velocity_is_transported_to_velocity(self):
        # Independent check of the geodesic velocity: d/dt Exp_P(t V) at t = 1.
        rng = np.random.default_rng(6)
        p = self.space.random_point(rng)
        v = self.space.random_tangent(p, rng)
        h = 1e-5
        fd = (self.space.exp(p, (1 + h) * v) - self.space.exp(p, (1 - h) * v)) / (2 * h)
        q = self.space.exp(p, v)
        np.testing.assert_allclose(self.space.parallel_transport(p, q, v), fd, rtol=1e-7, atol=1e-8)

    def test_batch_broadcasting(self):
        rng = np.random.default_rng(7)
        p = self.space.random_point(rng)
        v = self.space.random_tangent(np.broadcast_to(p, (2, 3, 3, 3)), rng)
        out = self.space.exp(p, v)
        assert out.shape == (2, 3, 3, 3)
        np.testing.assert_allclose(out[1, 2], self.space.exp(p, v[1, 2]), rtol=1e-13)
        q = self.space.random_point(rng, 4)
        moved = self.space.parallel_transport(p, q, v[0, 0])
        assert moved.shape == (4, 3, 3)
        np.testing.assert_allclose(
            moved[3], self.space.parallel_transport(p, q[3], v[0, 0]), rtol=1e-13
        )
        assert self.space.dist(q, p).shape == (4,)
        assert self.space.symmetry(p, q).shape == (4, 3, 3)

    def test_random_tangent_scale(self):
        rng = np.random.default_rng(8)
        p = self.space.random_point(rng, 3000)
        v = self.space.random_tangent(p, rng, scale=0.3)
        np.testing.assert_array_equal(v, np.swapaxes(v, -1, -2))
        np.testing.assert_allclose(np.mean(self.space.inner(p, v, v)), 0.09, rtol=0.05)
