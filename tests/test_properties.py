"""Property-based tests over every space, with hypothesis-drawn distances and batch sizes.

The contract of :mod:`manifolds.testing` draws seeds at a fixed tangent size;
here the size of the tangent (up to far from the base point), the batch size
and the landmark configuration are drawn too. Tolerances are relative to the
size of what is compared, as the coordinates of the hyperbolic space grow like
``e^dist``.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from manifolds import (
    Euclidean,
    Hyperbolic,
    Hypersphere,
    LDDMMLandmarks,
    PoincareHalfPlane,
    ResidualAugmented,
    RiemannianManifold,
    SPDMatrices,
    WarpedSurface,
)
from manifolds.residual import ResidualTangent

SEEDS = st.integers(0, 2**32 - 1)

# name -> (space, largest geodesic length drawn, relative tolerance, examples)
CLOSED = {
    "Euclidean(3, 2)": (Euclidean((3, 2)), 1e4, 1e-12, 40),
    "Hypersphere(2)": (Hypersphere(2), 3.0, 1e-9, 40),
    "Hypersphere(4)": (Hypersphere(4), 3.0, 1e-9, 40),
    "Hyperbolic(2)": (Hyperbolic(2), 7.0, 1e-6, 40),
    "Hyperbolic(3)": (Hyperbolic(3), 7.0, 1e-6, 40),
    "SPDMatrices(3)": (SPDMatrices(3), 6.0, 1e-8, 40),
}
ODE = {
    "PoincareHalfPlane": (PoincareHalfPlane(), 1.5, 1e-7, 4),
    "WarpedSurface": (WarpedSurface(), 1.5, 1e-7, 4),
}
ALL = {**CLOSED, **ODE}


def unit_tangent(space, point, rng, length):
    """A random tangent at ``point`` of Riemannian norm ``length``."""
    v = space.random_tangent(point, rng)
    return v * (length / space.norm(point, v))


def assert_relative(x, y, rtol):
    """``x == y`` up to ``rtol`` times the size of ``y`` (at least 1)."""
    scale = max(float(np.max(np.abs(y))), 1.0)
    np.testing.assert_allclose(x, y, rtol=0, atol=rtol * scale)


def run(examples, test):
    settings(max_examples=examples, deadline=None, derandomize=True)(test)()


@pytest.mark.parametrize("name", ALL)
def test_exp_log_round_trip_and_membership(name):
    space, max_len, rtol, examples = ALL[name]

    @given(SEEDS, st.floats(0.0, 1.0))
    def check(seed, fraction):
        rng = np.random.default_rng(seed)
        a = space.random_point(rng)
        v = unit_tangent(space, a, rng, fraction * max_len)
        b = space.exp(a, v)
        assert np.all(space.belongs(b, atol=1e-8))
        assert_relative(space.log(a, b), v, rtol)
        np.testing.assert_allclose(space.dist(a, b), fraction * max_len, rtol=rtol, atol=rtol)

    run(examples, check)


@pytest.mark.parametrize("name", ALL)
def test_symmetry_fixes_centre_and_is_an_isometric_involution(name):
    space, max_len, rtol, examples = ALL[name]

    @given(SEEDS, st.floats(0.0, 1.0), st.floats(0.0, 1.0))
    def check(seed, far, near):
        rng = np.random.default_rng(seed)
        a = space.random_point(rng)
        m = space.exp(a, unit_tangent(space, a, rng, far * max_len))  # centre far from a
        p = space.exp(m, unit_tangent(space, m, rng, near * min(max_len, 2.0)))
        s = space.symmetry(m, p)
        assert np.all(space.belongs(s, atol=1e-8))
        assert_relative(space.symmetry(m, s), p, rtol)
        assert_relative(space.symmetry(m, m), m, rtol)
        if isinstance(space, RiemannianManifold):
            np.testing.assert_allclose(space.dist(m, s), space.dist(m, p), rtol=1e-6, atol=1e-7)

    run(examples, check)


@pytest.mark.parametrize("name", CLOSED)
def test_batch_equals_loop(name):
    space, max_len, _, examples = CLOSED[name]

    @given(SEEDS, st.integers(1, 6), st.floats(0.0, 1.0))
    def check(seed, n, fraction):
        rng = np.random.default_rng(seed)
        a = space.random_point(rng, n)
        v = np.stack([unit_tangent(space, x, rng, fraction * max_len) for x in a])
        b = space.exp(a, v)
        assert b.shape == (n, *space.point_shape)
        pairs = [
            (b, [space.exp(x, y) for x, y in zip(a, v)]),
            (space.log(a, b), [space.log(x, y) for x, y in zip(a, b)]),
            (space.symmetry(a, b), [space.symmetry(x, y) for x, y in zip(a, b)]),
            (space.midpoint(a, b), [space.midpoint(x, y) for x, y in zip(a, b)]),
            (space.dist(a, b), [space.dist(x, y) for x, y in zip(a, b)]),
        ]
        for batched, looped in pairs:
            assert_relative(batched, np.stack(looped), 1e-13)

    run(examples, check)


@pytest.mark.parametrize("name", CLOSED)
def test_random_point_batches_lie_on_the_manifold(name):
    space = CLOSED[name][0]

    @given(SEEDS, st.integers(1, 20))
    def check(seed, n):
        pts = space.random_point(np.random.default_rng(seed), n)
        assert pts.shape == (n, *space.point_shape)
        assert np.all(space.belongs(pts))

    run(20, check)


def small_lddmm(alpha):
    return LDDMMLandmarks(4, 2, sigma=0.8, alpha=alpha, control_points="dense", integrator="rk2")


@pytest.mark.parametrize("use_residuals", [True, False])
def test_residual_augmented_lddmm_properties(use_residuals):
    """With residuals ``exp o log`` is the identity whatever the registration; the symmetry
    fixes its centre and lands on a finite shape of the right shape in both variants."""
    space = ResidualAugmented(small_lddmm(0.1), use_residuals=use_residuals)

    @given(SEEDS, st.floats(0.05, 0.4))
    def check(seed, scale):
        rng = np.random.default_rng(seed)
        t = space.random_point(rng)
        s = space.base.exp(t, space.base.random_tangent(t, rng, scale=scale))
        s = s + 0.01 * rng.standard_normal(s.shape)
        log = space.log(t, s)
        assert isinstance(log, ResidualTangent)
        if use_residuals:
            np.testing.assert_allclose(space.exp(t, log), s, rtol=0, atol=1e-10)
        np.testing.assert_array_equal(space.symmetry(t, t), t)
        r = space.symmetry(t, s)
        assert r.shape == t.shape and np.isfinite(r).all()

    run(3, check)


def test_lddmm_exp_log_round_trip_few_landmarks():
    """Registration inverts the shooting to within its regularisation (alpha small)."""
    space = small_lddmm(1e-4)

    @given(SEEDS, st.floats(0.05, 0.3))
    def check(seed, scale):
        rng = np.random.default_rng(seed)
        t = space.random_point(rng)
        v = space.random_tangent(t, rng, scale=scale)
        s = space.exp(t, v)
        assert s.shape == t.shape and np.isfinite(s).all()
        np.testing.assert_allclose(space.exp(t, space.log(t, s)), s, rtol=0, atol=1e-4)
        np.testing.assert_allclose(space.symmetry(t, t), t, rtol=0, atol=1e-12)

    run(3, check)


@settings(max_examples=60, deadline=None)
@given(
    seed=SEEDS,
    k=st.integers(1, 300),
    dim=st.sampled_from([2, 3]),
    spacing=st.floats(0.05, 3.0),
)
def test_farthest_point_sample_is_a_spacing_net(seed, k, dim, spacing):
    """Every point within ``spacing`` of the sample, the sample's points at least
    ``spacing`` apart, sorted distinct indices, the same sample for the same points."""
    from manifolds.lddmm.control_points import farthest_point_indices

    rng = np.random.default_rng(seed)
    points = rng.normal(size=(k, dim)) * rng.uniform(0.1, 5.0, size=dim)
    idx = farthest_point_indices(points, spacing)
    assert idx.ndim == 1 and 1 <= idx.size <= k
    assert np.all(np.diff(idx) > 0)
    to_sample = np.sqrt(((points[:, None] - points[idx][None]) ** 2).sum(-1)).min(axis=1)
    assert to_sample.max() < spacing
    if idx.size > 1:
        between = np.sqrt(((points[idx][:, None] - points[idx][None]) ** 2).sum(-1))
        assert between[~np.eye(idx.size, dtype=bool)].min() >= spacing
    np.testing.assert_array_equal(farthest_point_indices(points.copy(), spacing), idx)
