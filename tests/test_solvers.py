"""Registration solvers and stopping rules: minima on problems with a known answer.

The Gauss-Newton product is checked against the exact Hessian where the two
coincide (zero residual), the solvers are compared on exact shots (known
minimiser), the joint preconditioner's change of variables is exact, and the
``"shape"`` stopping rule stops within its tolerance of the converged shape.
"""

import numpy as np
import pytest

from manifolds.lddmm import (
    LDDMMLandmarks,
    RegistrationSettings,
    build_registration_problem,
    register,
)
from manifolds.lddmm.control_points import resolve_control_points
from manifolds.lddmm.hamiltonian_shooting import HamiltonianFlow
from manifolds.lddmm.joint_preconditioner import JointPreconditioner
from manifolds.lddmm.stationary_flow import StationaryKernelFlow
from manifolds.numerics.solvers import SOLVERS, StoppingRule, krylov_lower_bound, steihaug_cg

SIGMA = 0.6


def exact_pair(seed=0, k=24, dim=2, policy="grid", scale=0.3):
    space = LDDMMLandmarks(k, dim, sigma=SIGMA, alpha=0.0, control_points=policy)
    rng = np.random.default_rng(seed)
    template = space.random_point(rng)
    momenta = space.random_tangent(template, rng, scale)
    return space, template, space.exp(template, momenta), momenta


def problem_at(template, target, alpha, settings, model_class=HamiltonianFlow):
    return build_registration_problem(model_class, template, target, alpha, settings)


def test_built_problem_solved_by_hand_equals_register():
    _, template, target, _ = exact_pair(3)
    settings = RegistrationSettings(sigma=SIGMA, control_points="grid", max_iter=200)
    problem, x0 = problem_at(template, target, 0.3, settings)
    opt = SOLVERS["lbfgsb"](problem, x0, settings.solver_options(), settings.stopping_rule())
    mine = problem.result(opt)
    res = register(template, target, 0.3, settings)
    np.testing.assert_allclose(mine.momenta, res.momenta, rtol=1e-12, atol=1e-14)
    assert mine.n_flow_evaluations == res.n_flow_evaluations
    assert problem.size == x0.size == res.momenta.size


@pytest.mark.parametrize("model_class", [HamiltonianFlow, StationaryKernelFlow])
def test_gauss_newton_product_is_symmetric_and_equals_the_hessian_at_zero_residual(model_class):
    space, template, target, momenta = exact_pair(1)
    settings = RegistrationSettings(sigma=SIGMA, control_points="grid", integrator="euler")
    prob, _ = problem_at(template, target, 0.0, settings, model_class)
    if model_class is HamiltonianFlow:  # the target is an exact LDDMM shot: zero residual there
        x = prob.variables(momenta, prob.control_points)
    else:
        x = prob.variables(0.5 * momenta, prob.control_points)
    rng = np.random.default_rng(2)
    u, v = rng.standard_normal(x.size), rng.standard_normal(x.size)
    hv, hu = prob.gauss_newton_product(x, v), prob.gauss_newton_product(x, u)
    assert abs(u @ hv - v @ hu) <= 1e-10 * abs(u @ hv)
    assert v @ hv > 0  # positive semi-definite
    if model_class is HamiltonianFlow:
        eps = 1e-6
        fd = (prob.value_and_gradient(x + eps * v)[1] - prob.value_and_gradient(x - eps * v)[1]) / (
            2 * eps
        )
        np.testing.assert_allclose(hv, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())


def test_steihaug_cg_solves_a_convex_quadratic_and_stops_at_the_boundary():
    rng = np.random.default_rng(3)
    a = rng.standard_normal((12, 12))
    h = a @ a.T + 0.5 * np.eye(12)
    g = rng.standard_normal(12)
    p, pred, _, reason = steihaug_cg(lambda v: h @ v, g, np.inf, 1e-12, 100)
    np.testing.assert_allclose(p, np.linalg.solve(h, -g), rtol=1e-8)
    assert reason == "converged" and pred == pytest.approx(0.5 * g @ np.linalg.solve(h, g))
    radius = 0.5 * np.linalg.norm(p)
    q, _, _, reason = steihaug_cg(lambda v: h @ v, g, radius, 1e-12, 100)
    assert reason == "boundary" and np.linalg.norm(q) == pytest.approx(radius)
    # negative curvature: the step goes to the boundary along it
    q, _, _, reason = steihaug_cg(lambda v: -v, g, 2.0, 1e-12, 100)
    assert reason == "negative curvature" and np.linalg.norm(q) == pytest.approx(2.0)


@pytest.mark.parametrize("solver", sorted(SOLVERS))
def test_every_solver_recovers_an_exact_shot(solver):
    space, template, target, _ = exact_pair(4, policy="dense", scale=0.25)
    settings = RegistrationSettings(
        sigma=SIGMA, control_points="dense", solver=solver, stopping="shape", shape_tol=1e-7,
        max_iter=500,
    )  # fmt: skip
    res = register(template, target, 1e-4, settings)
    assert res.converged
    assert res.rms_error <= 1e-5 * np.ptp(target)


def test_solvers_reach_the_same_minimum_of_a_regularised_problem():
    _, template, target, _ = exact_pair(5, scale=0.4)
    target = target + 0.02 * np.random.default_rng(6).standard_normal(target.shape)
    base = RegistrationSettings(
        sigma=SIGMA, control_points="grid", stopping="shape", shape_tol=1e-8
    )
    results = {s: register(template, target, 0.1, base.replace(solver=s)) for s in sorted(SOLVERS)}
    values = [r.objective for r in results.values()]
    assert max(values) - min(values) <= 1e-8 * min(values)
    shapes = [r.deformed for r in results.values()]
    for other in shapes[1:]:
        assert np.sqrt(((other - shapes[0]) ** 2).sum(1).mean()) <= 1e-6


def test_shape_rule_stops_within_its_tolerance_of_the_converged_shape():
    _, template, target, _ = exact_pair(7, k=40, scale=0.5)
    tight = register(template, target, 0.05, RegistrationSettings(sigma=SIGMA, ftol=1e-15,
                     gtol=1e-13, max_iter=5000, control_points="grid"))  # fmt: skip
    for tol in (1e-2, 1e-3, 1e-4):
        settings = RegistrationSettings(
            sigma=SIGMA, control_points="grid", stopping="shape", shape_tol=tol, max_iter=5000
        )
        loose = register(template, target, 0.05, settings)
        assert loose.converged and "shape_tol" in loose.message
        gap = np.sqrt(((loose.deformed - tight.deformed) ** 2).sum(1).mean())
        assert gap <= 10 * tol  # the rule's two tests bound the remaining change
        assert loose.n_iter < tight.n_iter


def test_joint_preconditioner_change_of_variables_is_exact():
    _, template, target, momenta = exact_pair(8)
    kernel = RegistrationSettings(sigma=SIGMA).make_kernel()
    cp = resolve_control_points(template, "grid", SIGMA)
    jp = JointPreconditioner(kernel, template, cp, momenta, 0.3, 1e-2)
    x = jp.to_variables(momenta, cp)
    mu, c = jp.to_natural(x)
    np.testing.assert_allclose(mu, momenta, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(c, cp, rtol=1e-10, atol=1e-12)
    rng = np.random.default_rng(9)
    g_mu, g_c, v = (
        rng.standard_normal(cp.shape),
        rng.standard_normal(cp.shape),
        rng.standard_normal(x.size),
    )
    # chain rule: <grad_x, v> = <grad_w, dw(v)>
    d_mu, d_c = jp.to_natural(v)
    lhs = jp.gradient_to_variables(g_mu, g_c) @ v
    assert lhs == pytest.approx((g_mu * d_mu).sum() + (g_c * d_c).sum(), rel=1e-10)


def test_joint_registration_refreshes_and_lowers_the_objective_below_fixed_points():
    _, template, target, _ = exact_pair(10, k=30, scale=0.5)
    target = target + 0.03 * np.random.default_rng(11).standard_normal(target.shape)
    base = RegistrationSettings(sigma=SIGMA, control_points="grid", max_iter=200, ftol=1e-12)
    fixed = register(template, target, 0.1, base, warn=False)
    joint = register(template, target, 0.1, base.replace(optimize_control_points=True,
                     refresh_every=10), warn=False)  # fmt: skip
    assert joint.objective < fixed.objective
    assert not np.allclose(joint.control_points, fixed.control_points)


def test_stopping_rule_rejects_unknown_kinds_and_describes_itself():
    with pytest.raises(ValueError, match="kind"):
        StoppingRule("never")
    assert "shape" in StoppingRule("shape", shape_tol=1e-3).describe()
    assert "objective" in StoppingRule("objective").describe()


def _spd(n, cond, rng):
    q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    return (q * np.geomspace(1.0, cond, n)) @ q.T


def test_krylov_bound_is_exact_after_as_many_products_as_distinct_eigenvalues():
    rng = np.random.default_rng(0)
    eigenvalues = np.repeat([1.0, 3.0, 10.0, 40.0], 5)  # 4 distinct values, n = 20
    H, J = np.diag(eigenvalues), np.eye(20)
    x0, x_star = rng.standard_normal(20), rng.standard_normal(20)
    bound = krylov_lower_bound(H, J, x0, x_star)
    assert len(bound.errors) == 4  # the Krylov spaces stop growing at dimension 4
    assert bound.errors[2] > 1e-3 * bound.start_error
    assert bound.errors[3] < 1e-10 * bound.start_error
    assert bound.first_below(1e-8 * bound.start_error) == 4


def test_krylov_bound_equals_cg_in_the_energy_norm_and_never_exceeds_it_otherwise():
    rng = np.random.default_rng(1)
    n = 30
    H = _spd(n, 1e3, rng)
    x0, x_star = rng.standard_normal(n), rng.standard_normal(n)
    energy = np.linalg.cholesky(H).T  # J^T J = H: CG is optimal in |J e|
    b = krylov_lower_bound(H, energy, x0, x_star, max_cg=12)
    np.testing.assert_allclose(b.cg_errors[:12], b.errors[:12], rtol=1e-6)
    J = rng.standard_normal((45, n))  # another output map: CG is no better than the bound
    b = krylov_lower_bound(H, J, x0, x_star, n_points=15, max_cg=25)
    assert np.all(b.errors[:25] <= b.cg_errors * (1 + 1e-9))
    assert np.all(np.diff(b.errors) <= 1e-12)  # nested spaces: the bound never rises
    assert b.cg_first_below(b.cg_errors[-1]) == 25
    with pytest.raises(ValueError, match="H must be"):
        krylov_lower_bound(H, J[:, :-1], x0, x_star)
