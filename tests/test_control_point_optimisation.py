"""Registration over control points and momenta (eq. 3) and tangents that carry their control points.

The gradient itself is checked in ``test_lddmm_gradient.py``; here: the
tangent type's arithmetic, the connection (exp, log, symmetry, pole ladder,
residual-augmented space, fanning) with optimised control points, and that
optimising the control points lowers the registration objective.
"""

import numpy as np
import pytest

from ladders import (
    fanning_scheme,
    fanning_transport,
    pole_ladder,
    schild_ladder,
    symmetry_errors,
)
from manifolds import LandmarkTangent, LDDMMLandmarks, ManifoldError, ResidualAugmented
from manifolds.residual import ResidualTangent

# The properties checked here hold at any iterate: the registrations need not converge.
pytestmark = pytest.mark.filterwarnings("ignore::manifolds.errors.ConvergenceWarning")

K, SIGMA, ALPHA = 24, 0.5, 0.3
OPTIONS = {"max_iter": 150}  # settings overrides of the spaces


def _spaces(alpha=ALPHA):
    kw = dict(sigma=SIGMA, alpha=alpha, control_points="grid", **OPTIONS)
    fixed = LDDMMLandmarks(K, 2, **kw)
    optimised = LDDMMLandmarks(K, 2, optimize_control_points=True, **kw)
    return fixed, optimised


def _shapes(seed=0):
    rng = np.random.default_rng(seed)
    fixed, _ = _spaces()
    t = fixed.random_point(rng)
    s = fixed.exp(t, 0.4 * fixed.random_tangent(t, rng)) + 0.02 * rng.standard_normal((K, 2))
    s2 = fixed.exp(s, 0.3 * fixed.random_tangent(s, rng))
    return t, s, s2


def test_landmark_tangent_arithmetic_acts_on_the_momenta():
    rng = np.random.default_rng(0)
    c, mu, nu = rng.standard_normal((3, 5, 2))
    u, w = LandmarkTangent(c, mu), LandmarkTangent(c.copy(), nu)
    for out, expected in (
        (-u, -mu),
        (2.5 * u, 2.5 * mu),
        (u * 2.5, 2.5 * mu),
        (u / 4, mu / 4),
        (u + w, mu + nu),
        (u - w, mu - nu),
        (np.float64(0.5) * u, 0.5 * mu),
    ):
        assert isinstance(out, LandmarkTangent)
        np.testing.assert_array_equal(out.momenta, expected)
        np.testing.assert_array_equal(out.control_points, c)
    with pytest.raises(ManifoldError, match="different control points"):
        u + LandmarkTangent(c + 1e-3, nu)
    with pytest.raises(TypeError):
        np.ones((5, 2)) * u
    with pytest.raises(ManifoldError, match="same shape"):
        LandmarkTangent(c, mu[:3])


def test_optimising_control_points_lowers_the_objective():
    t, s, _ = _shapes()
    fixed, optimised = _spaces()
    r_fixed, r_opt = fixed.register(t, s), optimised.register(t, s)
    grid = fixed.control_points(t)
    np.testing.assert_array_equal(r_fixed.control_points, grid)
    assert np.abs(r_opt.control_points - grid).max() > 1e-3 * SIGMA  # they moved
    assert r_opt.objective < 0.9 * r_fixed.objective
    # The reported objective is eq. 3 at the optimised (c, mu).
    reg = ALPHA**2 * fixed.kernel.rkhs_inner(r_opt.control_points, r_opt.momenta, r_opt.momenta)
    np.testing.assert_allclose(r_opt.objective, (r_opt.residual**2).sum() + reg, rtol=1e-10)


def test_exp_log_symmetry_with_control_points():
    t, s, _ = _shapes(seed=1)
    _, space = _spaces()
    v = space.log(t, s)
    assert isinstance(v, LandmarkTangent)
    reg = space.register(t, s)
    np.testing.assert_array_equal(v.control_points, reg.control_points)
    # exp shoots from the tangent's own control points.
    np.testing.assert_allclose(space.exp(t, v), reg.deformed, atol=1e-12)
    by_hand = space.shoot(t, -v.momenta, control_points=v.control_points)
    np.testing.assert_allclose(space.symmetry(t, s), by_hand, atol=1e-12)
    np.testing.assert_allclose(
        space.midpoint(t, s), space.shoot(t, 0.5 * v.momenta, v.control_points), atol=1e-12
    )
    # Plain momenta still mean momenta at the policy's control points.
    mu = np.zeros_like(space.control_points(t))
    np.testing.assert_array_equal(space.exp(t, mu), t)
    np.testing.assert_allclose(space.norm(t, v), reg.rkhs_norm, rtol=1e-12)


def test_residual_space_and_pole_ladder_with_control_points():
    t, s, s2 = _shapes(seed=2)
    _, space = _spaces()
    aug = ResidualAugmented(space)
    u = aug.log(s, s2)
    assert isinstance(u, ResidualTangent) and isinstance(u.tangent, LandmarkTangent)
    np.testing.assert_allclose(aug.exp(s, u), s2, atol=1e-12)  # exact with the residual
    w, traj = pole_ladder(aug, s, t, u, n_rungs=1, return_trajectory=True)
    # One rung: T' = s_T(s_M(S')) and the transported vector is Log_T(T').
    errs = symmetry_errors(aug, t, s, s2)
    np.testing.assert_allclose(traj.end_point, errs.points["pole_ladder"], atol=1e-9)
    assert isinstance(w.tangent, LandmarkTangent)
    for ladder in (pole_ladder, schild_ladder):  # several rungs: sums and scalings of tangents
        w2, traj2 = ladder(aug, s, t, u, n_rungs=2, return_trajectory=True)
        assert isinstance(w2.tangent, LandmarkTangent) and np.isfinite(traj2.end_point).all()
        np.testing.assert_allclose(aug.exp(t, w2), traj2.end_point, atol=1e-12)
    for variant in (True, False):
        values = symmetry_errors(ResidualAugmented(space, variant), t, s, s2).as_dict()
        assert all(np.isfinite(x) and x >= 0 for x in values.values())


def test_fanning_takes_the_tangents_control_points():
    t, s, s2 = _shapes(seed=3)
    _, space = _spaces()
    geodesic, u = space.log(s, t), space.log(s, s2)
    assert not np.array_equal(geodesic.control_points, u.control_points)
    out = fanning_transport(space, s, t, u, n_steps=5)
    # The tangent is carried to the geodesic's control points by matching its velocity there.
    c = geodesic.control_points
    w0 = space.kernel_solve(c, space.kernel.convolve(c, u.control_points, u.momenta))
    ref = fanning_scheme(space, c, geodesic.momenta, w0, n_steps=5)
    np.testing.assert_allclose(out.momenta, ref.momenta, atol=1e-12)
    # A tangent already at the geodesic's control points is used as it is.
    same = fanning_transport(space, s, t, LandmarkTangent(c, w0), n_steps=5)
    np.testing.assert_array_equal(same.momenta, ref.momenta)
    np.testing.assert_array_equal(same.control_points, ref.control_points)


def test_inverse_consistency_units():
    t, s, _ = _shapes(seed=4)
    fixed, _ = _spaces()
    rms = fixed.inverse_consistency(t, s)
    frob = fixed.inverse_consistency(t, s, distance="frobenius")
    np.testing.assert_allclose(frob, np.sqrt(K) * rms, rtol=1e-12)
    assert fixed.inverse_consistency(t, s, distance="mean") <= rms * (1 + 1e-12)
    with pytest.raises(ValueError, match="distance"):
        fixed.inverse_consistency(t, s, distance="max")


def test_study_runs_with_optimised_control_points_and_reports_in_the_chosen_unit():
    from ladders.study.cohort import make_synthetic_cohort
    from ladders.study.running import StudyConfig, compute_pair

    cohort = make_synthetic_cohort(n_subjects=1, n_vertices=241, seed=0)
    args = (cohort.atlas, cohort.faces, cohort.subjects[0], 1.0)
    k = cohort.atlas.shape[0]
    out = {}
    for distance in ("rms", "frobenius"):
        config = StudyConfig.build(alpha2=(1.0,), max_iter=20, distance=distance)
        out[distance] = compute_pair(config, *args)
    for name in ("registration_error", "inverse_consistency"):
        np.testing.assert_allclose(
            out["frobenius"].measure("residual", name),
            np.sqrt(k) * out["rms"].measure("residual", name),
            rtol=1e-9,
        )
    np.testing.assert_allclose(out["rms"].registration.error, out["rms"].registration.rms)
    for measure in ("involutivity", "transvectivity"):
        np.testing.assert_allclose(
            out["frobenius"].measure("residual", measure),
            np.sqrt(k) * out["rms"].measure("residual", measure),
            rtol=1e-9,
        )
    config = StudyConfig.build(alpha2=(1.0,), sigma=20.0, max_iter=20, optimize_control_points=True)
    optimised = compute_pair(config, *args)
    # On this subject optimising c lowers the registration error too (0.29 vs 0.35 mm).
    assert optimised.registration.error < out["rms"].registration.error
    values = [optimised.measure(v, "centrality") for v in ("residual", "no_residual")]
    assert np.all(np.isfinite(values)) and np.isfinite(optimised.transport("fanning").ase)


def test_warm_start_from_a_tangent_with_control_points():
    t, s, _ = _shapes(seed=5)
    fixed, space = _spaces()
    first = space.register(t, s)
    v = space.log(t, s)
    assert space.is_tangent(t, v) and fixed.is_tangent(t, np.zeros_like(fixed.control_points(t)))
    again = space.register(t, s, initial_momenta=v)
    assert space.n_registrations == 2  # a different start is a different registration
    assert again.objective <= first.objective * (1 + 1e-12)
    with pytest.raises(ManifoldError, match="initial_momenta"):
        fixed.register(t, s, initial_momenta=v)
