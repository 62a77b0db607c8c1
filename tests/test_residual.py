"""Residual-augmented space on a flat space with a regularised (inexact) log."""

import numpy as np
import pytest

from ladders import pole_ladder, symmetry_errors
from manifolds import Euclidean
from manifolds.residual import ResidualAugmented, ResidualTangent
from manifolds.testing import ConnectionContract


class RegularisedEuclidean(Euclidean):
    """Flat space whose log solves ``min_v |b - (a + v)|^2 + alpha^2 |v|^2``.

    The minimiser ``v = (b - a) / (1 + alpha^2)`` undershoots like a regularised
    registration; ``alpha -> infinity`` gives ``v -> 0`` (the PDM limit).
    """

    is_symmetric = False

    def __init__(self, shape, alpha):
        super().__init__(shape)
        self.alpha = alpha

    def log(self, point, other):
        return super().log(point, other) / (1.0 + self.alpha**2)

    def midpoint(self, a, b):
        return self.exp(a, 0.5 * self.log(a, b))

    def symmetry(self, center, point):
        return self.exp(center, -self.log(center, point))


class TestResidualOverExactSpace(ConnectionContract):
    """Wrapping a space with an exact log changes nothing (residuals vanish)."""

    space = ResidualAugmented(Euclidean((5, 2)))

    def pair(self, rng):
        a = self.space.random_point(rng)
        b = a + 0.5 * rng.standard_normal(a.shape)
        return a, b, self.space.log(a, b)

    def tangent_arrays(self, v):
        return [v.tangent, v.residual]

    def corrupt_tangent(self, v):
        tangent = np.array(v.tangent, copy=True)
        tangent.flat[0] = np.nan
        return ResidualTangent(tangent, v.residual)

    def test_bad_residual_raises(self):
        from manifolds import ManifoldError

        a = np.zeros((5, 2))
        with pytest.raises(ManifoldError, match="residual"):
            self.space.exp(a, ResidualTangent(np.zeros((5, 2)), np.full((5, 2), np.nan)))
        with pytest.raises(ManifoldError, match="other"):
            self.space.log(a, np.full((5, 2), np.nan))


@pytest.mark.parametrize("alpha", [0.1, 1.0, 10.0])
def test_residuals_make_exp_log_exact(alpha):
    rng = np.random.default_rng(1)
    space = ResidualAugmented(RegularisedEuclidean((6, 3), alpha))
    t, s = rng.standard_normal((2, 6, 3))
    np.testing.assert_allclose(space.exp(t, space.log(t, s)), s, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(space.symmetry(t, t), t)
    # Residuals restore the flat symmetric structure exactly: s_T(S) = 2T - S.
    np.testing.assert_allclose(space.symmetry(t, s), 2 * t - s, atol=1e-12)
    np.testing.assert_allclose(space.midpoint(t, s), 0.5 * (t + s), atol=1e-12)


def test_without_residuals_errors_grow_with_alpha():
    rng = np.random.default_rng(2)
    t, s, s2 = rng.standard_normal((3, 6, 3))
    previous = -1.0
    for alpha in (0.1, 0.5, 1.0, 3.0):
        base = RegularisedEuclidean((6, 3), alpha)
        with_res = symmetry_errors(ResidualAugmented(base, True), t, s, s2)
        without = symmetry_errors(ResidualAugmented(base, False), t, s, s2)
        for name in ("midpoint_distance", "centrality", "involutivity", "transvectivity"):
            assert getattr(with_res, name) < 1e-12
        # Centrality of the shrunk symmetry: |s_M(T) - S| with M = T + (S-T)/(2(1+a^2)),
        # per-vertex RMS over the 6 vertices (the default distance).
        lam = 1.0 / (1.0 + alpha**2)
        m = t + 0.5 * lam * (s - t)
        expected = np.linalg.norm(m - lam * (t - m) - s) / np.sqrt(6)
        np.testing.assert_allclose(without.centrality, expected, rtol=1e-12)
        assert without.centrality > previous
        previous = without.centrality


def test_pole_ladder_runs_and_is_exact_with_residuals():
    rng = np.random.default_rng(3)
    base = RegularisedEuclidean((4, 2), alpha=2.0)
    space = ResidualAugmented(base)
    s, t, s2 = rng.standard_normal((3, 4, 2))
    u = space.log(s, s2)
    for n in (1, 2, 5):
        w, traj = pole_ladder(space, s, t, u, n_rungs=n, return_trajectory=True)
        # With residuals the space is exactly flat: T' = T + (S' - S).
        np.testing.assert_allclose(traj.end_point, t + s2 - s, atol=1e-11)
    plain = ResidualAugmented(base, use_residuals=False)
    w_plain, traj = pole_ladder(plain, s, t, plain.log(s, s2), return_trajectory=True)
    assert np.all(w_plain.residual == 0)
    assert np.linalg.norm(traj.end_point - (t + s2 - s)) > 0.1


def test_tangent_arithmetic():
    u = ResidualTangent(np.ones(3), 2 * np.ones((2, 2)))
    w = 2.0 * u - u / 2.0 + (-u)
    np.testing.assert_allclose(w.tangent, 0.5 * np.ones(3))
    np.testing.assert_allclose(w.residual, np.ones((2, 2)))
    with pytest.raises(TypeError):
        _ = u * np.ones(3)
