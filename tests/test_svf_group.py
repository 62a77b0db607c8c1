"""Group structure of SVF deformations: the symmetry s_phi(psi) = phi o psi^-1 o phi and
the SVF pole ladder (conjugation by exp(v/2)), against matrix exponentials on linear
fields and against the generic pole ladder on the SVF shape space."""

import numpy as np
import pytest
import scipy.linalg

from ladders import pole_ladder
from manifolds.lddmm import (
    GaussianKernel,
    StationaryFlow,
    SVFLandmarks,
    compose,
    group_pole_ladder,
    group_symmetry,
    svf_pole_ladder,
)

A = np.array([[0.3, -1.2], [0.9, -0.4]])
B = np.array([[-0.5, 0.4], [0.7, 0.2]])
POINTS = np.random.default_rng(0).uniform(-1, 1, (15, 2))


def linear(mat, n_steps=40):
    return StationaryFlow(lambda p: p @ mat.T, n_steps=n_steps)


def kernel_fields(n_steps):
    rng = np.random.default_rng(1)
    kernel = GaussianKernel(0.6)
    cp = rng.uniform(-1, 1, (8, 2))
    phi = StationaryFlow.from_momenta(kernel, cp, 0.6 * rng.standard_normal((8, 2)), "rk4", n_steps)
    psi = StationaryFlow.from_momenta(kernel, cp, 0.6 * rng.standard_normal((8, 2)), "rk4", n_steps)
    return phi, psi


def test_group_symmetry_on_linear_fields_is_the_matrix_product():
    got = group_symmetry(linear(A), linear(B))(POINTS)
    mat = scipy.linalg.expm(A) @ scipy.linalg.expm(-B) @ scipy.linalg.expm(A)
    np.testing.assert_allclose(got, POINTS @ mat.T, atol=1e-7)
    # At the identity the symmetry is the inverse.
    identity = linear(A).scaled(0.0)
    inv = group_symmetry(identity, linear(B))(POINTS)
    np.testing.assert_allclose(inv, POINTS @ scipy.linalg.expm(-B).T, atol=1e-8)


def test_group_symmetry_fixes_phi_and_is_an_involution_up_to_integration_error():
    errors = {"fix": [], "involution": []}
    for n in (8, 16, 32):
        phi, psi = kernel_fields(n)
        fixed = group_symmetry(phi, phi)(POINTS)
        errors["fix"].append(np.abs(fixed - phi(POINTS)).max())
        twice = group_symmetry(phi, group_symmetry(phi, psi))(POINTS)
        errors["involution"].append(np.abs(twice - psi(POINTS)).max())
    for name, errs in errors.items():
        # integration error only: it vanishes at (at least) the order of RK4 (measured: 5)
        assert errs[-1] < 1e-6, name
        assert np.log2(errs[0] / errs[-1]) / 2 > 3.5, (name, errs)
    # The symmetry moves other deformations: it is not the identity.
    phi, psi = kernel_fields(16)
    assert np.abs(group_symmetry(phi, psi)(POINTS) - psi(POINTS)).max() > 0.1


def test_svf_pole_ladder_on_linear_fields_is_the_conjugated_matrix():
    got = svf_pole_ladder(linear(A), linear(B))(POINTS)
    half = scipy.linalg.expm(A / 2)
    mat = np.linalg.solve(half, scipy.linalg.expm(B) @ half)  # expm(-A/2) expm(B) expm(A/2)
    np.testing.assert_allclose(got, POINTS @ mat.T, atol=1e-8)
    # The transported deformation is again a one-parameter subgroup: the flow of the
    # linear field Ad(expm(-A/2)) B.
    conj = linear(np.linalg.solve(half, B @ half), n_steps=80)
    np.testing.assert_allclose(got, conj(POINTS), atol=1e-8)
    # Without the conjugation the transport would be the identity: it is not here.
    assert np.abs(got - linear(B)(POINTS)).max() > 0.1


def test_svf_pole_ladder_is_the_pole_ladder_of_the_group_symmetries():
    """exp(-v/2) o exp(u) o exp(v/2) = s_id o s_M(S') with M = exp(v/2), S' = exp(u) o exp(v),
    up to the integration error of exp(v) o exp(-v/2) = exp(v/2)."""
    phi, psi = kernel_fields(40)
    half = phi.scaled(0.5)
    s_prime = compose(psi, phi)
    identity = phi.scaled(0.0)
    ladder = group_symmetry(identity, group_symmetry(half, s_prime))
    np.testing.assert_allclose(ladder(POINTS), svf_pole_ladder(phi, psi)(POINTS), atol=2e-6)


@pytest.mark.parametrize("with_tangent", [False, True])
def test_group_ladder_agrees_with_generic_pole_ladder_to_third_order(with_tangent):
    """On shapes the generic pole ladder replaces the group's compositions by
    registrations: the two transported shapes differ at third order in the size of
    the vectors, while the transport itself moves the shape at second order."""
    space = SVFLandmarks(6, 2, sigma=0.6, alpha=1e-4, control_points="dense")
    rng = np.random.default_rng(0)
    t = space.random_point(rng)
    v0 = space.random_tangent(t, rng, 1.0)
    u_rng = np.random.default_rng(1)
    u0 = space.random_tangent(space.exp(t, 0.1 * v0), u_rng, 1.0)
    gaps, moves = [], []
    for eps in (0.2, 0.1, 0.05):
        v, u = eps * v0, eps * u0
        s = space.exp(t, v)
        if with_tangent:
            group, w_group = group_pole_ladder(space, t, v, u, return_tangent=True)
            np.testing.assert_allclose(space.exp(t, w_group), group, atol=1e-6)
        else:
            group = group_pole_ladder(space, t, v, u)
        generic = space.exp(t, pole_ladder(space, s, t, u))
        gaps.append(np.abs(group - generic).max())
        moves.append(np.abs(group - space.exp(t, u)).max())
    orders = np.log2(np.array(gaps[:-1]) / np.array(gaps[1:]))
    assert np.all(orders > 2.5), gaps
    assert np.all(np.array(gaps) < 0.5 * np.array(moves)), (gaps, moves)
