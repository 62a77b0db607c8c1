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
from ..numerics.solvers import get_solver, limit_blas_threads
from .control_points import is_dense
from .flow_models import FlowModel
from .hamiltonian_shooting import HamiltonianFlow
from .kernels import GaussianKernel
from .preconditioner import IdentityPreconditioner, make_preconditioner
from .registration_problem import RegistrationProblem
from .registration_result import RegistrationResult
from .settings import RegistrationSettings

__all__ = [
    "RegistrationResult",
    "as_data_term",
    "registration_objective",
    "register",
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
    integrator: str | Integrator | None = None,
    n_steps: int = 10,
    with_gradient: bool = True,
    control_points_gradient: bool = False,
    *,
    flow: type[FlowModel] = HamiltonianFlow,
):
    """Objective ``C(c, mu)`` of eq. (3) for the deformation model ``flow``, with its exact gradient.

    With ``control_points_gradient`` the gradient with respect to the initial
    control points is returned as well (LDDMM only: its control points move with
    the flow): the adjoint state of ``c`` at ``t = 0`` (back-propagated data
    term) plus the regulariser's
    ``d(alpha^2 <mu, K(c, c) mu>)/dc_i = -2 alpha^2 dmu_i/dt(0)``. When the control
    points are the template's vertices (and ``control_points_gradient`` is False)
    the template is carried as the control points themselves.

    Parameters
    ----------
    kernel : GaussianKernel
    template : array, shape ``(k, d)``
    target : array ``(k, d)`` or DataTerm
        The target shape in correspondence, or any data term of the deformed points.
    control_points, momenta : arrays, shape ``(n_cp, d)``
    alpha : float
    integrator : str or Integrator, optional
        Default: the flow model's ``default_integrator`` (Euler for LDDMM, RK4 for SVF).
    n_steps : int
    with_gradient, control_points_gradient : bool
    flow : FlowModel subclass, default HamiltonianFlow
        :class:`HamiltonianFlow` (LDDMM geodesic shooting, eq. 2) or
        :class:`StationaryKernelFlow` (the flow of a stationary field: the SVF).

    Returns
    -------
    value : float
    gradient : array, shape ``(n_cp, d)``, or the pair ``(g_c, g_mu)`` with
        ``control_points_gradient`` (None unless ``with_gradient``)
    deformed : array, shape ``(k, d)``, ``phi_1(T)``
    norm_sq : float, ``||v||_H^2``
    """
    if control_points_gradient and not flow.moves_control_points:
        raise ValueError(
            f"control_points_gradient: the {flow.label} registration keeps its control points"
        )
    model = flow(kernel, flow.default_integrator if integrator is None else integrator, n_steps)
    template = np.asarray(template, dtype=float)
    cp = np.asarray(control_points, dtype=float)
    settings = RegistrationSettings(
        sigma=kernel.sigma, optimize_control_points=bool(control_points_gradient)
    )
    problem = RegistrationProblem(
        model, template, as_data_term(target), alpha, settings, IdentityPreconditioner(),
        dense=not control_points_gradient and is_dense(template, cp),
    )  # fmt: skip
    problem.control_points = cp
    x = problem.variables(np.asarray(momenta, dtype=float), cp)
    ev = problem.evaluate(x, with_gradient=with_gradient)
    if not with_gradient:
        grad = None
    elif control_points_gradient:
        grad = (ev.grad_c, ev.grad_mu)
    else:
        grad = ev.grad_mu
    return ev.value, grad, ev.flow_pass.deformed, ev.flow_pass.norm_sq


def register(
    template,
    target,
    alpha: float,
    settings: RegistrationSettings,
    *,
    flow: type[FlowModel] = HamiltonianFlow,
    control_points: np.ndarray | None = None,
    initial_momenta=None,
    kernel: GaussianKernel | None = None,
    warn: bool = True,
) -> RegistrationResult:
    """Register ``template`` onto ``target`` by minimising eq. (3): the one registration driver.

    Parameters
    ----------
    template : array, shape ``(k, d)``
    target : array ``(k, d)`` or DataTerm
        The target shape in correspondence with the template, or a data term
        (e.g. a varifold distance to a mesh with another triangulation).
    alpha : float
        Regularisation weight (``alpha^2`` multiplies ``||v||_H^2``).
    settings : RegistrationSettings
        Kernel, control points, integrator, solver and stopping rule. An integrator
        left to None is the flow model's ``default_integrator``.
    flow : FlowModel subclass, default HamiltonianFlow
        The deformation model: :class:`HamiltonianFlow` (LDDMM) or
        :class:`StationaryKernelFlow` (SVF: ``momenta`` are then the stationary
        field's and ``rkhs_norm`` is ``||v||_V``; control points cannot be optimised).
    control_points : array, shape ``(n_cp, d)``, optional
        Overrides the settings' policy (with ``optimize_control_points``, the start).
    initial_momenta : array, shape ``(n_cp, d)``, optional
        Warm start; defaults to the minimiser of the linearised problem when the
        preconditioner is used and the data term has a linear target, zero otherwise.
    kernel : GaussianKernel, optional
        A kernel of width ``settings.sigma`` to reuse (e.g. with its block size).
    warn : bool
        Emit a :class:`ConvergenceWarning` when the stopping rule was not met.

    The problem is built by :func:`build_registration_problem` and solved by the
    settings' solver (:mod:`manifolds.numerics.solvers`).
    """
    options = settings.solver_options()
    # The set-up (the preconditioner's Gram matrix and Cholesky factor) is small BLAS
    # work too: on the solver's BLAS threads, not the machine's.
    with limit_blas_threads(options.blas_threads):
        problem, mu0, cp = _unstarted_problem(
            flow, template, target, alpha, settings, control_points=control_points,
            initial_momenta=initial_momenta, kernel=kernel,
        )  # fmt: skip
        x0 = problem.start(mu0, cp)  # the problem of build_registration_problem
        opt = get_solver(settings.solver)(problem, x0, options, settings.stopping_rule())
        result = problem.result(opt)
    if warn and not result.converged:
        warnings.warn(
            ConvergenceWarning(
                f"{flow.label} registration did not converge after {opt.n_iter} "
                f"iterations ({opt.message}); objective {result.objective:.6g}, "
                f"registration error {result.registration_error:.3g}"
            ),
            stacklevel=2,
        )
    return result


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
    flow: type[FlowModel],
    template,
    target,
    alpha: float,
    settings: RegistrationSettings,
    *,
    control_points=None,
    initial_momenta=None,
    kernel: GaussianKernel | None = None,
) -> tuple[RegistrationProblem, np.ndarray]:
    """The problem of eq. (3) that :func:`register` hands to the solver, and its start.

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
    problem, mu0, cp = _unstarted_problem(
        flow, template, target, alpha, settings, control_points=control_points,
        initial_momenta=initial_momenta, kernel=kernel,
    )  # fmt: skip
    return problem, problem.start(mu0, cp)


def _unstarted_problem(
    flow, template, target, alpha, settings, *, control_points, initial_momenta, kernel
) -> tuple[RegistrationProblem, np.ndarray, np.ndarray]:
    """The problem of :func:`build_registration_problem`, its start momenta and control points."""
    label = flow.label
    if settings.optimize_control_points and not flow.moves_control_points:
        raise ValueError(
            f"{label} registration: settings.optimize_control_points: the {label} "
            "registration keeps its control points fixed"
        )
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
    model = flow(kernel, settings.integrator or flow.default_integrator,
                        settings.n_steps)  # fmt: skip
    problem = RegistrationProblem(model, template, data_term, alpha, settings, pre, dense)
    return problem, mu0, cp
