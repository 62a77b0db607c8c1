"""Per-vertex units of the distances (paper's Table 1: RMS over vertices, in mm)."""

import numpy as np
import pytest

from ladders import centrality_error, involutivity_error, symmetry_errors
from manifolds import Hypersphere, point_distance
from manifolds.residual import ResidualAugmented
from tests.test_residual import RegularisedEuclidean

A = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0], [5.0, 5.0]])
B = np.array([[3.0, 4.0], [1.0, 1.0], [2.0, 1.0], [5.0, 5.0]])
# Vertex distances D = (5, 0, 1, 0): sum of squares 26 over k = 4 vertices.


def test_hand_computed_vertex_distances():
    shape = A.shape
    assert point_distance("rms", shape)(A, B) == pytest.approx(np.sqrt(26 / 4), rel=1e-15)
    assert point_distance("frobenius", shape)(A, B) == pytest.approx(np.sqrt(26), rel=1e-15)
    assert point_distance("mean", shape)(A, B) == pytest.approx(6 / 4, rel=1e-15)
    # Batch axes broadcast: one distance per pair.
    batch = point_distance("rms", shape)(np.stack([A, A]), np.stack([B, A]))
    np.testing.assert_allclose(batch, [np.sqrt(6.5), 0.0], rtol=1e-15)


def test_other_point_shapes():
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal((2, 3))
    values = [point_distance(n, (3,))(a, b) for n in ("rms", "frobenius", "mean")]
    np.testing.assert_allclose(values, np.linalg.norm(a - b), rtol=1e-15)  # one vertex
    a, b = rng.standard_normal((2, 2, 3, 4))  # 6 vertices of R^4
    d = np.linalg.norm(a - b, axis=-1)
    np.testing.assert_allclose(point_distance("rms", (2, 3, 4))(a, b), np.sqrt((d**2).mean()))
    np.testing.assert_allclose(point_distance("mean", (2, 3, 4))(a, b), d.mean())
    custom = point_distance(lambda x, y: 7.0, (2, 3, 4))
    assert custom(a, b) == 7.0
    with pytest.raises(ValueError, match="distance"):
        point_distance("max", (2, 3))


def test_estimators_default_to_rms_and_accept_the_other_units():
    rng = np.random.default_rng(1)
    t, s, s2 = rng.standard_normal((3, 6, 3))
    space = ResidualAugmented(RegularisedEuclidean((6, 3), 0.5), use_residuals=False)
    rms = centrality_error(space, t, s)
    frob = centrality_error(space, t, s, distance="frobenius")
    mean = centrality_error(space, t, s, distance="mean")
    np.testing.assert_allclose(frob, np.sqrt(6) * rms, rtol=1e-12)
    assert 0 < mean <= rms
    # Shrunk log (alpha^2 = 0.25, lam = 1 / (1 + alpha^2) = 0.8), M = T + lam (S - T) / 2:
    # s_M(T) - S = M + lam (M - T) - S = -(1 - lam (1 + lam) / 2) (S - T).
    lam = 0.8
    diff = (1 - 0.5 * lam * (1 + lam)) * (s - t)
    np.testing.assert_allclose(mean, np.linalg.norm(diff, axis=1).mean(), rtol=1e-12)
    errs = symmetry_errors(space, t, s, s2, distance="frobenius").as_dict()
    np.testing.assert_allclose(errs["centrality"], frob, rtol=1e-12)
    inv = involutivity_error(space, t, s2, distance=lambda a, b: float(np.abs(a - b).max()))
    assert inv > 0
    # One-vertex spaces: the three units agree.
    sphere = Hypersphere(2)
    p, q = sphere.random_point(rng, 2)
    vals = [centrality_error(sphere, p, q, distance=n) for n in ("rms", "frobenius", "mean")]
    np.testing.assert_allclose(vals, vals[0], rtol=1e-14)
