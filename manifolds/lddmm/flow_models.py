"""The deformation models of the registrations: momenta (and control points) to deformed points.

A registration (paper, eq. 3) needs four things of its deformation model, and
nothing else: the deformed template for given control points and momenta (the
forward pass), the gradient of ``<cot, phi_1(T)>`` with respect to them (the
adjoint pass), the tangent of ``phi_1(T)`` along a perturbation of them (the
tangent-linear pass), and the regulariser ``||v||_H^2 = mu^T K(c, c) mu`` with its
derivatives. The models live with their flows:
:class:`~manifolds.lddmm.hamiltonian_shooting.HamiltonianFlow` is LDDMM's geodesic
shooting, :class:`~manifolds.lddmm.stationary_flow.StationaryKernelFlow` the flow of a
stationary kernel field. Solvers count passes through the flow, each about the cost
of one forward shooting.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from ..numerics.integrators import get_integrator
from ..validation import check_int
from .kernels import GaussianKernel

__all__ = [
    "FlowPass",
    "FlowModel",
    "rkhs_norm_sq",
    "rkhs_norm_sq_gradient",
    "rkhs_norm_sq_hvp",
]


def rkhs_norm_sq(kernel: GaussianKernel, control_points, momenta) -> float:
    """``||v||_H^2 = sum_ij K(c_i, c_j) mu_i . mu_j`` (eq. 1)."""
    return float((momenta * kernel.convolve(control_points, control_points, momenta)).sum())


def rkhs_norm_sq_gradient(kernel: GaussianKernel, control_points, momenta):
    """Gradient ``(g_c, g_mu)`` of ``||v||_H^2``: ``g_mu = 2 K mu``, ``g_c = -2 dmu/dt(0)``.

    ``||v||^2 = 2 H(c, mu)`` and the Hamiltonian equations give ``dmu/dt = -dH/dc``.
    """
    dc, dmu = kernel.hamiltonian_rhs(control_points, momenta)
    return -2.0 * dmu, 2.0 * dc


def rkhs_norm_sq_hvp(kernel: GaussianKernel, control_points, momenta, d_c, d_mu):
    """Hessian of ``||v||_H^2`` applied to ``(d_c, d_mu)``: the tangent of its gradient."""
    t_dc, t_dmu = kernel.hamiltonian_jvp(control_points, momenta, d_c, d_mu)
    return -2.0 * t_dmu, 2.0 * t_dc


@dataclass
class FlowPass:
    """One forward pass: the deformed points and what the adjoint and tangent passes need.

    Attributes
    ----------
    deformed : array, shape ``(k, d)``
        ``phi_1(T)``.
    control_points, momenta : arrays, shape ``(n_cp, d)``
        The initial control points and momenta of the pass.
    norm_sq : float
        ``||v||_H^2`` at those.
    velocity : array, shape ``(n_cp, d)``
        ``K(c, c) mu``, the velocity at the control points (``2 K mu`` is the
        regulariser's gradient with respect to ``mu``).
    state : object
        The model's record of the pass (stage states when kept).
    """

    deformed: np.ndarray
    control_points: np.ndarray
    momenta: np.ndarray
    norm_sq: float
    velocity: np.ndarray
    state: object = field(default=None, repr=False)


class FlowModel(ABC):
    """A deformation model of kernel landmark registration (see the module docstring).

    Parameters
    ----------
    kernel : GaussianKernel
    integrator : str or Integrator
    n_steps : int
    """

    #: Name in messages.
    label = "flow"
    #: Whether the model's control points can be optimised (they move with the flow).
    moves_control_points = False
    #: Integrator used when the settings leave it to None.
    default_integrator = "euler"

    def __init__(self, kernel: GaussianKernel, integrator, n_steps: int):
        self.kernel = kernel
        self.integrator = get_integrator(integrator)
        self.n_steps = check_int(n_steps, f"{self.label}: n_steps", minimum=1)

    @abstractmethod
    def forward(self, template, control_points, momenta, keep_stages=False, dense=False):
        """The :class:`FlowPass` of ``(control_points, momenta)`` applied to ``template``.

        ``dense`` says that the control points are the template's vertices (a model
        may then carry the template as its control points).
        """

    @abstractmethod
    def adjoint(self, flow_pass: FlowPass, cot):
        """Gradient ``(g_c, g_mu)`` of ``<cot, phi_1(T)>`` (needs ``keep_stages``)."""

    @abstractmethod
    def tangent(self, flow_pass: FlowPass, d_c, d_mu):
        """Tangent of ``phi_1(T)`` along ``(d_c, d_mu)`` (needs ``keep_stages``)."""
