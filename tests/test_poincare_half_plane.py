"""The Poincare half-plane computed from its metric agrees with closed-form hyperbolic geometry."""

import autograd.numpy as anp
import numpy as np
import pytest
from autograd import jacobian

from ladders.pole_ladder import pole_ladder
from ladders.symmetry_errors import symmetry_errors
from manifolds.errors import ConvergenceError, NotOnManifoldError
from manifolds.hyperbolic import Hyperbolic, minkowski_inner
from manifolds.numerics.shooting import ShootingSolver
from manifolds.poincare_half_plane import PoincareHalfPlane
from manifolds.testing import ConnectionContract

SPACE = PoincareHalfPlane()
HYPERBOLOID = Hyperbolic(2)


def to_hyperboloid(p):
    """Isometry (x, y) -> ((x^2+y^2+1)/(2y), x/y, (x^2+y^2-1)/(2y)) onto H^2."""
    x, y = p[0], p[1]
    r2 = x * x + y * y
    return anp.array([(r2 + 1.0) / (2.0 * y), x / y, (r2 - 1.0) / (2.0 * y)])


d_to_hyperboloid = jacobian(to_hyperboloid)


def push(p, v):
    """Differential of the isometry: a tangent vector at p to one at to_hyperboloid(p)."""
    return d_to_hyperboloid(p) @ v


def closed_form_dist(p, q):
    return np.arccosh(1.0 + np.sum((p - q) ** 2) / (2.0 * p[1] * q[1]))


def sample(seed, scale=0.8):
    rng = np.random.default_rng(seed)
    p = SPACE.random_point(rng)
    v = SPACE.random_tangent(p, rng, scale=scale)
    return rng, p, v


class TestPoincareHalfPlane(ConnectionContract):
    space = SPACE
    far_scale = 1.5
    rtol = 1e-8
    atol = 1e-8
    max_examples = 5


def test_christoffel_closed_form():
    for point in (np.array([0.3, 0.7]), np.array([-2.0, 1.9])):
        y = point[1]
        expected = np.zeros((2, 2, 2))
        expected[0, 0, 1] = expected[0, 1, 0] = -1.0 / y
        expected[1, 0, 0] = 1.0 / y
        expected[1, 1, 1] = -1.0 / y
        np.testing.assert_allclose(SPACE.christoffel(point), expected, atol=1e-14)


def test_constant_curvature_and_parallel_curvature():
    rng = np.random.default_rng(0)
    for _ in range(3):
        p = SPACE.random_point(rng)
        u, v, w, x = (SPACE.random_tangent(p, rng) for _ in range(4))
        assert SPACE.sectional_curvature(p, u, v) == pytest.approx(-1.0, rel=1e-12)
        expected = -(SPACE.inner(p, v, w) * u - SPACE.inner(p, u, w) * v)
        np.testing.assert_allclose(SPACE.curvature(p, u, v, w), expected, atol=1e-12)
        np.testing.assert_allclose(SPACE.curvature_derivative(p, x, u, v, w), 0.0, atol=1e-10)
        assert np.abs(SPACE.riemann_derivative(p)).max() < 1e-10


def test_isometry_pulls_back_the_metric():
    rng = np.random.default_rng(1)
    p = SPACE.random_point(rng)
    assert HYPERBOLOID.belongs(to_hyperboloid(p))
    u, v = SPACE.random_tangent(p, rng), SPACE.random_tangent(p, rng)
    np.testing.assert_allclose(
        minkowski_inner(push(p, u), push(p, v)), SPACE.inner(p, u, v), rtol=1e-13
    )


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_distance_formula(seed):
    _, p, v = sample(seed, scale=1.5)
    q = SPACE.exp(p, v)
    np.testing.assert_allclose(SPACE.dist(p, q), closed_form_dist(p, q), rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(SPACE.norm(p, v), closed_form_dist(p, q), rtol=1e-8)


@pytest.mark.parametrize("seed", [3, 4])
def test_exp_log_transport_agree_with_hyperboloid(seed):
    rng, p, v = sample(seed)
    q = SPACE.exp(p, v)
    hp, hq = to_hyperboloid(p), to_hyperboloid(q)
    np.testing.assert_allclose(hq, HYPERBOLOID.exp(hp, push(p, v)), rtol=1e-8, atol=1e-9)
    # log of a point not produced by exp
    r = SPACE.random_point(rng)
    np.testing.assert_allclose(
        push(p, SPACE.log(p, r)),
        HYPERBOLOID.log(hp, to_hyperboloid(r)),
        rtol=1e-8,
        atol=1e-9,
    )
    w = SPACE.random_tangent(p, rng)
    np.testing.assert_allclose(
        push(q, SPACE.parallel_transport(p, q, w)),
        HYPERBOLOID.parallel_transport(hp, hq, push(p, w)),
        rtol=1e-8,
        atol=1e-9,
    )


def test_pole_ladder_exact_and_symmetry_errors_vanish():
    """A symmetric space: one rung of pole ladder is parallel transport (paper, Sec. 2.2)."""
    s, t = np.array([-0.5, 0.6]), np.array([0.7, 1.4])
    u = np.array([0.3, -0.2])
    exact = SPACE.parallel_transport(s, t, u)
    np.testing.assert_allclose(pole_ladder(SPACE, s, t, u), exact, atol=1e-9)
    errors = symmetry_errors(SPACE, t, s, SPACE.exp(s, u))
    for name, value in errors.as_dict().items():
        assert value < 1e-9, name


def test_domain_and_shooting_failures():
    p = np.array([0.0, 1.0])
    with pytest.raises(NotOnManifoldError, match="other"):
        SPACE.log(p, np.array([0.0, -1.0]))
    with pytest.raises(NotOnManifoldError, match="point"):
        SPACE.exp(np.array([0.0, 0.0]), np.array([1.0, 0.0]))
    impatient = PoincareHalfPlane(shooting=ShootingSolver(max_iterations=1))
    with pytest.raises(ConvergenceError, match="did not converge"):
        impatient.log(p, np.array([3.0, 0.2]))


def test_default_is_tangent_accepts_vectors_pointing_out_of_the_half_plane():
    space = PoincareHalfPlane()
    point = np.array([0.0, 1.0])
    # Every finite vector is tangent to an open subset of R^2, also (0, -1) and (0, -5).
    for vector in ([0.0, -1.0], [0.0, -5.0], [3.0, 0.0]):
        assert space.is_tangent(point, vector)
        np.testing.assert_array_equal(space.check_tangent(point, vector), vector)
    assert not space.is_tangent(point, [np.nan, 0.0])
    assert not space.is_tangent(point, [1.0, 0.0, 0.0])
    # The point itself must still lie in the half-plane.
    assert not space.belongs([0.0, -1.0])
    # exp accepts a downward tangent and stays in the half-plane.
    assert space.belongs(space.exp(point, np.array([0.0, -1.0])))
