"""Deprecated names of the SVF registration: use :func:`manifolds.lddmm.register` with a flow.

The SVF registration of a template ``T`` onto a target ``S`` minimises, over the
momenta ``m`` of a stationary kernel field at fixed control points ``c`` (the SVF
counterpart of the paper's eq. 3)::

    C(m) = || S - exp(v)(T) ||_2^2 + alpha^2 || v ||_V^2,
    v(x) = sum_j K(x, c_j) m_j,   || v ||_V^2 = sum_ij K(c_i, c_j) m_i . m_j,

with the same driver, solver and preconditioner as LDDMM's: it is
``register(T, S, alpha, settings, flow=StationaryKernelFlow)`` and its objective
``registration_objective(..., flow=StationaryKernelFlow)``. The two functions below
forward there and warn; they will be removed in the next release.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..numerics.integrators import Integrator
from .kernels import GaussianKernel
from .registration import register, registration_objective
from .registration_result import RegistrationResult
from .settings import RegistrationSettings
from .stationary_flow import StationaryKernelFlow

__all__ = ["svf_objective", "register_svf"]


def _deprecated(old: str, new: str) -> None:
    warnings.warn(
        f"{old} is deprecated and will be removed in the next release: use {new}",
        DeprecationWarning,
        stacklevel=3,
    )


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
    """Deprecated: ``registration_objective(..., flow=StationaryKernelFlow)``."""
    _deprecated("svf_objective", "registration_objective(..., flow=StationaryKernelFlow)")
    return registration_objective(
        kernel, template, target, control_points, momenta, alpha, integrator, n_steps,
        with_gradient, control_points_gradient, flow=StationaryKernelFlow,
    )  # fmt: skip


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
    """Deprecated: ``register(..., flow=StationaryKernelFlow)``."""
    _deprecated("register_svf", "register(..., flow=StationaryKernelFlow)")
    return register(
        template, target, alpha, settings, flow=StationaryKernelFlow,
        control_points=control_points, initial_momenta=initial_momenta, kernel=kernel,
        warn=warn,
    )  # fmt: skip
