"""Generic metric-field manifold: autograd connection, ODE maps, shooting, input checks."""

import autograd.numpy as anp
import numpy as np
import pytest

from manifolds.errors import ConvergenceError, ManifoldError, NotOnManifoldError
from manifolds.metric_field import MetricField, christoffel_from_jet
from manifolds.numerics.geodesic_ode import GeodesicDomainError, GeodesicIntegrator
from manifolds.numerics.shooting import ShootingSolver
from manifolds.warped_surface import WarpedSurface


def warped_metric(x):
    f = 1.0 + x[0] ** 2
    return anp.array([[1.0, 0.0], [0.0, f * f]])


def stereographic_sphere(x):
    """Unit sphere in stereographic coordinates: g = 4 / (1 + |x|^2)^2 I (K = +1)."""
    return 4.0 / (1.0 + anp.sum(x**2)) ** 2 * anp.eye(2)


def flat_jet(x, order):
    z = np.zeros((2, 2, 2))
    return (np.eye(2), z) if order == 1 else (np.eye(2), z, np.zeros((2, 2, 2, 2)))


def punctured_plane():
    """The flat plane minus the closed disc of radius 1/2 (a non-convex domain)."""
    return MetricField(
        lambda x: anp.eye(2),
        2,
        domain=lambda x: float(x @ x) > 0.25,
        metric_jet=flat_jet,
        sampling_box=(np.array([1.0, 1.0]), np.array([2.0, 2.0])),
    )


AUTO = MetricField(warped_metric, 2)
CLOSED = WarpedSurface()


def test_christoffel_from_jet_matches_autograd():
    x = np.array([0.4, -0.2])
    gamma, dgamma = christoffel_from_jet(*CLOSED._jet_closed(x, 2))
    np.testing.assert_allclose(gamma, AUTO.christoffel(x), atol=1e-14)
    # dGamma against autograd on the autograd jet, and against central differences.
    np.testing.assert_allclose(dgamma, AUTO._christoffel_jet(x)[1], atol=1e-13)
    eps = 1e-6
    for l in range(2):
        e = np.eye(2)[l] * eps
        fd = (AUTO.christoffel(x + e) - AUTO.christoffel(x - e)) / (2 * eps)
        np.testing.assert_allclose(dgamma[..., l], fd, atol=1e-8)


def test_autograd_path_agrees_with_closed_jet():
    p, v = np.array([0.2, -0.1]), np.array([0.3, 0.2])
    q = AUTO.exp(p, v)
    np.testing.assert_allclose(q, CLOSED.exp(p, v), atol=1e-13)
    np.testing.assert_allclose(AUTO.log(p, q), v, atol=1e-10)


def test_exp_jacobian_matches_finite_differences():
    p, v = np.array([0.5, 0.0]), np.array([0.6, -0.8])
    end, jac = CLOSED.exp_with_jacobian(p, v)
    np.testing.assert_allclose(end, CLOSED.exp(p, v), atol=1e-14)
    eps = 1e-5
    fd = np.stack(
        [(CLOSED.exp(p, v + eps * e) - CLOSED.exp(p, v - eps * e)) / (2 * eps) for e in np.eye(2)],
        axis=1,
    )
    np.testing.assert_allclose(jac, fd, atol=1e-8)


def test_sphere_sign_convention_and_symmetry():
    """Stereographic sphere: K = +1 with <R(u,v)v,u>, R(u,v)w = <v,w>u - <u,w>v, nabla R = 0."""
    sphere = MetricField(stereographic_sphere, 2)
    rng = np.random.default_rng(5)
    p = sphere.random_point(rng)
    u, v, w = (sphere.random_tangent(p, rng) for _ in range(3))
    assert sphere.sectional_curvature(p, u, v) == pytest.approx(1.0, rel=1e-12)
    expected = sphere.inner(p, v, w) * u - sphere.inner(p, u, w) * v
    np.testing.assert_allclose(sphere.curvature(p, u, v, w), expected, atol=1e-12)
    assert np.abs(sphere.riemann_derivative(p)).max() < 1e-10


def test_random_tangent_is_isotropic_in_the_metric():
    p = np.array([0.7, 0.3])
    v = CLOSED.random_tangent(p, np.random.default_rng(11), scale=2.0)
    z = np.random.default_rng(11).standard_normal(2)
    assert CLOSED.inner(p, v, v) == pytest.approx(4.0 * z @ z, rel=1e-13)


def test_swappable_integrator():
    loose = WarpedSurface(integrator=GeodesicIntegrator(method="RK45", rtol=1e-9, atol=1e-9))
    p, v = np.array([0.5, 0.0]), np.array([0.6, -0.8])
    a, b = loose.exp(p, v), CLOSED.exp(p, v)
    assert 0 < np.abs(a - b).max() < 1e-6


def test_geodesic_leaving_the_domain():
    plane = punctured_plane()
    with pytest.raises(GeodesicDomainError, match="leaves the domain"):
        plane.exp(np.array([-1.0, 0.0]), np.array([2.0, 0.0]))
    # Points seen from each other past the hole: the straight segment.
    p, q = np.array([-1.0, 0.0]), np.array([0.0, 1.0])
    np.testing.assert_allclose(plane.log(p, q), q - p, atol=1e-12)
    # Opposite points: the only geodesic crosses the hole; shooting must give up.
    with pytest.raises(ConvergenceError, match="domain"):
        plane.log(p, np.array([1.0, 0.0]))


def test_input_validation():
    with pytest.raises(NotOnManifoldError, match="other"):
        punctured_plane().log(np.array([1.0, 1.0]), np.array([0.1, 0.0]))
    with pytest.raises(ManifoldError, match="tangent"):
        CLOSED.exp(np.zeros(2), np.array([np.inf, 0.0]))
    with pytest.raises(ManifoldError, match="other"):
        CLOSED.log(np.zeros(2), np.zeros(3))
    with pytest.raises(ValueError, match="dim"):
        MetricField(warped_metric, 0)
    with pytest.raises(TypeError, match="metric_matrix"):
        MetricField(None, 2)
    with pytest.raises(ValueError, match="metric_matrix"):
        MetricField(lambda x: anp.eye(3), 2).metric(np.zeros(2))
    with pytest.raises(ValueError, match="rtol"):
        GeodesicIntegrator(rtol=0.0)
    with pytest.raises(ValueError, match="max_iterations"):
        ShootingSolver(max_iterations=0)
    assert not CLOSED.belongs(np.array([np.nan, 0.0]))
    assert CLOSED.belongs(np.zeros((4, 2))).shape == (4,)
