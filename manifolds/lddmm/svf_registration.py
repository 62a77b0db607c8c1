"""SVF registration of landmark shapes: the logarithm of the SVF landmark space.

The registration of a template ``T`` onto a target ``S`` minimises, over the
momenta ``m`` of a stationary kernel field at fixed control points ``c``
(the SVF counterpart of the paper's eq. 3)::

    C(m) = || S - exp(v)(T) ||_2^2 + alpha^2 || v ||_V^2,
    v(x) = sum_j K(x, c_j) m_j,   || v ||_V^2 = sum_ij K(c_i, c_j) m_i . m_j,

where ``exp(v)`` is the discrete flow of :mod:`manifolds.lddmm.stationary_flow`.
The gradient is exact for the discretised objective (adjoint of the
Runge-Kutta steps, :func:`~manifolds.lddmm.stationary_flow.kernel_flow_vjp`,
plus ``2 alpha^2 K m``). The optimiser is the same L-BFGS-B on the same
preconditioned variables as the LDDMM registration: both objectives have the
same linearisation ``exp(v)(T) ~ T + K_xc m``.
"""

from __future__ import annotations

import numpy as np

from ..numerics.integrators import Integrator
from .flow_models import StationaryKernelFlow
from .kernels import GaussianKernel
from .registration import model_objective, run_registration
from .registration_result import RegistrationResult
from .settings import RegistrationSettings

__all__ = ["svf_objective", "register_svf"]


def svf_objective(
    kernel: GaussianKernel,
    template: np.ndarray,
    target,
    control_points: np.ndarray,
    momenta: np.ndarray,
    alpha: float,
    integrator: str | Integrator = "rk4",
    n_steps: int = 10,
    with_gradient: bool = True,
    control_points_gradient: bool = False,
):
    """Objective ``C(m)`` of the SVF registration and its exact gradient.

    Parameters
    ----------
    kernel : GaussianKernel
    template : array, shape ``(k, d)``
    target : array ``(k, d)`` or DataTerm
        The target in correspondence, or a data term of the deformed points.
    control_points, momenta : arrays, shape ``(n_cp, d)``
    alpha : float
    integrator, n_steps
        Discretisation of the flow ``exp(v)``.
    with_gradient : bool
    control_points_gradient : bool
        Must be False: the SVF keeps its control points.

    Returns
    -------
    value : float
    gradient : array, shape ``(n_cp, d)``, or None if not ``with_gradient``
    deformed : array, shape ``(k, d)``, ``exp(v)(T)``
    norm_sq : float, ``||v||_V^2``
    """
    if control_points_gradient:
        raise ValueError("the SVF registration does not optimise its control points")
    model = StationaryKernelFlow(kernel, integrator, n_steps)
    return model_objective(model, template, target, control_points, momenta, alpha, with_gradient)


def register_svf(
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
    """Register ``template`` onto ``target`` with a stationary field.

    Parameters and result as :func:`manifolds.lddmm.register` (the integrator
    defaults to RK4); ``momenta`` are the SVF's momenta (fixed in time) and
    ``rkhs_norm`` is ``||v||_V``. ``settings.optimize_control_points`` must be
    False. Emits a :class:`~manifolds.ConvergenceWarning` when ``warn`` and the
    stopping rule was not met.
    """
    if settings.optimize_control_points:
        raise ValueError(
            "register_svf: settings.optimize_control_points: the SVF registration keeps its "
            "control points fixed"
        )
    return run_registration(
        StationaryKernelFlow,
        template,
        target,
        alpha,
        settings,
        control_points=control_points,
        initial_momenta=initial_momenta,
        kernel=kernel,
        warn=warn,
    )
