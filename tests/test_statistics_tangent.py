"""Tangent statistics at one point, on spaces with known answers (Euclidean, sphere, SPD)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ladders.statistics import mode_shapes, normalize_amplitude, tangent_mean, tangent_pca
from manifolds import Euclidean, Hypersphere, LDDMMLandmarks, ResidualAugmented, SPDMatrices


def _orthonormal(space, base, vectors):
    """Gram-Schmidt in the space's inner product."""
    out = []
    for v in vectors:
        for e in out:
            v = v - space.inner(base, v, e) * e
        out.append(v / np.sqrt(space.inner(base, v, v)))
    return out


def _low_rank(space, base, directions, sds, n, rng):
    coefficients = rng.standard_normal((n, len(directions))) * np.asarray(sds)
    coefficients -= coefficients.mean(axis=0)
    return [sum(c * e for c, e in zip(row, directions)) for row in coefficients], coefficients


@settings(max_examples=20, deadline=None)
@given(st.integers(2, 12), st.integers(0, 2**31 - 1))
def test_mean_of_euclidean_tangents_is_the_numpy_mean(n, seed):
    rng = np.random.default_rng(seed)
    space = Euclidean((4, 3))
    u = rng.standard_normal((n, 4, 3))
    np.testing.assert_allclose(tangent_mean(space, np.zeros((4, 3)), u), u.mean(axis=0), atol=1e-12)


@pytest.mark.parametrize("space, base", [
    (Hypersphere(4), np.array([0.0, 0.0, 0.0, 0.0, 1.0])),
    (SPDMatrices(3), np.array([[2.0, 0.3, 0.0], [0.3, 1.0, 0.2], [0.0, 0.2, 0.5]])),
])  # fmt: skip
def test_tangent_pca_recovers_planted_modes_in_the_space_metric(space, base):
    rng = np.random.default_rng(0)
    raw = [space.random_tangent(base, rng) for _ in range(2)]
    directions = _orthonormal(space, base, raw)
    tangents, coefficients = _low_rank(space, base, directions, (2.0, 0.5), 400, rng)
    pca = tangent_pca(space, base, tangents)
    assert pca.metric == "space" and pca.n_components == 2  # the data have rank 2
    for k in range(2):
        cosine = space.inner(base, pca.components[k], directions[k])
        assert abs(cosine) > 0.99
        for j in range(2):
            assert space.inner(base, pca.components[k], pca.components[j]) == pytest.approx(
                float(k == j), abs=1e-9
            )
    expected = np.sort(np.var(coefficients, axis=0, ddof=1))[::-1]
    np.testing.assert_allclose(pca.variances, expected, rtol=0.05)
    np.testing.assert_allclose(pca.explained_variance_ratio.sum(), 1.0, atol=1e-12)
    np.testing.assert_allclose(pca.transform(space, tangents), pca.scores, atol=1e-9)
    rebuilt = pca.reconstruct(pca.scores)
    np.testing.assert_allclose(np.stack(rebuilt), np.stack(tangents), atol=1e-9)


def test_the_metric_matters_on_spd():
    space = SPDMatrices(2)
    base = np.diag([4.0, 0.25])  # the affine-invariant metric weighs the axes 1/16 and 16
    rng = np.random.default_rng(1)
    tangents = [np.diag([a, b]) for a, b in rng.standard_normal((1000, 2)) * [2.0, 0.2]]
    curved = tangent_pca(space, base, tangents, metric="space")
    flat = tangent_pca(space, base, tangents, metric="flat")
    assert flat.metric == "flat"
    # flat: the first mode is the large (0, 0) entry (variance 4 against 0.04); in the
    # metric, |diag(a, b)|^2 = a^2 / 16 + 16 b^2, the (1, 1) entry has the larger variance
    # (0.04 * 16 = 0.64 against 4 / 16 = 0.25)
    assert abs(flat.components[0][0, 0]) > 0.99
    whitened = np.diag(curved.components[0]) / np.diag(base)  # P^-1/2 U P^-1/2 on a diagonal
    assert abs(whitened[1]) > 0.98 and abs(whitened[0]) < 0.2


def test_auto_metric_falls_back_to_flat_without_an_inner_product():
    class NoMetric(Euclidean):
        def inner(self, point, u, v):
            raise NotImplementedError("no metric")

    rng = np.random.default_rng(2)
    pca = tangent_pca(NoMetric(3), np.zeros(3), rng.standard_normal((10, 3)))
    assert pca.metric == "flat"


def test_mode_shapes_and_amplitude_on_the_sphere():
    space = Hypersphere(2)
    base = np.array([0.0, 0.0, 1.0])
    rng = np.random.default_rng(3)
    tangents = [np.array([a, b, 0.0]) for a, b in rng.standard_normal((50, 2)) * [0.3, 0.05]]
    pca = tangent_pca(space, base, tangents)
    shapes = mode_shapes(space, base, pca, mode=0, ks=(-1.0, 0.0, 1.0))
    np.testing.assert_allclose(shapes[1], space.exp(base, pca.mean), atol=1e-12)
    sd = pca.standard_deviations[0]
    assert space.dist(shapes[0], shapes[2]) == pytest.approx(2 * sd, rel=0.05)
    u = np.array([0.2, 0.1, 0.0])
    scaled, lam = normalize_amplitude(space, base, u, lambda p: space.dist(base, p), 0.6)
    assert lam == pytest.approx(0.6 / np.linalg.norm(u), rel=1e-9)
    np.testing.assert_allclose(scaled, lam * u)
    with pytest.raises(ValueError, match="always on one side"):
        normalize_amplitude(space, base, u, lambda p: space.dist(base, p), 5.0, bracket=(0, 1))


def test_normalize_amplitude_finds_the_first_crossing_of_a_measure_that_turns_back():
    """``d (3 - d)`` of the distance ``d`` rises to 2.25 then falls below 0 at the bracket's
    end: the ends are on one side of the target 2, the roots at ``d = 1`` and ``d = 2``;
    the smallest scale that reaches the target is returned."""
    space = Euclidean((3,))
    base, u = np.zeros(3), np.array([0.6, 0.0, 0.8])

    def measure(p):
        d = space.dist(base, p)
        return d * (3.0 - d)

    _, lam = normalize_amplitude(space, base, u, measure, 2.0, bracket=(0.0, 4.0))
    assert lam == pytest.approx(1.0, abs=1e-9)


def test_pca_of_residual_tangents_of_lddmm_uses_the_product_metric():
    space = ResidualAugmented(LDDMMLandmarks(6, 2, sigma=1.0, alpha=1.0))
    rng = np.random.default_rng(4)
    base = space.random_point(rng)
    tangents = [space.random_tangent(base, rng, scale=0.3) for _ in range(8)]
    pca = tangent_pca(space, base, tangents, n_components=3)
    assert pca.metric == "space" and pca.n_components == 3
    for k in range(3):
        assert space.inner(base, pca.components[k], pca.components[k]) == pytest.approx(1.0)


def test_bad_inputs_name_the_argument():
    space = Euclidean(2)
    with pytest.raises(ValueError, match="at least 2"):
        tangent_pca(space, np.zeros(2), [np.ones(2)])
    with pytest.raises(ValueError, match="NaN"):
        tangent_mean(space, np.zeros(2), [np.array([np.nan, 0.0])])
    with pytest.raises(ValueError, match="metric"):
        tangent_pca(space, np.zeros(2), np.eye(2), metric="riemann")
    with pytest.raises(ValueError, match="n_components"):
        tangent_pca(space, np.zeros(2), np.eye(2) + 1, n_components=0)
