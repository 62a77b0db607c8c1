"""A registration as the solvers see it: variables, objective, output shape and counters.

The optimiser's variables are ``x = (z[, c / c_scale])``: the preconditioned
momenta ``z = R^T mu`` (:mod:`manifolds.lddmm.preconditioner`) and, when they are
optimised, the control points scaled by ``c_scale`` (``sigma`` by default). The
objective is normalised by its value at the start, so that tolerances are
relative. :class:`RegistrationProblem` implements the
:class:`~manifolds.numerics.solvers.SolverProblem` interface: value and
gradient, the deformed template at ``x`` (the ``"shape"`` stopping rule), the
change a preconditioned Newton step would make, and the count of flow passes.
"""

from __future__ import annotations

import numpy as np

__all__ = ["RegistrationProblem", "is_dense"]


def is_dense(template: np.ndarray, control_points: np.ndarray) -> bool:
    """Whether the control points are the template's vertices themselves."""
    return control_points is template or (
        control_points.shape == template.shape and np.array_equal(control_points, template)
    )


class RegistrationProblem:
    """The objective of eq. (3) on the optimiser's variables (see the module docstring).

    Parameters
    ----------
    objective : callable
        :func:`manifolds.lddmm.registration_objective` or its SVF counterpart.
    kernel : GaussianKernel
    template : array, shape ``(k, d)``
    data_term : DataTerm
    alpha : float
    integrator : str or Integrator
    settings : RegistrationSettings
    preconditioner : Preconditioner

    Attributes
    ----------
    n_flow_evaluations : int
        Forward shootings plus adjoint passes made so far.
    """

    def __init__(self, objective, kernel, template, data_term, alpha, integrator, settings, pre):
        self.objective = objective
        self.kernel, self.template, self.data_term = kernel, template, data_term
        self.alpha, self.integrator, self.settings = alpha, integrator, settings
        self.n_steps = settings.n_steps
        self.pre = pre
        self.optimise = settings.optimize_control_points
        scale = settings.control_point_scale
        self.c_scale = kernel.sigma if scale is None else float(scale)
        self.scale = 1.0
        self.control_points = None
        self.n_flow_evaluations = 0
        self._last: dict = {}

    # ------------------------------------------------------------ variables
    @property
    def size(self) -> int:
        n = self.control_points.size
        return 2 * n if self.optimise else n

    def start(self, mu0, control_points) -> np.ndarray:
        """Variables of the start ``(mu0, control_points)``; sets the normalisation."""
        self.control_points = np.asarray(control_points, dtype=float)
        x0 = self.variables(mu0, self.control_points)
        f0 = self.evaluate(x0)[0]
        self.scale = f0 if f0 > 0 else 1.0
        return x0

    def variables(self, mu, control_points) -> np.ndarray:
        """``x`` of the momenta ``mu`` at ``control_points``."""
        z = self.pre.to_variables(np.asarray(mu, dtype=float)).ravel()
        if not self.optimise:
            return z
        return np.concatenate([z, (np.asarray(control_points) / self.c_scale).ravel()])

    def unpack(self, x):
        """Momenta and control points at ``x``."""
        shape, n = self.control_points.shape, self.control_points.size
        mu = self.pre.to_momenta(x[:n].reshape(shape))
        if not self.optimise:
            return mu, self.control_points
        return mu, x[n:].reshape(shape) * self.c_scale

    # ------------------------------------------------------------ evaluations
    def evaluate(self, x, with_gradient: bool = True):
        """Objective, gradient (natural variables), deformed template and squared
        norm at ``x``; the latest evaluation is kept."""
        key = x.tobytes()
        last = self._last
        if last.get("key") == key and (last["out"][1] is not None or not with_gradient):
            return last["out"]
        mu, c = self.unpack(x)
        out = self.objective(
            self.kernel,
            self.template,
            self.data_term,
            c,
            mu,
            self.alpha,
            self.integrator,
            self.n_steps,
            with_gradient=with_gradient,
            control_points_gradient=self.optimise,
        )
        self.n_flow_evaluations += 2 if with_gradient else 1
        self._last = {"key": key, "out": out}
        return out

    def value_and_gradient(self, x):
        """Normalised objective and its gradient with respect to ``x``."""
        value, grad, _, _ = self.evaluate(x)
        if not self.optimise:
            return value / self.scale, self.pre.gradient_to_variables(grad).ravel() / self.scale
        g_c, g_mu = grad
        g_z = self.pre.gradient_to_variables(g_mu).ravel()
        return value / self.scale, np.concatenate([g_z, (self.c_scale * g_c).ravel()]) / self.scale

    def value(self, x) -> float:
        """Normalised objective at ``x`` (no adjoint pass)."""
        return self.evaluate(x, with_gradient=False)[0] / self.scale

    def shape(self, x) -> np.ndarray:
        """``phi_1(T)`` at ``x``, shape ``(k, d)``."""
        return self.evaluate(x, with_gradient=False)[2]

    def predicted_change(self, x, gradient) -> float:
        """Per-vertex RMS change of ``phi_1(T)`` a Newton step from ``x`` would make.

        With ``R R^T`` the linearised Gauss-Newton Hessian (half the objective's
        Hessian), the Newton step in ``z`` is ``-g_z / 2`` (unnormalised) and moves
        the template by at most its norm: ``||g_z|| / (2 sqrt(k))``. Only the
        momenta's part of the gradient enters (the control points' part has no
        such metric).
        """
        n = self.control_points.size
        g_z = np.asarray(gradient, dtype=float)[:n] * self.scale
        return float(np.linalg.norm(g_z) / (2.0 * np.sqrt(self.template.shape[0])))

    # ------------------------------------------------------------ result
    def result(self, opt):
        """The :class:`~manifolds.lddmm.RegistrationResult` of the solver's run ``opt``."""
        from .registration import RegistrationResult

        mu, c = self.unpack(opt.x)
        value, _, deformed, rkhs_sq = self.evaluate(opt.x, with_gradient=False)
        term = self.data_term
        err = term.distance(deformed)
        k = self.template.shape[0]
        return RegistrationResult(
            momenta=mu,
            control_points=np.array(c, dtype=float),
            deformed=deformed,
            residual=term.residual(deformed) if term.corresponds else None,
            objective=value,
            registration_error=err,
            rms_error=err / np.sqrt(k) if term.corresponds else None,
            rkhs_norm=float(np.sqrt(max(rkhs_sq, 0.0))),
            n_iter=opt.n_iter,
            n_evals=opt.n_evals,
            n_flow_evaluations=self.n_flow_evaluations,
            history=[h * self.scale for h in opt.history],
            converged=opt.converged,
            message=opt.message,
            gradient_norm=float(np.max(np.abs(opt.grad))) if np.size(opt.grad) else 0.0,
            predicted_change=self.predicted_change(opt.x, opt.grad),
            settings_key=self.settings.key(),
        )
