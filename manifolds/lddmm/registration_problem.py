"""A registration as the solvers see it: variables, objective, output shape and counters.

The optimiser's variables are the preconditioned momenta ``x = z = R^T mu``
(:mod:`manifolds.lddmm.preconditioner`) or, when the control points are optimised
with the momenta, ``x = L^T (mu, c)`` with the joint linearised Gauss-Newton factor
(:mod:`manifolds.lddmm.joint_preconditioner`), rebuilt by :meth:`refresh`; without
preconditioning ``x = (mu, c / c_scale)``. The
objective ``C = D(phi_1(T)) + alpha^2 ||v||_H^2`` (eq. 3) is normalised by its value
at the start, so that tolerances are relative. :class:`RegistrationProblem`
implements the :class:`~manifolds.numerics.solvers.SolverProblem` interface: value
and gradient (forward and adjoint passes of the flow model), the deformed template
at ``x`` (the ``"shape"`` stopping rule), the change a preconditioned Newton step
would make, Gauss-Newton Hessian products (tangent-linear then adjoint pass) and
the count of flow passes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .flow_models import FlowPass, rkhs_norm_sq_gradient, rkhs_norm_sq_hvp
from .joint_preconditioner import JointPreconditioner
from .registration_result import RegistrationResult

__all__ = ["RegistrationProblem", "Evaluation"]


@dataclass
class Evaluation:
    """Objective at one iterate: value, gradient (natural variables) and the flow pass."""

    value: float
    grad_c: np.ndarray | None
    grad_mu: np.ndarray | None
    flow_pass: FlowPass
    #: The gradient in the optimiser's variables (unnormalised), once asked.
    grad_x: np.ndarray | None = None


class RegistrationProblem:
    """The objective of eq. (3) on the optimiser's variables (see the module docstring).

    Parameters
    ----------
    model : FlowModel
        The deformation model (LDDMM shooting or stationary flow).
    template : array, shape ``(k, d)``
    data_term : DataTerm
    alpha : float
    settings : RegistrationSettings
    preconditioner : Preconditioner
    dense : bool
        The control points are the template's vertices (and are not optimised).

    Attributes
    ----------
    n_flow_evaluations : int
        Forward, adjoint and tangent-linear passes made so far.
    """

    def __init__(self, model, template, data_term, alpha, settings, preconditioner, dense=False):
        self.model = model
        self.kernel = model.kernel
        self.template, self.data_term = template, data_term
        self.alpha, self.settings = float(alpha), settings
        self.pre = preconditioner
        self.optimise = settings.optimize_control_points
        self.dense = bool(dense) and not self.optimise
        scale = settings.control_point_scale
        self.c_scale = self.kernel.sigma if scale is None else float(scale)
        self.scale = 1.0
        self.control_points = None
        self.joint = None
        self.n_flow_evaluations = 0
        self._last: tuple = (None, None)

    # ------------------------------------------------------------ variables
    @property
    def size(self) -> int:
        n = self.control_points.size
        return 2 * n if self.optimise else n

    def start(self, mu0, control_points) -> np.ndarray:
        """Variables of the start ``(mu0, control_points)``; sets the normalisation."""
        self.control_points = np.asarray(control_points, dtype=float)
        s = self.settings
        if self.optimise and s.precondition and s.joint_metric:
            self.joint = self._joint(mu0, self.control_points)
        x0 = self.variables(mu0, self.control_points)
        self.scale = 1.0
        self.value_and_gradient(x0)  # kept as the latest evaluation
        f0 = self._last[1].value
        self.scale = f0 if f0 > 0 else 1.0
        return x0

    def _joint(self, mu, control_points):
        s = self.settings
        return JointPreconditioner(
            self.kernel, self.template, control_points, mu, self.alpha, s.rel_ridge
        )

    @property
    def refreshable(self) -> bool:
        """Whether :meth:`refresh` changes the variables (the joint preconditioner is in use)."""
        return self.joint is not None

    def refresh(self, x) -> np.ndarray:
        """Rebuild the joint preconditioner at ``x``; the same iterate in the new variables.

        A no-op (``x`` itself) unless the control points are optimised with the
        preconditioner on. The latest evaluation is kept under the new variables.
        """
        if self.joint is None:
            return x
        mu, c = self.unpack(x)
        key, ev = self._last
        self.joint = self._joint(mu, c)
        new = self.variables(mu, c)
        if key == x.tobytes():
            ev.grad_x = None  # the variables changed
            self._last = (new.tobytes(), ev)
        return new

    def variables(self, mu, control_points) -> np.ndarray:
        """``x`` of the momenta ``mu`` at ``control_points``."""
        if self.joint is not None:
            return self.joint.to_variables(mu, control_points)
        z = self.pre.to_variables(np.asarray(mu, dtype=float)).ravel()
        if not self.optimise:
            return z
        return np.concatenate([z, (np.asarray(control_points) / self.c_scale).ravel()])

    def unpack(self, x):
        """Momenta and control points at ``x``."""
        if self.joint is not None:
            return self.joint.to_natural(x)
        shape, n = self.control_points.shape, self.control_points.size
        mu = self.pre.to_momenta(x[:n].reshape(shape))
        if not self.optimise:
            return mu, self.control_points
        return mu, x[n:].reshape(shape) * self.c_scale

    def to_natural(self, v):
        """A direction ``v`` in ``x`` as ``(d_c, d_mu)`` (``d_c`` zero for fixed control points)."""
        if self.joint is not None:
            d_mu, d_c = self.joint.to_natural(v)
            return d_c, d_mu
        shape, n = self.control_points.shape, self.control_points.size
        d_mu = self.pre.to_momenta(v[:n].reshape(shape))
        d_c = v[n:].reshape(shape) * self.c_scale if self.optimise else np.zeros(shape)
        return d_c, d_mu

    def to_variables_gradient(self, g_c, g_mu):
        """A gradient in ``(c, mu)`` as a gradient in ``x`` (the chain rule of :meth:`unpack`)."""
        if self.joint is not None:
            return self.joint.gradient_to_variables(g_mu, g_c)
        g_z = self.pre.gradient_to_variables(g_mu).ravel()
        if not self.optimise:
            return g_z
        return np.concatenate([g_z, (self.c_scale * g_c).ravel()])

    # ------------------------------------------------------------ evaluations
    def value_and_gradient(self, x):
        """Normalised objective and its gradient with respect to ``x``.

        The forward pass keeps its stages, so that the adjoint pass here, or
        Gauss-Newton products asked later at the same ``x``, need no new shooting;
        the latest evaluation is kept (:meth:`evaluate`).
        """
        key = x.tobytes()
        last_key, ev = self._last
        cot = None
        if last_key != key:  # the data term's value and gradient in one evaluation
            mu, c = self.unpack(x)
            flow = self.model.forward(self.template, c, mu, keep_stages=True, dense=self.dense)
            data_value, cot = self.data_term.value_and_gradient(flow.deformed)
            ev = self._record(key, flow, data_value)
        if ev.grad_mu is None:
            flow = ev.flow_pass
            if cot is None:  # the value alone was asked at this x before
                _, cot = self.data_term.value_and_gradient(flow.deformed)
            g_c, g_mu = self.model.adjoint(flow, cot)
            self.n_flow_evaluations += 1
            alpha2 = self.alpha**2
            ev.grad_mu = g_mu + 2.0 * alpha2 * flow.velocity
            if self.optimise:
                grad_reg = rkhs_norm_sq_gradient(self.kernel, flow.control_points, flow.momenta)
                g_c = g_c + alpha2 * grad_reg[0]
            ev.grad_c = g_c
        if ev.grad_x is None:  # solvers ask again at the accepted iterate: computed once
            ev.grad_x = self.to_variables_gradient(ev.grad_c, ev.grad_mu)
        return ev.value / self.scale, ev.grad_x / self.scale

    def _record(self, key: bytes, flow: FlowPass, data_value: float | None = None) -> Evaluation:
        """Keep the forward pass ``flow`` at the variables of bytes ``key`` as the latest.

        ``data_value`` is the data term's value at ``flow.deformed`` when already known.
        """
        self.n_flow_evaluations += 1
        if data_value is None:
            data_value = self.data_term.value(flow.deformed)
        ev = Evaluation(data_value + self.alpha**2 * flow.norm_sq, None, None, flow)
        self._last = (key, ev)
        return ev

    def evaluate(self, x, with_gradient: bool = True) -> Evaluation:
        """Objective, gradient (natural variables) and flow pass at ``x``; the latest is kept."""
        key = x.tobytes()
        last_key, ev = self._last
        if last_key == key and (ev.grad_mu is not None or not with_gradient):
            return ev
        if with_gradient:
            self.value_and_gradient(x)
            return self._last[1]
        mu, c = self.unpack(x)
        return self._record(
            key, self.model.forward(self.template, c, mu, keep_stages=True, dense=self.dense)
        )

    def value(self, x) -> float:
        """Normalised objective at ``x`` (no adjoint pass)."""
        return self.evaluate(x, with_gradient=False).value / self.scale

    def shape(self, x) -> np.ndarray:
        """``phi_1(T)`` at ``x``, shape ``(k, d)``."""
        return self.evaluate(x, with_gradient=False).flow_pass.deformed

    def gauss_newton_product(self, x, v) -> np.ndarray:
        """Gauss-Newton Hessian of the normalised objective at ``x`` applied to ``v``.

        ``J^T H_D J v + alpha^2 H_reg v`` with ``J`` the tangent-linear model of the
        flow (one tangent and one adjoint pass), ``H_D`` the data term's Gauss-Newton
        Hessian and ``H_reg`` the exact Hessian of ``||v||_H^2`` (positive
        semi-definite in ``mu``; with optimised control points its ``c`` block may be
        indefinite).
        """
        ev = self.evaluate(x)
        d_c, d_mu = self.to_natural(np.asarray(v, dtype=float))
        flow = ev.flow_pass
        d_x = self.model.tangent(flow, d_c, d_mu)
        h_x = self.data_term.gauss_newton_product(flow.deformed, d_x)
        h_c, h_mu = self.model.adjoint(flow, h_x)
        self.n_flow_evaluations += 2
        alpha2 = self.alpha**2
        r_c, r_mu = rkhs_norm_sq_hvp(self.kernel, flow.control_points, flow.momenta, d_c, d_mu)
        h_mu = h_mu + alpha2 * r_mu
        h_c = h_c + alpha2 * r_c if self.optimise else h_c
        return self.to_variables_gradient(h_c, h_mu) / self.scale

    def predicted_change(self, x, gradient) -> float:
        """Per-vertex RMS change of ``phi_1(T)`` a Newton step from ``x`` would make.

        With ``R R^T`` the linearised Gauss-Newton Hessian (half the objective's
        Hessian), the Newton step in ``z`` is ``-g_z / 2`` (unnormalised) and moves
        the template by at most its norm: ``||g_z|| / (2 sqrt(k))``. With the joint
        preconditioner the whole gradient enters; with optimised control points and
        no preconditioner only the momenta's part does (the control points' part
        has no such metric).
        """
        n = self.size if self.joint is not None else self.control_points.size
        g_z = np.asarray(gradient, dtype=float)[:n] * self.scale
        return float(np.linalg.norm(g_z) / (2.0 * np.sqrt(self.template.shape[0])))

    # ------------------------------------------------------------ result
    def result(self, opt):
        """The :class:`~manifolds.lddmm.RegistrationResult` of the solver's run ``opt``."""
        mu, c = self.unpack(opt.x)
        ev = self.evaluate(opt.x, with_gradient=False)
        deformed = ev.flow_pass.deformed
        term = self.data_term
        err = term.distance(deformed)
        k = self.template.shape[0]
        return RegistrationResult(
            momenta=mu,
            control_points=np.array(c, dtype=float),
            deformed=deformed,
            residual=term.residual(deformed) if term.corresponds else None,
            objective=ev.value,
            registration_error=err,
            rms_error=err / np.sqrt(k) if term.corresponds else None,
            rkhs_norm=float(np.sqrt(max(ev.flow_pass.norm_sq, 0.0))),
            n_iter=opt.n_iter,
            n_evals=opt.n_evals,
            n_flow_evaluations=self.n_flow_evaluations,
            history=[h * self.scale for h in opt.history],
            converged=opt.converged,
            message=opt.message,
            gradient_norm=float(np.max(np.abs(opt.grad))) if np.size(opt.grad) else 0.0,
            predicted_change=self.predicted_change(opt.x, opt.grad),
            settings_key=self.settings.key(),
            trace=list(opt.trace),
        )
