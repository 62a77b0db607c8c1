"""Generic contract that every space of :mod:`manifolds` must satisfy.

Shipped with the library so that a user adding a space can test it (needs the
``test`` extra: pytest and hypothesis)::

    from manifolds.testing import ConnectionContract

    class TestMySpace(ConnectionContract):
        space = MySpace(...)

pytest then checks round trips of ``exp`` and ``log``, that ``exp`` lands on the
manifold and ``log`` returns a tangent, the symmetry (fixes its centre, is an
involution, reverses ``log``), the midpoint, the geodesic, the metric (when the
space is Riemannian), batching (when it broadcasts), bad-input errors, and,
for a space claiming ``is_symmetric``, an exact one-rung pole ladder and zero
transvectivity. Tolerances, sampling sizes, where points are drawn
(``random_point``) and how tangents are compared (``tangent_arrays``,
``corrupt_tangent``) are class attributes and hooks to set
(``docs/add_your_own_space.md`` lists them all).

Far from the base point: with ``far_scale > 0`` the centre is first moved by a
random tangent of size ``far_scale`` (e.g. 6 on the hyperbolic space, where the
coordinates then grow like ``e^6``) and the same properties are checked there
with the relative tolerance ``far_rtol``: results stay on the manifold (within
``membership_atol``), ``log o exp`` and ``s_m o s_m`` are the identity, ``s_m``
fixes ``m``. ``far_scale = 0`` (the default) skips these checks.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from manifolds import ManifoldError, RiemannianManifold

SEEDS = st.integers(min_value=0, max_value=2**32 - 1)

__all__ = ["ConnectionContract", "run_contract", "assert_curvature_matches_distance_expansion"]


def run_contract(contract) -> dict[str, str]:
    """Run every property of a :class:`ConnectionContract` instance outside pytest.

    Returns
    -------
    dict
        ``property -> "passed" | "skipped: why" | "failed: why"`` (the property's name is
        its test's without ``test_``, underscores as spaces; ``why`` is the first line of
        the assertion or error).
    """
    out = {}
    for name in sorted(n for n in dir(contract) if n.startswith("test_")):
        prop = name[len("test_") :].replace("_", " ")
        try:
            getattr(contract, name)()
        except pytest.skip.Exception as exc:
            out[prop] = f"skipped: {exc}"
        except Exception as exc:  # an assertion or an error of the space: both fail it
            first = str(exc).strip().splitlines()
            out[prop] = f"failed: {type(exc).__name__}: {first[0] if first else ''}".strip()
        else:
            out[prop] = "passed"
    return out


def assert_curvature_matches_distance_expansion(space, rng, rtol, sign=None, eps=1e-2):
    """Check ``<R(u, v) v, u>`` against the small-distance expansion of ``dist``.

    ``d(Exp_x(eps u), Exp_x(eps v))^2 = eps^2 |u - v|^2 - eps^4 / 3 <R(u, v) v, u> + O(eps^6)``
    at a random point ``x`` and random tangents ``u, v``; ``sign`` (``+1`` or ``-1``),
    when given, is the expected sign of ``<R(u, v) v, u>``.
    """
    x = space.random_point(rng)
    u, v = space.random_tangent(x, rng), space.random_tangent(x, rng)
    d2 = space.dist(space.exp(x, eps * u), space.exp(x, eps * v)) ** 2
    measured = 3 * (eps**2 * space.inner(x, u - v, u - v) - d2) / eps**4
    expected = space.inner(x, space.curvature(x, u, v, v), u)
    if sign is not None:
        assert np.sign(expected) == sign
    np.testing.assert_allclose(measured, expected, rtol=rtol)


class ConnectionContract:
    """Round trips, symmetry and midpoint properties, batching, bad input."""

    space = None
    rtol = 1e-10
    atol = 1e-10
    tangent_scale = 0.5
    max_examples = 25
    n_batch = 5
    membership_atol = 1e-8
    far_scale = 0.0
    far_rtol = 1e-8

    # ------------------------------------------------------------- helpers
    def given_seed(self, check):
        """Run ``check(rng)`` for hypothesis-chosen seeds."""

        @settings(max_examples=self.max_examples, deadline=None, derandomize=True)
        @given(SEEDS)
        def run(seed):
            check(np.random.default_rng(seed))

        run()

    def random_point(self, rng):
        """A point to check the properties at: ``space.random_point(rng)`` by default; override
        it to sample where the space is meant to be used (e.g. shapes near a template)."""
        return self.space.random_point(rng)

    def pair(self, rng):
        """A point and a nearby point reached by a tangent of size ~``tangent_scale``."""
        a = self.random_point(rng)
        v = self.space.random_tangent(a, rng, scale=self.tangent_scale)
        return a, self.space.exp(a, v), v

    def assert_points_close(self, x, y):
        np.testing.assert_allclose(x, y, rtol=self.rtol, atol=self.atol)

    def assert_tangents_close(self, u, v):
        for x, y in zip(self.tangent_arrays(u), self.tangent_arrays(v), strict=True):
            np.testing.assert_allclose(x, y, rtol=self.rtol, atol=self.atol)

    def tangent_arrays(self, v) -> list:
        """The arrays that make up a tangent vector (one array by default)."""
        return [np.asarray(v, dtype=float)]

    def corrupt_tangent(self, v):
        """A copy of the tangent ``v`` with a NaN entry (for the bad-input check)."""
        bad = np.array(v, dtype=float, copy=True)
        bad.flat[0] = np.nan
        return bad

    # ------------------------------------------------------------- contract
    def test_point_shape(self):
        rng = np.random.default_rng(0)
        p = self.random_point(rng)
        assert np.shape(p) == tuple(self.space.point_shape)
        assert np.all(self.space.belongs(p))

    def test_log_of_exp(self):
        def check(rng):
            a, b, v = self.pair(rng)
            self.assert_tangents_close(self.space.log(a, b), v)

        self.given_seed(check)

    def test_exp_of_log(self):
        def check(rng):
            a, b, _ = self.pair(rng)
            self.assert_points_close(self.space.exp(a, self.space.log(a, b)), b)

        self.given_seed(check)

    def test_log_at_self_is_zero(self):
        def check(rng):
            a = self.random_point(rng)
            for arr in self.tangent_arrays(self.space.log(a, a)):
                np.testing.assert_allclose(arr, np.zeros_like(arr), atol=self.atol)

        self.given_seed(check)

    def test_exp_lands_on_manifold(self):
        def check(rng):
            a = self.random_point(rng)
            v = self.space.random_tangent(a, rng, scale=self.tangent_scale)
            assert np.all(self.space.belongs(self.space.exp(a, v), atol=self.membership_atol))

        self.given_seed(check)

    def test_log_returns_a_tangent(self):
        def check(rng):
            a, b, _ = self.pair(rng)
            v = self.space.log(a, b)
            assert np.all(self.space.is_tangent(a, v, atol=self.membership_atol))

        self.given_seed(check)

    def triple(self, rng):
        """``(T, S, S')``: a template, a shape near it and a shape near the shape."""
        t = self.random_point(rng)
        s = self.space.exp(t, self.space.random_tangent(t, rng, scale=self.tangent_scale))
        s2 = self.space.exp(s, self.space.random_tangent(s, rng, scale=self.tangent_scale))
        return t, s, s2

    def test_symmetric_space_has_exact_one_rung_pole_ladder(self):
        if not self.space.is_symmetric:
            pytest.skip("space does not claim to be symmetric")

        def check(rng):
            t, s, s2 = self.triple(rng)
            m = self.space.midpoint(t, s)
            ladder = self.space.log(t, self.space.transvection(t, m)(s2))  # Algorithm 1
            try:
                exact = self.space.parallel_transport(s, t, self.space.log(s, s2))
            except NotImplementedError:
                pytest.skip("no exact parallel transport to compare with")
            self.assert_tangents_close(ladder, exact)

        self.given_seed(check)

    def test_symmetric_space_has_zero_transvectivity(self):
        if not self.space.is_symmetric:
            pytest.skip("space does not claim to be symmetric")

        def check(rng):
            t, s, s2 = self.triple(rng)
            m = self.space.midpoint(t, s)
            self.assert_points_close(
                self.space.transvection(t, m)(s2), self.space.transvection(m, s)(s2)
            )

        self.given_seed(check)

    def test_symmetry_fixes_center(self):
        def check(rng):
            a = self.random_point(rng)
            self.assert_points_close(self.space.symmetry(a, a), a)

        self.given_seed(check)

    def test_symmetry_is_involution(self):
        def check(rng):
            m, p, _ = self.pair(rng)
            self.assert_points_close(self.space.symmetry(m, self.space.symmetry(m, p)), p)

        self.given_seed(check)

    def test_symmetry_reverses_log(self):
        def check(rng):
            m, p, _ = self.pair(rng)
            s = self.space.symmetry(m, p)
            self.assert_tangents_close(self.space.log(m, s), -self.space.log(m, p))

        self.given_seed(check)

    def test_midpoint_is_halfway(self):
        def check(rng):
            a, b, _ = self.pair(rng)
            m = self.space.midpoint(a, b)
            self.assert_tangents_close(self.space.log(a, m), 0.5 * self.space.log(a, b))
            if isinstance(self.space, RiemannianManifold):
                d = self.space.dist(a, b)
                np.testing.assert_allclose(
                    self.space.dist(a, m), 0.5 * d, rtol=1e-8, atol=self.atol
                )
                np.testing.assert_allclose(
                    self.space.dist(m, b), 0.5 * d, rtol=1e-8, atol=self.atol
                )

        self.given_seed(check)

    def test_geodesic_endpoints(self):
        rng = np.random.default_rng(1)
        a, b, _ = self.pair(rng)
        path = self.space.geodesic(a, b)
        self.assert_points_close(path(0.0), a)
        self.assert_points_close(path(1.0), b)
        self.assert_points_close(path(0.5), self.space.midpoint(a, b))

    def test_dist_is_norm_of_tangent(self):
        if not isinstance(self.space, RiemannianManifold):
            pytest.skip("not a Riemannian space")

        def check(rng):
            a, b, v = self.pair(rng)
            np.testing.assert_allclose(
                self.space.dist(a, b), self.space.norm(a, v), rtol=1e-8, atol=self.atol
            )

        self.given_seed(check)

    def test_transport_preserves_inner_product(self):
        if not isinstance(self.space, RiemannianManifold):
            pytest.skip("not a Riemannian space")

        def check(rng):
            a, b, _ = self.pair(rng)
            u = self.space.random_tangent(a, rng)
            w = self.space.random_tangent(a, rng)
            try:
                tu = self.space.parallel_transport(a, b, u)
            except NotImplementedError:
                pytest.skip("no exact parallel transport")
            tw = self.space.parallel_transport(a, b, w)
            np.testing.assert_allclose(
                self.space.inner(b, tu, tw), self.space.inner(a, u, w), rtol=1e-8, atol=1e-9
            )
            # The geodesic's own velocity is transported to the velocity at the end.
            v = self.space.log(a, b)
            self.assert_tangents_close(
                self.space.parallel_transport(a, b, v), -self.space.log(b, a)
            )

        self.given_seed(check)

    def test_batch_equals_loop(self):
        if not self.space.supports_batch:
            pytest.skip("space does not broadcast over batch axes")
        rng = np.random.default_rng(2)
        pairs = [self.pair(rng) for _ in range(self.n_batch)]
        a = np.stack([p[0] for p in pairs])
        b = np.stack([p[1] for p in pairs])
        v = np.stack([p[2] for p in pairs])
        sp = self.space
        checks = [
            (sp.exp(a, v), [sp.exp(x, y) for x, y in zip(a, v)]),
            (sp.log(a, b), [sp.log(x, y) for x, y in zip(a, b)]),
            (sp.symmetry(a, b), [sp.symmetry(x, y) for x, y in zip(a, b)]),
            (sp.midpoint(a, b), [sp.midpoint(x, y) for x, y in zip(a, b)]),
        ]
        if isinstance(sp, RiemannianManifold):
            checks.append((sp.dist(a, b), [sp.dist(x, y) for x, y in zip(a, b)]))
            checks.append((sp.inner(a, v, v), [sp.inner(x, y, y) for x, y in zip(a, v)]))
        for batched, looped in checks:
            np.testing.assert_allclose(batched, np.stack(looped), rtol=1e-12, atol=1e-13)

    # ------------------------------------------------------------- far from the base point
    def far_triple(self, rng):
        """``(m, p, v)``: a centre ``m`` at ~``far_scale`` from a random point, ``p = Exp_m(v)``."""
        a = self.random_point(rng)
        m = self.space.exp(a, self.space.random_tangent(a, rng, scale=self.far_scale))
        v = self.space.random_tangent(m, rng, scale=self.tangent_scale)
        return m, self.space.exp(m, v), v

    def assert_close_relative(self, x, y):
        """``x == y`` up to ``far_rtol`` relative to the largest entry of ``y``."""
        for a, b in zip(self.tangent_arrays(x), self.tangent_arrays(y), strict=True):
            scale = max(float(np.max(np.abs(b))), 1.0)
            np.testing.assert_allclose(a, b, rtol=0, atol=self.far_rtol * scale)

    def skip_unless_far(self):
        if not self.far_scale:
            pytest.skip("far_scale = 0: no far-from-base checks for this space")

    def test_far_points_stay_on_manifold(self):
        self.skip_unless_far()

        def check(rng):
            m, p, _ = self.far_triple(rng)
            s = self.space.symmetry(m, p)
            for q in (m, p, s, self.space.symmetry(m, s), self.space.midpoint(m, p)):
                assert np.all(self.space.belongs(q, atol=self.membership_atol))

        self.given_seed(check)

    def test_far_log_of_exp(self):
        self.skip_unless_far()

        def check(rng):
            m, p, v = self.far_triple(rng)
            self.assert_close_relative(self.space.log(m, p), v)

        self.given_seed(check)

    def test_far_symmetry_is_involution_fixing_center(self):
        self.skip_unless_far()

        def check(rng):
            m, p, _ = self.far_triple(rng)
            self.assert_close_relative(self.space.symmetry(m, self.space.symmetry(m, p)), p)
            self.assert_close_relative(self.space.symmetry(m, m), m)

        self.given_seed(check)

    def test_nan_input_raises(self):
        rng = np.random.default_rng(3)
        a, b, v = self.pair(rng)
        bad = np.array(b, dtype=float, copy=True)
        bad.flat[0] = np.nan
        with pytest.raises(ManifoldError, match="other"):
            self.space.log(a, bad)
        with pytest.raises(ManifoldError, match="tangent"):
            self.space.exp(a, self.corrupt_tangent(v))

    def test_wrong_shape_raises(self):
        rng = np.random.default_rng(4)
        a, b, _ = self.pair(rng)
        wrong = np.zeros(tuple(s + 1 for s in self.space.point_shape))
        with pytest.raises(ManifoldError, match="other"):
            self.space.log(a, wrong)
