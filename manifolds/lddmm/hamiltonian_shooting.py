"""Hamiltonian shooting of control points and momenta, point flow and its adjoint.

The geodesic equations of the LDDMM landmark metric (paper, eq. 2) with the
Gaussian kernel ``K(x, y) = exp(-|x - y|^2 / sigma^2)`` read::

    dc_i/dt  = sum_j K(c_i, c_j) mu_j,
    dmu_i/dt = (2 / sigma^2) sum_j (mu_i . mu_j) K(c_i, c_j) (c_i - c_j),

and any set of points follows the same velocity field, ``dx/dt = sum_j K(x, c_j) mu_j``.
The three are integrated together as one ODE on the state ``(c, mu[, x])``
with a Runge-Kutta scheme of :mod:`manifolds.numerics.integrators`, so that
points and control points see the same (stage) velocity fields and the flow of
the control points equals their shooting. :func:`shooting_vjp` is the exact
adjoint of this discrete forward pass.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..numerics.integrators import Integrator, get_integrator
from .kernels import GaussianKernel

__all__ = [
    "ShootingResult",
    "hamiltonian",
    "hamiltonian_system",
    "shoot",
    "shooting_vjp",
    "shooting_jvp",
]


def hamiltonian(kernel: GaussianKernel, control_points, momenta) -> float:
    """``H(c, mu) = 1/2 sum_ij mu_i . mu_j K(c_i, c_j)`` (half the squared RKHS norm)."""
    return 0.5 * kernel.rkhs_inner(control_points, momenta, momenta)


def hamiltonian_system(kernel: GaussianKernel):
    """Right-hand side and its derivatives for the state ``(c, mu[, x])``.

    Returns
    -------
    rhs : callable ``state -> dstate``
    rhs_vjp : callable ``(state, cotangent) -> gradient`` (same tuple layout)
    rhs_jvp : callable ``(state, tangent) -> tangent of dstate`` (same tuple layout)
    """

    def rhs(state):
        c, mu = state[0], state[1]
        dc, dmu = kernel.hamiltonian_rhs(c, mu)
        if len(state) == 2:
            return dc, dmu
        return dc, dmu, kernel.convolve(state[2], c, mu)

    def rhs_vjp(state, cot):
        c, mu = state[0], state[1]
        g_c, g_mu = kernel.hamiltonian_vjp(c, mu, cot[0], cot[1])
        if len(state) == 2:
            return g_c, g_mu
        g_x, g_c2, g_mu2 = kernel.convolve_vjp(state[2], c, mu, cot[2])
        return g_c + g_c2, g_mu + g_mu2, g_x

    def rhs_jvp(state, tan):
        c, mu = state[0], state[1]
        d_dc, d_dmu = kernel.hamiltonian_jvp(c, mu, tan[0], tan[1])
        if len(state) == 2:
            return d_dc, d_dmu
        return d_dc, d_dmu, kernel.convolve_jvp(state[2], c, mu, tan[2], tan[0], tan[1])

    return rhs, rhs_vjp, rhs_jvp


@dataclass
class ShootingResult:
    """Output of :func:`shoot`.

    Attributes
    ----------
    control_points, momenta : arrays, shape ``(n_cp, d)``
        ``c(1)`` and ``mu(1)``.
    points : array, shape ``(k, d)``, or None
        ``phi_1(x)`` for the points given to :func:`shoot`.
    trajectory : list of tuples, or None
        The ``n_steps + 1`` states ``(c, mu[, x])`` at the step boundaries.
    stages : list, or None
        Stage states of every step, kept for :func:`shooting_vjp`.
    integrator : Integrator
    n_steps : int
    initial_velocity : array, shape ``(n_cp, d)``
        ``v_0(c_j) = sum_i K(c_j, c_i) mu_i`` at ``t = 0`` (so ``<mu, K mu> = sum mu . v``).
    """

    control_points: np.ndarray
    momenta: np.ndarray
    points: np.ndarray | None
    trajectory: list | None = None
    stages: list | None = field(default=None, repr=False)
    integrator: Integrator | None = None
    n_steps: int = 10
    initial_velocity: np.ndarray | None = field(default=None, repr=False)


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
    scheme = get_integrator(integrator)
    base_rhs, _, _ = hamiltonian_system(kernel)
    first: list = []

    def rhs(state):
        out = base_rhs(state)
        if not first:
            first.append(out)
        return out

    state = (np.asarray(control_points, dtype=float), np.asarray(momenta, dtype=float))
    if points is not None:
        state += (np.asarray(points, dtype=float),)
    out = scheme.integrate(
        rhs,
        state,
        n_steps=n_steps,
        return_trajectory=return_trajectory,
        keep_stages=keep_stages,
    )
    if not isinstance(out, tuple) or not isinstance(out[0], tuple):
        out = (out,)
    final = out[0]
    traj = out[1] if return_trajectory else None
    stages = out[-1] if keep_stages else None
    return ShootingResult(
        control_points=final[0],
        momenta=final[1],
        points=final[2] if points is not None else None,
        trajectory=traj,
        stages=stages,
        integrator=scheme,
        n_steps=int(n_steps),
        initial_velocity=first[0][0],
    )


def _state_like(result: ShootingResult, c, mu, x) -> tuple:
    """A (co)tangent ``(c, mu[, x])`` of the shot's state, zeros where None is given."""
    parts = [(c, result.control_points), (mu, result.momenta)]
    if result.points is not None:
        parts.append((x, result.points))
    return tuple(
        np.zeros_like(ref) if v is None else np.asarray(v, dtype=float) for v, ref in parts
    )


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
    _, rhs_vjp, _ = hamiltonian_system(kernel)
    cot = _state_like(result, cot_control_points, cot_momenta, cot_points)
    h = 1.0 / result.n_steps
    grad = result.integrator.backward(rhs_vjp, result.stages, h, cot)
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
    _, _, rhs_jvp = hamiltonian_system(kernel)
    tan = _state_like(result, d_control_points, d_momenta, d_points)
    h = 1.0 / result.n_steps
    out = result.integrator.forward(rhs_jvp, result.stages, h, tan)
    return out[0], out[1], (out[2] if len(out) > 2 else None)
