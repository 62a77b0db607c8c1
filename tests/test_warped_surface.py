"""The warped surface g = dx^2 + f(x)^2 dy^2: closed-form connection and curvature."""

import autograd.numpy as anp
import numpy as np
import pytest

from manifolds.errors import ConvergenceError, ManifoldError, NotOnManifoldError
from manifolds.numerics.shooting import ShootingSolver
from manifolds.testing import ConnectionContract
from manifolds.warped_surface import WarpedSurface


def cosh_surface(**kwargs):
    return WarpedSurface(f=anp.cosh, df=anp.sinh, d2f=anp.cosh, **kwargs)


def closed_form_christoffel(f, df, x):
    """Gamma^x_yy = -f f', Gamma^y_xy = Gamma^y_yx = f'/f, others zero."""
    gam = np.zeros((2, 2, 2))
    gam[0, 1, 1] = -f(x) * df(x)
    gam[1, 0, 1] = gam[1, 1, 0] = df(x) / f(x)
    return gam


def two_d_curvature(space, point, kappa, u, v, w):
    """In dimension 2, R(u, v) w = K (<v, w> u - <u, w> v)."""
    return kappa * (space.inner(point, v, w) * u - space.inner(point, u, w) * v)


class TestWarpedSurface(ConnectionContract):
    space = WarpedSurface()
    far_scale = 1.5
    rtol = 1e-8
    atol = 1e-8
    max_examples = 5


class TestCoshControl(ConnectionContract):
    space = cosh_surface()
    rtol = 1e-8
    atol = 1e-8
    max_examples = 3


POINTS = [np.array([0.5, 0.0]), np.array([-0.7, 0.3]), np.array([1.3, -2.0])]


@pytest.mark.parametrize("point", POINTS)
def test_christoffel_closed_form(point):
    space = WarpedSurface()
    expected = closed_form_christoffel(lambda x: 1 + x**2, lambda x: 2 * x, point[0])
    np.testing.assert_allclose(space.christoffel(point), expected, atol=1e-14)
    cosh = cosh_surface()
    np.testing.assert_allclose(
        cosh.christoffel(point), closed_form_christoffel(np.cosh, np.sinh, point[0]), atol=1e-13
    )


@pytest.mark.parametrize("point", POINTS)
def test_gaussian_curvature_is_minus_f_second_over_f(point):
    space = WarpedSurface()
    rng = np.random.default_rng(7)
    u, v = space.random_tangent(point, rng), space.random_tangent(point, rng)
    kappa = -2.0 / (1.0 + point[0] ** 2)
    np.testing.assert_allclose(space.sectional_curvature(point, u, v), kappa, rtol=1e-12)
    np.testing.assert_allclose(space.gaussian_curvature(point), kappa, rtol=1e-15)
    # The full tensor, not only its sectional part.
    w = space.random_tangent(point, rng)
    np.testing.assert_allclose(
        space.curvature(point, u, v, w), two_d_curvature(space, point, kappa, u, v, w), atol=1e-12
    )
    cosh = cosh_surface()
    np.testing.assert_allclose(cosh.sectional_curvature(point, u, v), -1.0, rtol=1e-12)


def test_autograd_derivatives_of_custom_f():
    """Without closed-form f', f'' the surface differentiates f itself."""
    auto = WarpedSurface(f=anp.cosh)
    point = np.array([0.4, 0.1])
    assert auto.df(0.4) == pytest.approx(np.sinh(0.4), rel=1e-14)
    assert auto.d2f(0.4) == pytest.approx(np.cosh(0.4), rel=1e-14)
    v = np.array([0.3, -0.2])
    np.testing.assert_allclose(auto.exp(point, v), cosh_surface().exp(point, v), atol=1e-13)


def test_nabla_r_closed_form_and_nonzero():
    """(nabla_x R)(u, v) w = dK(x) (<v, w> u - <u, w> v), dK = K'(x) dx, K = -2/(1+x^2)."""
    space = WarpedSurface()
    rng = np.random.default_rng(3)
    for point in POINTS:
        x, u, v, w = (space.random_tangent(point, rng) for _ in range(4))
        dk = 4.0 * point[0] / (1.0 + point[0] ** 2) ** 2 * x[0]
        got = space.curvature_derivative(point, x, u, v, w)
        np.testing.assert_allclose(got, two_d_curvature(space, point, dk, u, v, w), atol=1e-11)
    assert np.abs(space.riemann_derivative(np.array([0.5, 0.0]))).max() > 0.5


def test_nabla_r_vanishes_on_cosh_control():
    cosh = cosh_surface()
    for point in POINTS:
        assert np.abs(cosh.riemann_derivative(point)).max() < 1e-10


def test_log_matches_flat_polar_chart():
    """f(x) = x is the flat plane in polar coordinates (r, theta): log is a chord."""
    polar = WarpedSurface(f=lambda r: r, df=lambda r: 1.0, d2f=lambda r: 0.0)
    p, q = np.array([1.0, 0.0]), np.array([1.5, 2.0])
    cart = lambda z: z[0] * np.array([np.cos(z[1]), np.sin(z[1])])  # noqa: E731
    np.testing.assert_allclose(polar.dist(p, q), np.linalg.norm(cart(q) - cart(p)), rtol=1e-10)
    assert polar.sectional_curvature(p, np.array([1.0, 0]), np.array([0, 1.0])) == 0.0


def test_shooting_failure_raises_convergence_error():
    space = WarpedSurface(shooting=ShootingSolver(max_iterations=1))
    with pytest.raises(ConvergenceError, match=r"residual .* tolerance"):
        space.log(np.array([0.0, 0.0]), np.array([2.0, 3.0]))
    # f vanishes at x = 0 here: x < 0 is outside the domain of the metric.
    polar = WarpedSurface(f=lambda r: r, df=lambda r: 1.0, d2f=lambda r: 0.0)
    with pytest.raises(NotOnManifoldError, match="other"):
        polar.log(np.array([1.0, 0.0]), np.array([-1.0, 0.0]))
    with pytest.raises(ConvergenceError, match="leaves the domain"):
        polar.exp(np.array([1.0, 0.0]), np.array([-2.0, 0.0]))


def test_bad_input():
    space = WarpedSurface()
    with pytest.raises(ManifoldError, match="point"):
        space.exp(np.array([np.nan, 0.0]), np.zeros(2))
    with pytest.raises(ManifoldError, match="batches"):
        space.exp(np.zeros((3, 2)), np.zeros((3, 2)))
    with pytest.raises(ManifoldError, match=": w:"):
        space.curvature(np.zeros(2), np.ones(2), np.ones(2), np.ones(3))
    with pytest.raises(ValueError, match="df, d2f"):
        WarpedSurface(df=np.sinh)
