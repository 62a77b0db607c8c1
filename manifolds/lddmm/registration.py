"""LDDMM registration of landmark shapes: the logarithm of the landmark space.

The registration of a template ``T`` onto a target minimises, over the initial
momenta ``mu`` (and, optionally, the control points ``c``) (paper, eq. 3)::

    C(c, mu) = D(phi_1(T)) + alpha^2 || v_0 ||_H^2,
    || v_0 ||_H^2 = sum_ij K(c_i, c_j) mu_i . mu_j,

where ``phi_1`` is the discrete flow of :mod:`manifolds.lddmm.hamiltonian_shooting` and ``D`` a
data term (:mod:`manifolds.data_terms`): for shapes in correspondence, the squared
distance ``|| S - phi_1(T) ||_2^2`` of the paper. The gradient is exact for the
discretised objective: the data term's gradient is back-propagated through the
Runge-Kutta steps by a hand-written adjoint and the regulariser contributes
``2 alpha^2 K mu``.

Every setting (kernel, control points, integrator, solver, stopping rule) comes
from one :class:`~manifolds.lddmm.RegistrationSettings`; the optimiser works on
preconditioned variables (:mod:`manifolds.lddmm.preconditioner`) and starts from
the minimiser of the linearised problem. See ``docs/lddmm.md``.
"""

from __future__ import annotations

import warnings

import numpy as np

from manifolds.data_terms import DataTerm, SquaredDistance

from ..errors import ConvergenceWarning
from ..numerics.integrators import Integrator
from ..numerics.solvers import StoppingRule, get_solver
from .control_points import is_dense
from .flow_models import FlowModel, HamiltonianFlow
from .kernels import GaussianKernel
from .preconditioner import IdentityPreconditioner, make_preconditioner
from .registration_problem import RegistrationProblem
from .registration_result import RegistrationResult
from .settings import RegistrationSettings

__all__ = [
    "RegistrationResult",
    "as_data_term",
    "registration_objective",
    "model_objective",
    "register",
    "run_registration",
    "build_registration_problem",
]


def as_data_term(target) -> DataTerm:
    """``target`` as a data term: a :class:`DataTerm` as given, points as :class:`SquaredDistance`."""
    if isinstance(target, DataTerm):
        return target
    return SquaredDistance(target)


def registration_objective(
    kernel: GaussianKernel,
    template: np.ndarray,
    target,
    control_points: np.ndarray,
    momenta: np.ndarray,
    alpha: float,
    integrator: str | Integrator = "euler",
    n_steps: int = 10,
    with_gradient: bool = True,
    control_points_gradient: bool = False,
):
    """Objective ``C(c, mu)`` of eq. (3) and its exact gradient (LDDMM shooting).

    When the control points are the template's vertices (and
    ``control_points_gradient`` is False) the template is carried as the
    control points themselves (no separate point flow).

    With ``control_points_gradient`` the gradient with respect to the initial
    control points is returned as well: the adjoint state of ``c`` at ``t = 0``
    (back-propagated data term) plus the regulariser's
    ``d(alpha^2 <mu, K(c, c) mu>)/dc_i = -2 alpha^2 dmu_i/dt(0)``.

    Parameters
    ----------
    target : array ``(k, d)`` or DataTerm
        The target shape in correspondence, or any data term of the deformed points.

    Returns
    -------
    value : float
    gradient : array, shape ``(n_cp, d)``, or the pair ``(g_c, g_mu)`` with
        ``control_points_gradient`` (None unless ``with_gradient``)
    deformed : array, shape ``(k, d)``, ``phi_1(T)``
    rkhs_sq : float, ``||v_0||_H^2``
    """
    return model_objective(
        HamiltonianFlow(kernel, integrator, n_steps),
        template, target, control_points, momenta, alpha, with_gradient,
        control_points_gradient,
    )  # fmt: skip


def model_objective(
    model: FlowModel,
    template,
    target,
    control_points,
    momenta,
    alpha: float,
    with_gradient: bool = True,
    control_points_gradient: bool = False,
):
    """Objective of eq. (3) for the deformation ``model`` and its exact gradient.

    Returns ``(value, gradient, deformed, norm_sq)`` as :func:`registration_objective`.
    """
    template = np.asarray(template, dtype=float)
    cp = np.asarray(control_points, dtype=float)
    settings = RegistrationSettings(
        sigma=model.kernel.sigma, optimize_control_points=bool(control_points_gradient)
    )
    problem = RegistrationProblem(
        model, template, as_data_term(target), alpha, settings, IdentityPreconditioner(),
        dense=not control_points_gradient and is_dense(template, cp),
    )  # fmt: skip
    problem.control_points = cp
    x = problem.variables(np.asarray(momenta, dtype=float), cp)
    ev = problem.evaluate(x, with_gradient=with_gradient)
    flow = ev.flow_pass
    if not with_gradient:
        grad = None
    elif control_points_gradient:
        grad = (ev.grad_c, ev.grad_mu)
    else:
        grad = ev.grad_mu
    return ev.value, grad, flow.deformed, flow.norm_sq


def register(
    template,
    target,
    alpha: float,
    settings: RegistrationSettings,
    *,
    control_points: np.ndarray | None = None,
    initial_momenta=None,
    kernel: GaussianKernel | None = None,
    warn: bool = True,
) -> RegistrationResult:
    """Register ``template`` onto ``target`` by minimising eq. (3).

    Parameters
    ----------
    template : array, shape ``(k, d)``
    target : array ``(k, d)`` or DataTerm
        The target shape in correspondence with the template, or a data term
        (e.g. a varifold distance to a mesh with another triangulation).
    alpha : float
        Regularisation weight (``alpha^2`` multiplies ``||v_0||_H^2``).
    settings : RegistrationSettings
        Kernel, control points, integrator, solver and stopping rule. Its
        integrator defaults to Euler here.
    control_points : array, shape ``(n_cp, d)``, optional
        Overrides the settings' policy (with ``optimize_control_points``, the start).
    initial_momenta : array, shape ``(n_cp, d)``, optional
        Warm start; defaults to the minimiser of the linearised problem when the
        preconditioner is used and the data term has a linear target, zero otherwise.
    kernel : GaussianKernel, optional
        A kernel of width ``settings.sigma`` to reuse (e.g. with its block size).
    warn : bool
        Emit a :class:`ConvergenceWarning` when the stopping rule was not met.
    """
    return run_registration(
        HamiltonianFlow,
        template,
        target,
        alpha,
        settings,
        control_points=control_points,
        initial_momenta=initial_momenta,
        kernel=kernel,
        warn=warn,
    )


def _check_settings(settings, kernel, label):
    if not isinstance(settings, RegistrationSettings):
        raise TypeError(
            f"{label} registration: settings: expected RegistrationSettings, got "
            f"{type(settings).__name__}"
        )
    if kernel is None:
        return settings.make_kernel()
    if not isinstance(kernel, GaussianKernel) or kernel.sigma != settings.sigma:
        raise ValueError(
            f"{label} registration: kernel: expected a GaussianKernel of width "
            f"settings.sigma = {settings.sigma:g}, got {kernel!r}"
        )
    return kernel


def build_registration_problem(
    model_class: type[FlowModel],
    template,
    target,
    alpha: float,
    settings: RegistrationSettings,
    *,
    control_points=None,
    initial_momenta=None,
    kernel: GaussianKernel | None = None,
) -> tuple[RegistrationProblem, np.ndarray]:
    """The problem of eq. (3) that :func:`run_registration` hands to the solver, and its start.

    For a solver or an analysis of one's own: ``problem.value_and_gradient(x)``,
    ``problem.gauss_newton_product(x, v)``, ``problem.shape(x)`` and
    ``problem.n_flow_evaluations`` are what the library's solvers use.

    Returns
    -------
    problem : RegistrationProblem
    x0 : array, shape ``(problem.size,)``
        The start in the solver's variables (the linearised start unless
        ``initial_momenta`` is given).
    """
    label = model_class.label
    kernel = _check_settings(settings, kernel, label)
    template = np.asarray(template, dtype=float)
    data_term = as_data_term(target)
    if control_points is None:
        control_points = settings.resolve_control_points(template)
    cp = np.asarray(control_points, dtype=float)
    dense = is_dense(template, cp)
    alpha = float(alpha)
    pre = make_preconditioner(
        kernel, template, cp, alpha, dense, settings.precondition, settings.rel_ridge
    )
    if initial_momenta is not None:
        mu0 = np.asarray(initial_momenta, dtype=float).reshape(cp.shape)
    else:
        mu0 = pre.linearised_start(kernel, template, data_term.linear_target(template), cp)
    model = model_class(kernel, settings.integrator or model_class.default_integrator,
                        settings.n_steps)  # fmt: skip
    problem = RegistrationProblem(model, template, data_term, alpha, settings, pre, dense)
    return problem, problem.start(mu0, cp)


def run_registration(
    model_class: type[FlowModel],
    template,
    target,
    alpha: float,
    settings: RegistrationSettings,
    *,
    control_points=None,
    initial_momenta=None,
    kernel: GaussianKernel | None = None,
    warn: bool = True,
) -> RegistrationResult:
    """The driver shared by the LDDMM and SVF registrations.

    ``model_class`` is the deformation model (:class:`HamiltonianFlow`,
    :class:`StationaryKernelFlow`); its ``default_integrator`` is used when the
    settings leave the integrator to None. The other parameters are those of
    :func:`register`. The problem is built by :func:`build_registration_problem`.
    """
    problem, x0 = build_registration_problem(
        model_class,
        template,
        target,
        alpha,
        settings,
        control_points=control_points,
        initial_momenta=initial_momenta,
        kernel=kernel,
    )
    opt = get_solver(settings.solver)(problem, x0, settings, StoppingRule.from_settings(settings))
    result = problem.result(opt)
    if warn and not result.converged:
        warnings.warn(
            ConvergenceWarning(
                f"{model_class.label} registration did not converge after {opt.n_iter} "
                f"iterations ({opt.message}); objective {result.objective:.6g}, "
                f"registration error {result.registration_error:.3g}"
            ),
            stacklevel=3,
        )
    return result
