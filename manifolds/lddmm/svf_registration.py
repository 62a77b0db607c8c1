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
from ..numerics.optimizers import LBFGSOptions
from .kernels import GaussianKernel
from .registration import RegistrationResult, run_registration
from .stationary_flow import kernel_flow, kernel_flow_vjp

__all__ = ["svf_objective", "register_svf"]


def svf_objective(
    kernel: GaussianKernel,
    template: np.ndarray,
    target: np.ndarray,
    control_points: np.ndarray,
    momenta: np.ndarray,
    alpha: float,
    integrator: str | Integrator = "rk4",
    n_steps: int = 10,
    with_gradient: bool = True,
):
    """Objective ``C(m)`` of the SVF registration and its exact gradient.

    Parameters
    ----------
    kernel : GaussianKernel
    template, target : arrays, shape ``(k, d)``
    control_points, momenta : arrays, shape ``(n_cp, d)``
    alpha : float
    integrator, n_steps
        Discretisation of the flow ``exp(v)``.
    with_gradient : bool

    Returns
    -------
    value : float
    gradient : array, shape ``(n_cp, d)``, or None if not ``with_gradient``
    deformed : array, shape ``(k, d)``, ``exp(v)(T)``
    norm_sq : float, ``||v||_V^2``
    """
    res = kernel_flow(
        kernel, control_points, momenta, template, integrator, n_steps, keep_stages=with_gradient
    )
    deformed = res.points
    resid = target - deformed
    kv = kernel.convolve(control_points, control_points, momenta)
    norm_sq = float((momenta * kv).sum())
    value = float((resid * resid).sum()) + alpha**2 * norm_sq
    if not with_gradient:
        return value, None, deformed, norm_sq
    _, g_m, _ = kernel_flow_vjp(kernel, control_points, momenta, res, -2.0 * resid)
    g_m += 2.0 * alpha**2 * kv
    return value, g_m, deformed, norm_sq


def register_svf(
    template,
    target,
    kernel: GaussianKernel,
    alpha: float,
    control_points: np.ndarray | None = None,
    integrator: str | Integrator = "rk4",
    n_steps: int = 10,
    initial_momenta=None,
    options: LBFGSOptions | None = None,
    precondition: bool = True,
    rel_ridge: float = 1e-2,
    warn: bool = True,
) -> RegistrationResult:
    """Register ``template`` onto ``target`` with a stationary field (L-BFGS-B).

    Parameters and result as :func:`manifolds.lddmm.register`; ``momenta`` are
    the SVF's momenta (fixed in time) and ``rkhs_norm`` is ``||v||_V``. Emits a
    :class:`~manifolds.ConvergenceWarning` when ``warn`` and the optimiser did
    not converge.
    """
    return run_registration(
        _svf_objective_for_driver,
        "SVF",
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
    )


def _svf_objective_for_driver(
    kernel, template, target, control_points, momenta, alpha, integrator, n_steps, **flags
):
    """:func:`svf_objective` with the driver's signature (the SVF keeps its control points)."""
    if flags.get("control_points_gradient"):
        raise ValueError("the SVF registration does not optimise its control points")
    return svf_objective(
        kernel, template, target, control_points, momenta, alpha, integrator, n_steps
    )
