import numpy as np

from ladders import pole_ladder, schild_ladder, symmetry_errors
from manifolds import Euclidean
from manifolds.testing import ConnectionContract


class TestEuclideanVector(ConnectionContract):
    space = Euclidean(4)


class TestEuclideanPDM(ConnectionContract):
    space = Euclidean((7, 3))
    far_scale = 1000.0

    def test_symmetry_closed_form(self):
        rng = np.random.default_rng(0)
        m, p = self.space.random_point(rng), self.space.random_point(rng)
        np.testing.assert_allclose(self.space.symmetry(m, p), 2 * m - p, atol=0)

    def test_ladders_are_identity(self):
        rng = np.random.default_rng(1)
        s, t = self.space.random_point(rng), self.space.random_point(rng)
        u = self.space.random_tangent(s, rng)
        for ladder in (pole_ladder, schild_ladder):
            for n in (1, 3, 4):
                np.testing.assert_allclose(ladder(self.space, s, t, u, n_rungs=n), u, atol=1e-13)

    def test_symmetry_errors_vanish(self):
        rng = np.random.default_rng(2)
        t, s, s2 = (self.space.random_point(rng) for _ in range(3))
        errs = symmetry_errors(self.space, t, s, s2)
        for value in errs.as_dict().values():
            assert value < 1e-13
