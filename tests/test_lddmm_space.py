"""The LDDMM landmark space: contract with registration-level tolerances, cache, validation."""

import numpy as np
import pytest

from ladders.pole_ladder import pole_ladder
from ladders.schild_ladder import schild_ladder
from ladders.symmetry_errors import symmetry_errors
from manifolds.errors import ManifoldError
from manifolds.lddmm import LDDMMLandmarks, RegistrationSettings
from manifolds.testing import ConnectionContract


def small_space(**kw):
    """Six well-separated landmarks: registration is well posed and fast."""
    params = dict(sigma=0.6, alpha=1e-3, control_points="dense", integrator="rk2")
    params.update(kw)
    return LDDMMLandmarks(6, 2, **params)


class TestLDDMMContract(ConnectionContract):
    """The generic contract; log is a registration, exact up to ~1e-6 here."""

    space = small_space()
    rtol = 1e-4
    atol = 1e-4
    tangent_scale = 0.3
    max_examples = 4


def test_symmetry_fixes_center_exactly_and_zero_momenta():
    space = small_space(control_points="grid")
    rng = np.random.default_rng(0)
    a = space.random_point(rng)
    np.testing.assert_array_equal(space.symmetry(a, a), a)
    zero = np.zeros_like(space.control_points(a))
    np.testing.assert_array_equal(space.exp(a, zero), a)
    np.testing.assert_array_equal(space.log(a, a), zero)


def test_log_with_residual_and_register_share_one_registration():
    space = small_space(alpha=0.3)
    rng = np.random.default_rng(1)
    a, b = space.random_point(rng), space.random_point(rng)
    mom = space.log(a, b)
    mom2, resid = space.log_with_residual(a, b)
    res = space.register(a, b)
    assert space.n_registrations == 1
    np.testing.assert_array_equal(mom, mom2)
    np.testing.assert_allclose(space.exp(a, mom) + resid, b, atol=1e-12)
    assert res.registration_error > 1e-3  # alpha = 0.3: inexact matching, nonzero residual
    mom[0, 0] += 1.0  # returned arrays are copies: the cache is not modified
    np.testing.assert_array_equal(space.log(a, b), mom2)
    assert space.n_registrations == 1
    space.register(b, a)
    assert space.n_registrations == 2


def test_cache_is_bounded_lru():
    space = small_space(cache_size=2)
    rng = np.random.default_rng(2)
    pts = [space.random_point(rng) for _ in range(4)]
    for p in pts[1:]:
        space.log(pts[0], p)
    assert space.n_registrations == 3 and len(space._cache) == 2
    space.log(pts[0], pts[1])  # evicted: registered again
    assert space.n_registrations == 4


def test_grid_tangents_inner_and_random_tangent_scale():
    space = LDDMMLandmarks(40, 3, sigma=0.5, alpha=0.1, control_points="grid")
    rng = np.random.default_rng(3)
    a = space.random_point(rng)
    cp = space.control_points(a)
    assert cp.shape[1] == 3 and 4 <= cp.shape[0] < 40
    u = space.random_tangent(a, rng, scale=0.2)
    assert u.shape == cp.shape
    vel = space.kernel.convolve(cp, cp, u)
    np.testing.assert_allclose(np.sqrt((vel**2).sum(1).mean()), 0.2, rtol=1e-12)
    v = space.random_tangent(a, rng)
    k = space.kernel_matrix(cp)
    np.testing.assert_allclose(space.inner(a, u, v), np.sum(u * (k @ v)), rtol=1e-12)
    np.testing.assert_allclose(space.norm(a, u) ** 2, space.inner(a, u, u), rtol=1e-12)
    np.testing.assert_allclose(space.kernel_solve(cp, k @ u), u, rtol=1e-6, atol=1e-8)
    deformed, traj = space.shoot(a, u, return_trajectory=True, integrator="rk2")
    assert len(traj) == space.n_steps + 1 and len(traj[0]) == 3
    np.testing.assert_allclose(deformed, space.exp(a, u), atol=0.05 * 0.2)


def test_validation_errors_name_the_argument():
    space = small_space()
    rng = np.random.default_rng(4)
    a = space.random_point(rng)
    with pytest.raises(ManifoldError, match="other"):
        space.log(a, np.zeros((7, 2)))
    with pytest.raises(ManifoldError, match="point"):
        space.exp(np.full((6, 2), np.nan), np.zeros((6, 2)))
    with pytest.raises(ManifoldError, match="tangent"):
        space.exp(a, np.zeros((5, 2)))
    with pytest.raises(ManifoldError, match="initial_momenta"):
        space.register(a, a, initial_momenta=np.zeros((6, 3)))
    with pytest.raises(ManifoldError, match="target"):
        space.register(a, np.ones((6, 3)))
    with pytest.raises(ManifoldError, match="dim"):
        LDDMMLandmarks(6, 4, sigma=1.0, alpha=0.1)
    with pytest.raises(ManifoldError, match="alpha"):
        LDDMMLandmarks(6, 2, sigma=1.0, alpha=-1.0)
    with pytest.raises(ManifoldError, match="control_points"):
        LDDMMLandmarks(6, 2, sigma=1.0, alpha=0.1, control_points="random")


def test_ladders_and_symmetry_errors_run_on_the_space():
    space = small_space()
    rng = np.random.default_rng(5)
    s = space.random_point(rng)
    t = space.exp(s, space.random_tangent(s, rng, 0.2))
    u = space.random_tangent(s, rng, 0.15)
    # Transport from a point to itself is the identity up to registration accuracy.
    for ladder in (pole_ladder, schild_ladder):
        np.testing.assert_allclose(ladder(space, s, s, u), u, atol=1e-4 * np.abs(u).max())
    for ladder in (pole_ladder, schild_ladder):
        w = ladder(space, s, t, u, n_rungs=2)
        assert w.shape == u.shape and np.all(np.isfinite(w))
        # Transport roughly preserves the size of the vector (up to curvature effects).
        np.testing.assert_allclose(space.norm(t, w), space.norm(s, u), rtol=0.2)
    s2 = space.exp(s, u)
    errs = symmetry_errors(space, t, s, s2).as_dict()
    size = np.linalg.norm(s - s.mean(0))
    for name in ("midpoint_distance", "centrality", "involutivity"):
        assert 0 <= errs[name] < 1e-3 * size, (name, errs[name])
    assert 0 <= errs["transvectivity"] < 0.1 * size


def test_finegrid_policy_halves_the_spacing():
    from manifolds.lddmm import grid_control_points

    space = small_space(control_points="finegrid", sigma=0.3)
    rng = np.random.default_rng(5)
    t = space.random_point(rng)
    cp = space.control_points(t)
    np.testing.assert_array_equal(cp, grid_control_points(t, 0.15))
    coarse = small_space(control_points="grid", sigma=0.3).control_points(t)
    assert len(cp) > 2 * len(coarse)
    steps = np.diff(np.unique(np.round(cp[:, 0], 12)))
    np.testing.assert_allclose(steps, 0.15)


def test_vertices_policy_is_a_spacing_net_of_the_template():
    """Farthest-point sample: every vertex within the spacing of a control point, the
    control points at least the spacing apart, rows of the template, deterministic."""
    from manifolds.lddmm.control_points import farthest_point_indices

    rng = np.random.default_rng(11)
    t = rng.normal(size=(400, 3)) * np.array([3.0, 2.0, 1.0])
    space = LDDMMLandmarks(400, 3, sigma=1.0, alpha=0.1, control_points="vertices")
    cp = space.control_points(t)
    spacing = 0.7  # VERTEX_SPACING * sigma
    idx = farthest_point_indices(t, spacing)
    np.testing.assert_array_equal(cp, t[idx])
    assert np.all(np.diff(idx) > 0)
    to_cp = np.sqrt(((t[:, None] - cp[None]) ** 2).sum(-1))
    assert to_cp.min(axis=1).max() < spacing
    between = np.sqrt(((cp[:, None] - cp[None]) ** 2).sum(-1)) + np.eye(len(cp)) * 1e9
    assert between.min() >= spacing
    np.testing.assert_array_equal(space.control_points(t.copy()), cp)
    finer = space.settings.replace(control_point_spacing=0.35).resolve_control_points(t)
    assert len(cp) < len(finer) < len(t)
    tiny = space.settings.replace(control_point_spacing=1e-9).resolve_control_points(t)
    np.testing.assert_array_equal(tiny, t)  # every vertex: the dense policy
    huge = space.settings.replace(control_point_spacing=1e9).resolve_control_points(t)
    assert huge.shape == (1, 3)


def test_vertices_policy_registers_and_round_trips():
    rng = np.random.default_rng(12)
    t = rng.normal(size=(60, 2))
    space = LDDMMLandmarks(60, 2, sigma=1.0, alpha=1e-2, control_points="vertices")
    cp = space.control_points(t)
    assert 1 < len(cp) < 60
    mu = 0.3 * rng.normal(size=cp.shape)
    s = space.exp(t, mu)
    back = space.log(t, s)
    np.testing.assert_allclose(space.exp(t, back), s, atol=2e-3)


def test_fixed_vertex_indices_are_material_control_points():
    """With the sample drawn once (``control_point_indices``) every shape in
    correspondence carries its momenta at the same vertices, and a geodesic carries
    its control points exactly as it carries those vertices: the control points at
    ``t = 1`` are the control points of ``Exp_T(mu)``."""
    rng = np.random.default_rng(13)
    t = rng.normal(size=(80, 3)) * np.array([3.0, 2.0, 1.0])
    settings = RegistrationSettings(sigma=1.0, control_points="vertices")
    fixed = settings.fix_control_point_indices(t)
    idx = np.asarray(fixed.control_point_indices)
    np.testing.assert_array_equal(
        fixed.resolve_control_points(t), settings.resolve_control_points(t)
    )
    assert fixed.fix_control_point_indices(2.0 * t) is fixed  # already fixed: unchanged
    space = LDDMMLandmarks(80, 3, alpha=0.1, settings=fixed)
    mu = 0.3 * rng.normal(size=(len(idx), 3))
    s = space.exp(t, mu)
    np.testing.assert_array_equal(space.control_points(s), s[idx])
    _, states = space.shoot(t, mu, return_trajectory=True)
    c_end = states[-1][0]
    np.testing.assert_allclose(c_end, s[idx], rtol=0, atol=1e-12)
    with pytest.raises(ManifoldError, match="control_point_indices.*out of range"):
        LDDMMLandmarks(int(idx.max()), 3, alpha=0.1, settings=fixed)


def test_study_space_draws_the_vertex_sample_on_the_atlas():
    from ladders.study.running import StudyConfig
    from ladders.study.running.pipeline import make_space
    from manifolds.lddmm.control_points import farthest_point_indices

    atlas = np.random.default_rng(14).normal(size=(120, 3)) * 20.0
    space = make_space(StudyConfig(), atlas, 1.0)
    expected = farthest_point_indices(atlas, 7.0)  # 0.7 sigma at the default sigma = 10
    np.testing.assert_array_equal(space.settings.control_point_indices, expected)
    shape = 0.8 * atlas
    np.testing.assert_array_equal(space.control_points(shape), shape[expected])
    grid = make_space(StudyConfig.build(control_points="grid"), atlas, 1.0)
    assert grid.settings.control_point_indices is None


def test_study_preflight_budget_covers_the_finer_grid():
    from ladders.study.cli.cli_types import check_sigma
    from manifolds.lddmm import RegistrationSettings

    def settings(sigma, policy):
        return RegistrationSettings(sigma=sigma, control_points=policy)

    shape = np.random.default_rng(0).uniform(0.0, 100.0, (50, 3))  # a 100 mm box
    check_sigma(shape, settings(5.0, "grid"))  # 21^3 = 9,261 points: within the budget
    with pytest.raises(ManifoldError, match="sigma"):
        check_sigma(shape, settings(5.0, "finegrid"))  # spacing 2.5 mm: 41^3 = 68,921
    check_sigma(shape, settings(20.0, "dense"))  # no grid, nothing to count
    check_sigma(shape, settings(20.0, "vertices"))  # at most the vertices
    # a unit slip: sigma far below the vertex spacing or far above the extent
    spacing = np.median(np.sort(np.sqrt(((shape[:, None] - shape[None]) ** 2).sum(-1)))[:, 1])
    for sigma in (0.05 * spacing, 200.0 * 100.0):
        for policy in ("dense", "vertices", "grid"):
            with pytest.raises(ManifoldError, match="sigma.*another unit"):
                check_sigma(shape, settings(sigma, policy))


def test_dense_means_control_points_at_the_template_vertices_everywhere():
    """shoot tells dense control points as the registration does (equal values, not
    only the same array): a copy of the template is carried as the control points."""
    from manifolds.lddmm.control_points import is_dense

    rng = np.random.default_rng(7)
    space = LDDMMLandmarks(12, 2, sigma=0.8, alpha=0.1, control_points="dense")
    s = space.random_point(rng)
    mu = 0.2 * space.random_tangent(s, rng)
    d1, t1 = space.shoot(s, mu, return_trajectory=True)
    d2, t2 = space.shoot(s, mu, control_points=s.copy(), return_trajectory=True)
    assert is_dense(s, s.copy()) and len(t1[0]) == len(t2[0]) == 2  # states (c, mu)
    np.testing.assert_array_equal(d1, d2)
    grid = LDDMMLandmarks(12, 2, sigma=0.8, alpha=0.1, control_points="grid")
    _, t3 = grid.shoot(s, np.zeros_like(grid.control_points(s)), return_trajectory=True)
    assert len(t3[0]) == 3  # (c, mu, x): the template follows the flow of other points
