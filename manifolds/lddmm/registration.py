"""LDDMM registration of landmark shapes: the logarithm of the landmark space.

The registration of a template ``T`` onto a target ``S`` minimises, over the
initial momenta ``mu`` at fixed control points ``c`` (paper, eq. 3)::

    C(mu) = || S - phi_1(T) ||_2^2 + alpha^2 || v_0 ||_H^2,
    || v_0 ||_H^2 = sum_ij K(c_i, c_j) mu_i . mu_j,

where ``phi_1`` is the discrete flow of :mod:`manifolds.lddmm.shooting`.
The gradient is exact for the discretised objective: the data term is
back-propagated through the Runge-Kutta steps by a hand-written adjoint and
the regulariser contributes ``2 alpha^2 K mu``.

The optimiser (L-BFGS-B) works on preconditioned variables ``z = R^T mu``
(:mod:`manifolds.lddmm.preconditioner`) and starts from the minimiser of the
linearised problem. See ``docs/lddmm.md``.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from ..errors import ConvergenceWarning
from ..numerics.integrators import Integrator
from ..numerics.optimizers import LBFGSOptions, minimize_lbfgsb
from .kernels import GaussianKernel
from .preconditioner import make_preconditioner
from .shooting import shoot, shooting_vjp

__all__ = [
    "RegistrationResult",
    "registration_objective",
    "register",
]


@dataclass
class RegistrationResult:
    """Outcome of a registration of ``template`` onto ``target``.

    Attributes
    ----------
    momenta : array, shape ``(n_cp, d)``
        Initial momenta ``mu`` (the logarithm ``Log_T(S)``).
    control_points : array, shape ``(n_cp, d)``
    deformed : array, shape ``(k, d)``
        ``phi_1(T)``.
    residual : array, shape ``(k, d)``
        ``delta = S - phi_1(T)`` (paper, eq. 4).
    objective : float
        Final value of ``C(mu)`` (eq. 3).
    registration_error : float
        ``||delta||_2`` (L2 norm over all vertices).
    rms_error : float
        ``||delta||_2 / sqrt(k)``, root mean square vertex distance.
    rkhs_norm : float
        ``||v_0||_H``.
    n_iter, n_evals : int
        Optimiser iterations and objective evaluations.
    history : list of float
        Objective at the initial momenta and after every iteration.
    converged : bool
    message : str
    gradient_norm : float
        Largest entry of the final gradient in the optimiser's (preconditioned,
        normalised) variables, the quantity L-BFGS-B compares with ``gtol``.
    """

    momenta: np.ndarray
    control_points: np.ndarray
    deformed: np.ndarray
    residual: np.ndarray
    objective: float
    registration_error: float
    rms_error: float
    rkhs_norm: float
    n_iter: int
    n_evals: int
    history: list = field(default_factory=list)
    converged: bool = False
    message: str = ""
    gradient_norm: float = float("nan")


def is_dense(template: np.ndarray, control_points: np.ndarray) -> bool:
    return control_points is template or (
        control_points.shape == template.shape and np.array_equal(control_points, template)
    )


def registration_objective(
    kernel: GaussianKernel,
    template: np.ndarray,
    target: np.ndarray,
    control_points: np.ndarray,
    momenta: np.ndarray,
    alpha: float,
    integrator: str | Integrator = "euler",
    n_steps: int = 10,
    with_gradient: bool = True,
    control_points_gradient: bool = False,
):
    """Objective ``C(c, mu)`` of eq. (3) and its exact gradient.

    When the control points are the template's vertices (and
    ``control_points_gradient`` is False) the template is carried as the
    control points themselves (no separate point flow).

    With ``control_points_gradient`` the gradient with respect to the initial
    control points is returned as well: the adjoint state of ``c`` at ``t = 0``
    (back-propagated data term) plus the regulariser's
    ``d(alpha^2 <mu, K(c, c) mu>)/dc_i = -2 alpha^2 dmu_i/dt(0)``.

    Returns
    -------
    value : float
    gradient : array, shape ``(n_cp, d)``, or the pair ``(g_c, g_mu)`` with
        ``control_points_gradient`` (None unless ``with_gradient``)
    deformed : array, shape ``(k, d)``, ``phi_1(T)``
    rkhs_sq : float, ``||v_0||_H^2``
    """
    dense = not control_points_gradient and is_dense(template, control_points)
    res = shoot(
        kernel,
        control_points,
        momenta,
        integrator,
        n_steps,
        points=None if dense else template,
        keep_stages=with_gradient,
    )
    deformed = res.control_points if dense else res.points
    resid = target - deformed
    rkhs_sq = float((momenta * res.initial_velocity).sum())
    value = float((resid * resid).sum()) + alpha**2 * rkhs_sq
    if not with_gradient:
        return value, None, deformed, rkhs_sq
    cot = -2.0 * resid
    if dense:
        g_c, g_mu, _ = shooting_vjp(kernel, res, cot_control_points=cot)
    else:
        g_c, g_mu, _ = shooting_vjp(kernel, res, cot_points=cot)
    g_mu += 2.0 * alpha**2 * res.initial_velocity
    if not control_points_gradient:
        return value, g_mu, deformed, rkhs_sq
    # <mu, K mu> = 2 H(c, mu) and dmu/dt = -dH/dc: its gradient is -2 dmu/dt(0).
    _, dmu0 = kernel.hamiltonian_rhs(np.asarray(control_points, dtype=float), momenta)
    g_c -= 2.0 * alpha**2 * dmu0
    return value, (g_c, g_mu), deformed, rkhs_sq


def register(
    template,
    target,
    kernel: GaussianKernel,
    alpha: float,
    control_points: np.ndarray | None = None,
    integrator: str | Integrator = "euler",
    n_steps: int = 10,
    initial_momenta=None,
    options: LBFGSOptions | None = None,
    precondition: bool = True,
    rel_ridge: float = 1e-2,
    warn: bool = True,
    optimize_control_points: bool = False,
    control_point_scale: float | None = None,
) -> RegistrationResult:
    """Register ``template`` onto ``target`` by minimising eq. (3) with L-BFGS-B.

    The momenta (and, with ``optimize_control_points``, the control points) minimise
    ``C(c, mu)``; the gradient is exact (:func:`registration_objective`).

    Parameters
    ----------
    template, target : arrays, shape ``(k, d)``
    kernel : GaussianKernel
    alpha : float
        Regularisation weight (``alpha^2`` multiplies ``||v_0||_H^2``).
    control_points : array, shape ``(n_cp, d)``, optional
        Defaults to the template's vertices.
    integrator, n_steps
        Discretisation of the flow.
    initial_momenta : array, shape ``(n_cp, d)``, optional
        Warm start; defaults to the minimiser of the linearised problem when the
        preconditioner is used, zero otherwise.
    options : LBFGSOptions, optional
    precondition : bool, default True
        Optimise ``z = R^T mu`` (see :mod:`manifolds.lddmm.preconditioner`: dense
        Cholesky up to ``PRECONDITION_MAX_CP`` control points, a diagonal scaling above).
    rel_ridge : float
        Ridge of the preconditioner relative to the mean of its diagonal.
    warn : bool
        Emit a :class:`ConvergenceWarning` when the optimiser did not converge.
    optimize_control_points : bool, default False
        Minimise eq. (3) over the control points and the momenta jointly,
        starting from ``control_points``; the result holds the optimised ones.
    control_point_scale : float, optional
        The optimiser's variable for the control points is ``c / scale``
        (default ``kernel.sigma``), next to the preconditioned ``z`` of the momenta.
    """
    return run_registration(
        registration_objective,
        "LDDMM",
        template,
        target,
        kernel,
        alpha,
        control_points,
        integrator,
        n_steps,
        initial_momenta,
        options,
        precondition,
        rel_ridge,
        warn,
        optimize_control_points,
        control_point_scale,
    )


def run_registration(
    objective,
    label: str,
    template,
    target,
    kernel: GaussianKernel,
    alpha: float,
    control_points=None,
    integrator: str | Integrator = "euler",
    n_steps: int = 10,
    initial_momenta=None,
    options: LBFGSOptions | None = None,
    precondition: bool = True,
    rel_ridge: float = 1e-2,
    warn: bool = True,
    optimize_control_points: bool = False,
    control_point_scale: float | None = None,
) -> RegistrationResult:
    """The L-BFGS-B driver shared by the LDDMM and SVF registrations.

    ``objective(kernel, template, target, control_points, momenta, alpha,
    integrator, n_steps, control_points_gradient=...)`` returns ``(value,
    gradient, deformed, norm_sq)`` as :func:`registration_objective` does; ``label``
    names the model in the convergence warning. The other parameters are those of
    :func:`register`.
    """
    template = np.asarray(template, dtype=float)
    target = np.asarray(target, dtype=float)
    cp = template if control_points is None else np.asarray(control_points, dtype=float)
    dense = is_dense(template, cp)
    n_cp, dim = cp.shape
    alpha = float(alpha)
    pre = make_preconditioner(kernel, template, cp, alpha, dense, precondition, rel_ridge)
    if initial_momenta is not None:
        mu0 = np.asarray(initial_momenta, dtype=float).reshape(n_cp, dim)
    else:
        mu0 = pre.linearised_start(kernel, template, target, cp)
    c_scale = kernel.sigma if control_point_scale is None else float(control_point_scale)
    if not (np.isfinite(c_scale) and c_scale > 0):
        raise ValueError(f"control_point_scale: expected a positive number, got {c_scale!r}")
    problem = _Problem(objective, kernel, template, target, alpha, integrator, n_steps, pre)
    problem.optimise, problem.c_scale = optimize_control_points, c_scale
    x0 = problem.variables(mu0, cp)
    f_init = problem.evaluate(x0)[0]
    problem.scale = f_init if f_init > 0 else 1.0
    opt = minimize_lbfgsb(problem.fun_and_grad, x0, options)
    mu, c = problem.unpack(opt.x)
    result = make_result(target, c, mu, problem.evaluate(opt.x), opt, problem.scale)
    if warn and not result.converged:
        warnings.warn(
            ConvergenceWarning(
                f"{label} registration did not converge after {opt.n_iter} iterations "
                f"({opt.message}); objective {result.objective:.6g}, "
                f"RMS residual {result.rms_error:.3g}"
            ),
            stacklevel=3,
        )
    return result


class _Problem:
    """The objective as L-BFGS-B sees it, on ``x = (z[, c / c_scale])``, normalised by ``scale``.

    ``z = R^T mu`` are the preconditioned momenta; the control points are part of
    ``x`` only when they are optimised. The latest evaluation is kept, so the start
    (which sets ``scale``) and the final iterate are not shot twice.
    """

    def __init__(self, objective, kernel, template, target, alpha, integrator, n_steps, pre):
        self.objective = objective
        self.kernel, self.template, self.target = kernel, template, target
        self.alpha, self.integrator, self.n_steps = alpha, integrator, n_steps
        self.pre, self.optimise, self.c_scale = pre, False, 1.0
        self.scale = 1.0
        self.control_points = None
        self._last: dict = {}

    def variables(self, mu, control_points) -> np.ndarray:
        """``x`` of the momenta ``mu`` at ``control_points`` (fixed ones are kept aside)."""
        self.control_points = control_points
        z = self.pre.to_variables(mu).ravel()
        return np.concatenate([z, (control_points / self.c_scale).ravel()]) if self.optimise else z

    def unpack(self, x):
        """Momenta and control points at ``x``."""
        shape, n = self.control_points.shape, self.control_points.size
        mu = self.pre.to_momenta(x[:n].reshape(shape))
        if not self.optimise:
            return mu, self.control_points
        return mu, x[n:].reshape(shape) * self.c_scale

    def evaluate(self, x):
        """Objective, gradient, deformed template and squared RKHS norm at ``x``."""
        key = x.tobytes()
        if self._last.get("key") != key:
            mu, c = self.unpack(x)
            out = self.objective(
                self.kernel,
                self.template,
                self.target,
                c,
                mu,
                self.alpha,
                self.integrator,
                self.n_steps,
                control_points_gradient=self.optimise,
            )
            self._last.update(key=key, out=out)
        return self._last["out"]

    def fun_and_grad(self, x):
        """Normalised objective and its gradient with respect to ``x``."""
        value, grad, _, _ = self.evaluate(x)
        if not self.optimise:
            return value / self.scale, self.pre.gradient_to_variables(grad).ravel() / self.scale
        g_c, g_mu = grad
        g_z = self.pre.gradient_to_variables(g_mu).ravel()
        return value / self.scale, np.concatenate([g_z, (self.c_scale * g_c).ravel()]) / self.scale


def make_result(target, control_points, momenta, evaluation, opt, scale) -> RegistrationResult:
    """Assemble a :class:`RegistrationResult` from the final evaluation and the optimiser's run."""
    value, _, deformed, rkhs_sq = evaluation
    resid = target - deformed
    err = float(np.sqrt((resid * resid).sum()))
    return RegistrationResult(
        momenta=momenta,
        control_points=control_points.copy(),
        deformed=deformed,
        residual=resid,
        objective=value,
        registration_error=err,
        rms_error=err / np.sqrt(target.shape[0]),
        rkhs_norm=float(np.sqrt(max(rkhs_sq, 0.0))),
        n_iter=opt.n_iter,
        n_evals=opt.n_evals,
        history=[h * scale for h in opt.history],
        converged=opt.converged,
        message=opt.message,
        gradient_norm=float(np.max(np.abs(opt.grad))) if np.size(opt.grad) else 0.0,
    )
