"""Hamiltonian shooting of control points and momenta, point flow and its adjoint.

The geodesic equations of the LDDMM landmark metric (paper, eq. 2) with the
Gaussian kernel ``K(x, y) = exp(-|x - y|^2 / sigma^2)`` read::

    dc_i/dt  = sum_j K(c_i, c_j) mu_j,
    dmu_i/dt = (2 / sigma^2) sum_j (mu_i . mu_j) K(c_i, c_j) (c_i - c_j),

and any set of points follows the same velocity field, ``dx/dt = sum_j K(x, c_j) mu_j``.
The three are integrated together as one ODE on the state ``(c, mu[, x])``
(:mod:`manifolds.lddmm.hamiltonian_system`, in the kernel backend's layout) with a
Runge-Kutta scheme of :mod:`manifolds.numerics.integrators`, so that points and
control points see the same (stage) velocity fields and the flow of the control
points equals their shooting.

:class:`HamiltonianFlow` is LDDMM's deformation model: its :meth:`~HamiltonianFlow.forward`
pass is the shooting, its :meth:`~HamiltonianFlow.adjoint` the exact adjoint of this
discrete forward pass and its :meth:`~HamiltonianFlow.tangent` the exact tangent-linear
pass; each converts to the system's layout once, calls the integrator, and converts
back once. :func:`shoot`, :func:`shooting_vjp` and :func:`shooting_jvp` are the same
passes for a kernel, with every cotangent and tangent of the state.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..numerics.integrators import Integrator
from .flow_models import FlowModel, FlowPass
from .hamiltonian_system import HamiltonianSystem, hamiltonian_system
from .kernels import GaussianKernel

__all__ = [
    "HamiltonianFlow",
    "ShootingResult",
    "hamiltonian",
    "shoot",
    "shooting_vjp",
    "shooting_jvp",
]


def hamiltonian(kernel: GaussianKernel, control_points, momenta) -> float:
    """``H(c, mu) = 1/2 sum_ij mu_i . mu_j K(c_i, c_j)`` (half the squared RKHS norm)."""
    return 0.5 * kernel.rkhs_inner(control_points, momenta, momenta)


@dataclass
class ShootingResult:
    """Output of :func:`shoot` (and the record of a :meth:`HamiltonianFlow.forward` pass).

    Attributes
    ----------
    control_points, momenta : arrays, shape ``(n_cp, d)``
        ``c(1)`` and ``mu(1)``.
    points : array, shape ``(k, d)``, or None
        ``phi_1(x)`` for the points given to :func:`shoot`.
    trajectory : list of tuples, or None
        The ``n_steps + 1`` states ``(c, mu[, x])`` at the step boundaries.
    stages : list, or None
        Stage states of every step, in ``system``'s layout, kept for :func:`shooting_vjp`.
    integrator : Integrator
    n_steps : int
    initial_velocity : array, shape ``(n_cp, d)``
        ``v_0(c_j) = sum_i K(c_j, c_i) mu_i`` at ``t = 0`` (so ``<mu, K mu> = sum mu . v``).
    system : HamiltonianSystem, or None
        The system that integrated (the layout of ``stages``).
    """

    control_points: np.ndarray
    momenta: np.ndarray
    points: np.ndarray | None
    trajectory: list | None = None
    stages: list | None = field(default=None, repr=False)
    integrator: Integrator | None = None
    n_steps: int = 10
    initial_velocity: np.ndarray | None = field(default=None, repr=False)
    system: HamiltonianSystem | None = field(default=None, repr=False)


def _in_layout(result: ShootingResult, c, mu, x) -> tuple:
    """A (co)tangent ``(c, mu[, x])`` of the shot's state in its system's layout (zeros for None)."""
    parts = [(c, result.control_points), (mu, result.momenta)]
    if result.points is not None:
        parts.append((x, result.points))
    return result.system.to_layout(
        *(np.zeros_like(ref) if v is None else np.asarray(v, dtype=float) for v, ref in parts)
    )


def _from_layout(result: ShootingResult, state: tuple) -> tuple:
    d = result.control_points.shape[1]
    return tuple(result.system.from_layout(a, d) for a in state)


class HamiltonianFlow(FlowModel):
    """LDDMM: geodesic shooting of control points and momenta (eq. 2), points carried along.

    Parameters
    ----------
    kernel : GaussianKernel
    integrator : str or Integrator
    n_steps : int

    Attributes
    ----------
    system : HamiltonianSystem
        Eq. 2 in the kernel backend's layout (:func:`hamiltonian_system`).
    """

    label = "LDDMM"
    moves_control_points = True

    def __init__(self, kernel: GaussianKernel, integrator, n_steps: int):
        super().__init__(kernel, integrator, n_steps)
        self.system = hamiltonian_system(kernel)

    def forward(
        self,
        template,
        control_points,
        momenta,
        keep_stages: bool = False,
        dense: bool = False,
        return_trajectory: bool = False,
    ) -> FlowPass:
        """Shoot ``(control_points, momenta)``, carrying ``template`` (unless ``dense`` or None).

        ``flow_pass.state`` is the :class:`ShootingResult`; ``flow_pass.deformed`` is
        ``phi_1(template)``, or ``c(1)`` when the template is the control points.
        """
        system = self.system
        carried = not dense and template is not None
        arrays = (control_points, momenta, template) if carried else (control_points, momenta)
        out = self.integrator.integrate(
            system.rhs,
            system.to_layout(*arrays),
            n_steps=self.n_steps,
            return_trajectory=return_trajectory,
            keep_stages=keep_stages,
            return_initial_rate=True,
        )
        d = np.shape(control_points)[1]
        final = tuple(system.from_layout(a, d) for a in out[0])
        trajectory = None
        if return_trajectory:
            trajectory = [tuple(system.from_layout(a, d) for a in y) for y in out[1]]
        velocity = system.from_layout(out[-1][0], d)
        shot = ShootingResult(
            control_points=final[0],
            momenta=final[1],
            points=final[2] if carried else None,
            trajectory=trajectory,
            stages=out[-2] if keep_stages else None,
            integrator=self.integrator,
            n_steps=self.n_steps,
            initial_velocity=velocity,
            system=system,
        )
        with np.errstate(over="ignore", invalid="ignore"):  # a non-finite shot is named
            norm_sq = float((momenta * velocity).sum())  # by its caller, not warned here
        return FlowPass(
            deformed=final[2] if carried else final[0],
            control_points=control_points,
            momenta=momenta,
            norm_sq=norm_sq,
            velocity=velocity,
            state=shot,
        )

    def adjoint(self, flow_pass: FlowPass, cot):
        shot = flow_pass.state
        carried = shot.points is not None
        cot = _in_layout(shot, None if carried else cot, None, cot if carried else None)
        grad = self.integrator.backward(self.system.rhs_vjp, shot.stages, 1.0 / self.n_steps, cot)
        return _from_layout(shot, grad[:2])

    def tangent(self, flow_pass: FlowPass, d_c, d_mu):
        shot = flow_pass.state
        tan = _in_layout(shot, d_c, d_mu, None)
        out = self.integrator.forward(self.system.rhs_jvp, shot.stages, 1.0 / self.n_steps, tan)
        return _from_layout(shot, out[2:] if shot.points is not None else out[:1])[0]


def shoot(
    kernel: GaussianKernel,
    control_points,
    momenta,
    integrator: str | Integrator = "rk2",
    n_steps: int = 10,
    points=None,
    return_trajectory: bool = False,
    keep_stages: bool = False,
) -> ShootingResult:
    """Integrate the Hamiltonian system from ``(c, mu)`` over ``[0, 1]``, flowing ``points``.

    The forward pass of :class:`HamiltonianFlow`.

    Parameters
    ----------
    kernel : GaussianKernel
    control_points, momenta : arrays, shape ``(n_cp, d)``
    integrator : {"euler", "rk2", "rk4"} or Integrator, default "rk2"
    n_steps : int, default 10
    points : array, shape ``(k, d)``, optional
        Points carried by the flow ``phi_t``.
    return_trajectory : bool
        Keep the states at every step boundary.
    keep_stages : bool
        Keep the stage states needed by :func:`shooting_vjp`.
    """
    flow = HamiltonianFlow(kernel, integrator, n_steps)
    momenta = np.asarray(momenta, dtype=float)
    return flow.forward(
        points, control_points, momenta, keep_stages, return_trajectory=return_trajectory
    ).state


def shooting_vjp(
    kernel: GaussianKernel,
    result: ShootingResult,
    cot_control_points=None,
    cot_momenta=None,
    cot_points=None,
):
    """Exact gradient of ``<cot, final state>`` with respect to the initial state.

    Back-propagates through the discrete scheme used by :func:`shoot` (which
    must have been called with ``keep_stages=True``).

    Returns
    -------
    g_c, g_mu : arrays, shape ``(n_cp, d)``
        Gradients with respect to the initial control points and momenta.
    g_x : array, shape ``(k, d)``, or None
        Gradient with respect to the initial points (when points were flowed).
    """
    if result.stages is None:
        raise ValueError("shooting_vjp: shoot must be called with keep_stages=True")
    cot = _in_layout(result, cot_control_points, cot_momenta, cot_points)
    h = 1.0 / result.n_steps
    grad = _from_layout(
        result, result.integrator.backward(result.system.rhs_vjp, result.stages, h, cot)
    )
    return grad[0], grad[1], (grad[2] if len(grad) > 2 else None)


def shooting_jvp(
    kernel: GaussianKernel,
    result: ShootingResult,
    d_control_points=None,
    d_momenta=None,
    d_points=None,
):
    """Exact tangent of the final state along a tangent of the initial state.

    Pushes ``(dc_0, dmu_0[, dx_0])`` forward through the discrete scheme used by
    :func:`shoot` (which must have been called with ``keep_stages=True``): the
    tangent-linear model of the shooting, one pass costing about one forward
    shooting.

    Returns
    -------
    dc, dmu : arrays, shape ``(n_cp, d)``
        Tangents of ``c(1)`` and ``mu(1)``.
    dx : array, shape ``(k, d)``, or None
        Tangent of ``phi_1(x)`` (when points were flowed).
    """
    if result.stages is None:
        raise ValueError("shooting_jvp: shoot must be called with keep_stages=True")
    tan = _in_layout(result, d_control_points, d_momenta, d_points)
    h = 1.0 / result.n_steps
    out = _from_layout(
        result, result.integrator.forward(result.system.rhs_jvp, result.stages, h, tan)
    )
    return out[0], out[1], (out[2] if len(out) > 2 else None)
