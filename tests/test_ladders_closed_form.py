"""Ladders and symmetry errors validated against closed forms on symmetric spaces.

In a locally symmetric space (``nabla R = 0``) the one-rung pole ladder is a
transvection and equals parallel transport (paper, eq. 4), the transvectivity
error (eq. 8) vanishes, and Schild's ladder keeps its second-order rung error,
which gives ``n^-1`` / ``n^-2`` convergence with ``scaling_exponent`` 1 / 2.
"""

import numpy as np
import pytest

from ladders.pole_ladder import pole_ladder
from ladders.schild_ladder import schild_ladder
from ladders.symmetry_errors import (
    centrality_error,
    involutivity_error,
    midpoint_distance,
    symmetry_errors,
    transvectivity_error,
)
from manifolds.hyperbolic import Hyperbolic
from manifolds.hypersphere import Hypersphere
from manifolds.spd import SPDMatrices

SPACES = {
    "S2": Hypersphere(2),
    "S5": Hypersphere(5),
    "H3": Hyperbolic(3),
    "SPD3": SPDMatrices(3),
}


def configurations(space, seed, n=8, distance=1.0, size=1.0):
    """Batch of ``(base, end, tangent)`` with ``|Log(base, end)| ~ distance``, ``|u| ~ size``."""
    rng = np.random.default_rng(seed)
    base = space.random_point(rng, n)
    end = space.exp(base, space.random_tangent(base, rng, scale=distance))
    return base, end, space.random_tangent(base, rng, scale=size)


def relative_error(space, end, approx, exact):
    return space.norm(end, approx - exact) / space.norm(end, exact)


def loglog_slope(ns, errors):
    """Least-squares slope of ``log(error)`` against ``log(n)``."""
    return np.polyfit(np.log(ns), np.log(errors), 1)[0]


@pytest.mark.parametrize("name", SPACES)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_one_rung_pole_ladder_is_parallel_transport(name, seed):
    space = SPACES[name]
    base, end, u = configurations(space, seed, distance=1.2, size=1.0)
    exact = space.parallel_transport(base, end, u)
    err = relative_error(space, end, pole_ladder(space, base, end, u), exact)
    assert np.all(err <= 1e-12), err.max()


@pytest.mark.parametrize("name", SPACES)
def test_pole_ladder_with_many_rungs_stays_exact(name):
    space = SPACES[name]
    base, end, u = configurations(space, 3, n=4, distance=1.0, size=0.8)
    exact = space.parallel_transport(base, end, u)
    for n_rungs in (2, 3, 4, 7):
        for exponent in (1.0, 2.0):
            approx = pole_ladder(space, base, end, u, n_rungs=n_rungs, scaling_exponent=exponent)
            err = relative_error(space, end, approx, exact)
            # Round-off of each rung is multiplied by the final rescaling n^exponent.
            assert np.all(err <= 5e-13 * n_rungs**exponent), (n_rungs, exponent, err.max())


@pytest.mark.parametrize("name", ["S2", "SPD3", "H3"])
@pytest.mark.parametrize("exponent", [1.0, 2.0])
def test_schild_ladder_convergence_order(name, exponent):
    space = SPACES[name]
    # Vectors not aligned with the geodesic, large enough for a clear rung error.
    base, end, u = configurations(space, 4, n=3, distance=1.0, size=1.0)
    exact = space.parallel_transport(base, end, u)
    ns = np.array([4, 8, 16, 32, 64])
    errors = np.array(
        [
            relative_error(
                space, end, schild_ladder(space, base, end, u, n, scaling_exponent=exponent), exact
            )
            for n in ns
        ]
    )
    assert np.all(errors > 1e-8)  # far above round-off, so the fit is clean
    for k in range(errors.shape[1]):
        slope = loglog_slope(ns, errors[:, k])
        assert abs(slope + exponent) <= 0.15, (k, slope)


@pytest.mark.parametrize("name", SPACES)
def test_symmetry_errors_vanish_on_symmetric_spaces(name):
    space = SPACES[name]
    rng = np.random.default_rng(5)
    template = space.random_point(rng, 6)
    shape = space.exp(template, space.random_tangent(template, rng, scale=1.0))
    other = space.exp(shape, space.random_tangent(shape, rng, scale=0.7))
    # The paper's L2 distance on the point arrays (entries of size up to ~7 here).
    assert np.all(transvectivity_error(space, template, shape, other) <= 1e-12)
    assert np.all(centrality_error(space, template, shape) <= 1e-12)
    assert np.all(involutivity_error(space, template, other) <= 1e-12)
    assert np.all(midpoint_distance(space, template, shape) <= 1e-12)
    errs = symmetry_errors(space, template, shape, other)
    for value in errs.as_dict().values():
        assert np.max(value) <= 1e-12


def test_transvectivity_detects_a_wrong_symmetry():
    # Control: a perturbed symmetry (no longer an isometry) must show up.
    class SkewedSphere(Hypersphere):
        def symmetry(self, center, point):
            s = super().symmetry(center, point)
            s = s + 0.05 * np.cross(center, s)
            return s / np.linalg.norm(s, axis=-1, keepdims=True)

    space = SkewedSphere(2)
    rng = np.random.default_rng(6)
    t = space.random_point(rng, 5)
    s = space.exp(t, space.random_tangent(t, rng, scale=1.0))
    s2 = space.exp(s, space.random_tangent(s, rng, scale=0.7))
    assert np.all(transvectivity_error(space, t, s, s2) > 1e-4)


def test_one_rung_pole_ladder_with_trajectory():
    space = SPACES["S2"]
    base, end, u = configurations(space, 7, n=3)
    transported, traj = pole_ladder(space, base, end, u, return_trajectory=True)
    np.testing.assert_allclose(traj.end_point, space.exp(end, transported), atol=1e-15)
    np.testing.assert_allclose(traj.pivots[0], space.midpoint(end, base), atol=1e-15)
    # The symmetric pole ladder's end point is the transvection s_T o s_M of S'.
    tip = space.exp(base, u)
    np.testing.assert_allclose(
        traj.end_point, space.symmetry(end, space.symmetry(traj.pivots[0], tip)), atol=1e-14
    )


def test_symmetry_errors_points_are_the_pole_ladder_of_algorithm_1():
    space = Hypersphere(2)
    rng = np.random.default_rng(7)
    s = space.random_point(rng)
    t = space.exp(s, space.random_tangent(s, rng, scale=0.9))
    u = space.random_tangent(s, rng, scale=0.4)
    s2 = space.exp(s, u)
    errs = symmetry_errors(space, t, s, s2)
    _, traj = pole_ladder(space, s, t, u, return_trajectory=True)
    np.testing.assert_allclose(errs.points["pole_ladder"], traj.end_point, atol=1e-14)
    np.testing.assert_allclose(errs.points["midpoint"], traj.pivots[0], atol=1e-15)
    np.testing.assert_allclose(errs.points["reflected"], traj.reflected[0], atol=1e-14)
    assert set(errs.as_dict()) == {
        "midpoint_distance",
        "centrality",
        "involutivity",
        "transvectivity",
    }
