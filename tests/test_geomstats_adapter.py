"""geomstats spaces through manifolds.interop.geomstats: contract, ladders, agreement."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

# The adapter (it aliases numpy.trapz for geomstats 2.8) is imported before geomstats.
pytest.importorskip("manifolds.interop.geomstats")

from geomstats.geometry.connection import Connection as GsConnection  # noqa: E402
from geomstats.geometry.hyperboloid import Hyperboloid  # noqa: E402
from geomstats.geometry.hypersphere import Hypersphere  # noqa: E402
from geomstats.geometry.spd_matrices import SPDMatrices  # noqa: E402

import manifolds  # noqa: E402
from ladders import loglog_slope, pole_ladder, schild_ladder, symmetry_errors  # noqa: E402
from manifolds import ManifoldError, NotOnManifoldError, NotTangentError  # noqa: E402
from manifolds.interop import GeomstatsConnection, GeomstatsManifold, from_geomstats  # noqa: E402
from manifolds.testing import ConnectionContract  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RTOL = 1e-10  # relative agreement required with geomstats' own transports

SPACES = {
    "S2": lambda: Hypersphere(2),
    "H2": lambda: Hyperboloid(2),
    "SPD3": lambda: SPDMatrices(3),
}
OURS = {
    "S2": lambda: manifolds.Hypersphere(2),
    "H2": lambda: manifolds.Hyperbolic(2),
    "SPD3": lambda: manifolds.SPDMatrices(3),
}


def wrap(key):
    return from_geomstats(SPACES[key](), is_symmetric=True)


def relative(x, ref):
    return np.abs(np.asarray(x) - ref).max() / np.abs(ref).max()


def configuration(space, seed, reach=0.8, size=0.5):
    """A base point, an end point at geodesic distance ~``reach``, a tangent of size ~``size``."""
    rng = np.random.default_rng(seed)
    base = space.random_point(rng)
    end = space.exp(base, space.random_tangent(base, rng, scale=reach))
    return base, end, space.random_tangent(base, rng, scale=size)


# ------------------------------------------------------------------ contract
class TestSphereContract(ConnectionContract):
    space = wrap("S2")


class TestHyperboloidContract(ConnectionContract):
    space = wrap("H2")


class TestSPDContract(ConnectionContract):
    space = wrap("SPD3")
    rtol = 1e-9  # geomstats' SPD logm/expm lose a few more digits than the sphere's formulas


# ------------------------------------------------------------------ argument order
@pytest.mark.parametrize("key", sorted(SPACES))
def test_argument_order_matches_geomstats(key):
    space = wrap(key)
    base, end, v = configuration(space, 0)
    metric = space.space.metric
    np.testing.assert_allclose(space.exp(base, v), metric.exp(v, base), rtol=0, atol=0)
    np.testing.assert_allclose(space.log(base, end), metric.log(end, base), rtol=0, atol=0)
    np.testing.assert_allclose(
        space.parallel_transport(base, end, v),
        metric.parallel_transport(v, base, end_point=end),
        rtol=0,
        atol=0,
    )
    np.testing.assert_allclose(space.inner(base, v, v), metric.inner_product(v, v, base))


@pytest.mark.parametrize("key", sorted(SPACES))
def test_agrees_with_our_closed_forms(key):
    """Same space, two implementations: exp, log, transport and distance coincide."""
    space, ours = wrap(key), OURS[key]()
    for seed in range(5):
        base, end, v = configuration(space, seed)
        np.testing.assert_allclose(space.exp(base, v), ours.exp(base, v), rtol=1e-11, atol=1e-12)
        np.testing.assert_allclose(
            space.log(base, end), ours.log(base, end), rtol=1e-10, atol=1e-11
        )
        np.testing.assert_allclose(
            space.parallel_transport(base, end, v),
            ours.parallel_transport(base, end, v),
            rtol=1e-10,
            atol=1e-11,
        )
        np.testing.assert_allclose(space.dist(base, end), ours.dist(base, end), rtol=1e-11)


# ------------------------------------------------------------------ ladders
@pytest.mark.parametrize("key", sorted(SPACES))
@pytest.mark.parametrize("n_rungs", [1, 2, 5])
def test_pole_ladder_matches_exact_transport(key, n_rungs):
    """The pole ladder is exact in a symmetric space (paper, Section 2.2)."""
    space = wrap(key)
    for seed in range(3):
        base, end, u = configuration(space, seed)
        exact = space.space.metric.parallel_transport(u, base, end_point=end)
        assert relative(pole_ladder(space, base, end, u, n_rungs=n_rungs), exact) < RTOL


@pytest.mark.parametrize("key", sorted(SPACES))
@pytest.mark.parametrize("scheme", ["pole", "schild"])
@pytest.mark.parametrize("n_rungs", [1, 2, 5])
def test_ladders_match_geomstats_ladders(key, scheme, n_rungs):
    """Same scheme, same rungs, same scaling as geomstats' ladder_parallel_transport."""
    space = wrap(key)
    ladder, exponent = (pole_ladder, 1.0) if scheme == "pole" else (schild_ladder, 2.0)
    for seed in range(3):
        base, end, u = configuration(space, seed)
        theirs = space.space.metric.ladder_parallel_transport(
            u, base, space.log(base, end), n_rungs=n_rungs, scheme=scheme, alpha=exponent
        )["transported_tangent_vec"]
        ours = ladder(space, base, end, u, n_rungs=n_rungs, scaling_exponent=exponent)
        assert relative(ours, theirs) < RTOL


def test_schild_ladder_converges_at_second_order():
    """Schild's ladder is not exact: its error to the exact transport decays as n^-2."""
    space = wrap("S2")
    base, end, u = configuration(space, 1, reach=1.0, size=0.8)
    exact = space.parallel_transport(base, end, u)
    n = np.array([2, 4, 8, 16])
    errors = [relative(schild_ladder(space, base, end, u, n_rungs=k), exact) for k in n]
    assert errors[0] > 1e-3  # far from exact, so the slope measures the scheme
    assert abs(loglog_slope(n, errors) + 2.0) < 0.15


@pytest.mark.parametrize("key", sorted(SPACES))
def test_symmetry_errors_vanish_in_symmetric_spaces(key):
    space = wrap(key)
    template, shape, _ = configuration(space, 3)
    shape2 = space.exp(shape, space.random_tangent(shape, np.random.default_rng(4), scale=0.4))
    errors = symmetry_errors(space, template, shape, shape2)
    scale = np.abs(np.stack([template, shape, shape2])).max()
    for name, value in errors.as_dict().items():
        assert value < 1e-12 * scale, name


def test_symmetry_errors_see_a_wrong_midpoint():
    """A space whose midpoint is off the geodesic has a positive centrality error."""

    class Skewed(GeomstatsManifold):
        def midpoint(self, a, b):
            m = super().midpoint(a, b)
            return self.exp(m, 1e-3 * self.random_tangent(m, np.random.default_rng(0)))

    space = Skewed(Hypersphere(2))
    template, shape, _ = configuration(space, 5)
    errors = symmetry_errors(space, template, shape, shape)
    assert errors.centrality > 1e-4


# ------------------------------------------------------------------ sampling
@pytest.mark.parametrize("key", sorted(SPACES))
def test_random_draws_use_only_the_given_generator(key):
    space = wrap(key)
    # geomstats draws from numpy's legacy global generator: it must stay untouched.
    state = np.random.get_state()[1].copy()  # noqa: NPY002
    a = space.random_point(np.random.default_rng(7), n_samples=3)
    b = space.random_point(np.random.default_rng(7), n_samples=3)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(np.random.get_state()[1], state)  # noqa: NPY002
    assert a.shape == (3, *space.point_shape) and np.all(space.belongs(a))
    v = space.random_tangent(a, np.random.default_rng(8), scale=0.3)
    assert np.all(space.is_tangent(a, v))


@pytest.mark.parametrize("key", sorted(SPACES))
def test_random_tangent_has_the_requested_size(key):
    space = wrap(key)
    base = space.random_point(np.random.default_rng(1))
    vs = space.random_tangent(
        np.broadcast_to(base, (4000, *space.point_shape)), np.random.default_rng(2), 0.7
    )
    np.testing.assert_allclose(np.mean(space.inner(base, vs, vs)), 0.49, rtol=0.05)
    dists = space.dist(space.base_point, space.random_point(np.random.default_rng(3), 4000))
    np.testing.assert_allclose(np.mean(dists**2), space.spread**2, rtol=0.05)


# ------------------------------------------------------------------ errors and options
def test_bad_input_names_the_argument():
    space = wrap("S2")
    base, end, v = configuration(space, 0)
    with pytest.raises(NotOnManifoldError, match="point"):
        space.exp(2.0 * base, v)
    with pytest.raises(NotTangentError, match="tangent"):
        space.exp(base, base)
    with pytest.raises(ManifoldError, match="end"):
        space.parallel_transport(base, np.full(3, np.nan), v)
    with pytest.raises(ManifoldError, match="scale"):
        space.random_tangent(base, np.random.default_rng(0), scale=-1.0)
    with pytest.raises(ManifoldError, match="n_samples"):
        space.random_point(np.random.default_rng(0), n_samples=0)
    with pytest.raises(TypeError, match="space"):
        from_geomstats(manifolds.Hypersphere(2))
    with pytest.raises(ManifoldError, match="spread"):
        from_geomstats(Hypersphere(2), spread=0.0)
    with pytest.raises(NotOnManifoldError, match="base_point"):
        from_geomstats(Hypersphere(2), base_point=np.ones(3))


class SphereConnection(GsConnection):
    """The sphere's Levi-Civita connection as a bare geomstats Connection (no metric)."""

    def exp(self, tangent_vec, base_point):
        return self._space.metric.exp(tangent_vec, base_point)

    def log(self, point, base_point):
        return self._space.metric.log(point, base_point)


def test_connection_without_metric_or_exact_transport():
    """A bare connection runs the ladders; no metric, no closed-form transport."""
    sphere = Hypersphere(2)
    space = from_geomstats(sphere, SphereConnection(sphere), is_symmetric=True)
    assert type(space) is GeomstatsConnection
    assert not space.has_exact_transport()
    base, end, u = configuration(space, 2)
    with pytest.raises(NotImplementedError, match="parallel_transport"):
        space.parallel_transport(base, end, u)
    with pytest.raises(NotImplementedError, match="metric"):
        space.dist(base, end)
    exact = sphere.metric.parallel_transport(u, base, end_point=end)
    assert relative(pole_ladder(space, base, end, u), exact) < RTOL
    with pytest.raises(TypeError, match="RiemannianMetric"):
        GeomstatsManifold(sphere, SphereConnection(sphere))
    with pytest.raises(TypeError, match="connection"):
        GeomstatsConnection(sphere, connection="metric")


def test_trapz_alias_integrates_like_trapezoid():
    """geomstats' gs.trapz (needed by its functional spaces) works on current numpy."""
    import geomstats.backend as gs

    x = np.linspace(0.0, 1.0, 101)
    np.testing.assert_allclose(gs.trapz(x**2, x=x), np.trapezoid(x**2, x=x), rtol=1e-15)
    np.testing.assert_allclose(gs.trapz(x**2, x=x), 1.0 / 3.0, rtol=1e-4)


def test_docs_page_snippets_run():
    """In a fresh interpreter, so that the page's import order is what is tested."""
    text = (ROOT / "docs" / "geomstats.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks
    for block in blocks:
        proc = subprocess.run(
            [sys.executable, "-c", block], capture_output=True, text=True, cwd=ROOT, timeout=120
        )
        assert proc.returncode == 0, proc.stderr[-3000:]
