"""Flows of stationary velocity fields and their exact adjoint.

A stationary velocity field (SVF) does not change in time. For the Gaussian
kernel fields of the landmark spaces it is

    v(x) = sum_j K(x, c_j) m_j,

with control points ``c`` and momenta ``m`` fixed in time (unlike LDDMM,
where both follow the Hamiltonian equations). Its group exponential
``exp(v) = phi_1`` is the time-one flow of ``dx/dt = v(x)``, integrated here
with an explicit Runge-Kutta scheme of :mod:`manifolds.numerics.integrators`
(RK4 by default). Since ``v`` is autonomous, ``exp(t v)`` is the flow of ``v``
for time ``t`` and ``exp(-v)`` is the inverse of ``exp(v)`` up to the
integrator's error (order 4 for RK4).

:func:`integrate_stationary` flows points along any velocity callable (a
kernel field, or e.g. a linear field ``x -> A x`` whose flow is ``expm(A)``);
:func:`kernel_flow` is the kernel case, :func:`kernel_flow_vjp` the exact gradient
of the discrete flow with respect to the points, momenta and control points, and
:func:`kernel_flow_jvp` its exact tangent-linear model.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..numerics.integrators import Integrator, get_integrator
from .flow_models import FlowModel, FlowPass
from .hamiltonian_system import HamiltonianSystem, hamiltonian_system
from .kernels import GaussianKernel

__all__ = [
    "FlowResult",
    "StationaryFlow",
    "StationaryKernelFlow",
    "kernel_velocity",
    "integrate_stationary",
    "kernel_flow",
    "kernel_flow_vjp",
    "kernel_flow_jvp",
]

Velocity = Callable[[np.ndarray], np.ndarray]


@dataclass
class FlowResult:
    """Output of :func:`integrate_stationary`.

    Attributes
    ----------
    points : array, shape ``(k, d)``
        ``exp(t_final v)(x)`` for the points ``x`` given.
    stages : list, or None
        Stage states of every step (input of the adjoint pass).
    integrator : Integrator
    n_steps : int
    t_final : float
    system : HamiltonianSystem, or None
        For :func:`kernel_flow`: the kernel's system, in whose layout ``stages`` are
        (None: ``(k, d)`` arrays).
    """

    points: np.ndarray
    stages: list | None = field(default=None, repr=False)
    integrator: Integrator | None = None
    n_steps: int = 10
    t_final: float = 1.0
    system: HamiltonianSystem | None = field(default=None, repr=False)


def kernel_velocity(kernel: GaussianKernel, control_points, momenta) -> Velocity:
    """The field ``x -> sum_j K(x, c_j) m_j`` as a callable on ``(k, d)`` arrays."""
    cp = np.asarray(control_points, dtype=float)
    mom = np.asarray(momenta, dtype=float)

    def velocity(x: np.ndarray) -> np.ndarray:
        return kernel.convolve(x, cp, mom)

    return velocity


def integrate_stationary(
    velocity: Velocity,
    points,
    integrator: str | Integrator = "rk4",
    n_steps: int = 10,
    t_final: float = 1.0,
    keep_stages: bool = False,
) -> FlowResult:
    """Flow ``points`` along the stationary field ``velocity`` from ``t = 0`` to ``t_final``.

    Parameters
    ----------
    velocity : callable ``(k, d) array -> (k, d) array``
    points : array, shape ``(k, d)``
    integrator : {"euler", "rk2", "rk4"} or Integrator, default "rk4"
    n_steps : int, default 10
    t_final : float, default 1
        ``exp(t_final v)``; a negative time flows backwards.
    keep_stages : bool
        Keep the stage states needed by :func:`kernel_flow_vjp`.
    """
    scheme = get_integrator(integrator)
    out = scheme.integrate(
        lambda state: (velocity(state[0]),),
        (np.asarray(points, dtype=float),),
        n_steps=n_steps,
        t_final=t_final,
        keep_stages=keep_stages,
    )
    final, stages = (out[0], out[1]) if keep_stages else (out, None)
    return FlowResult(final[0], stages, scheme, int(n_steps), float(t_final))


def kernel_flow(
    kernel: GaussianKernel,
    control_points,
    momenta,
    points,
    integrator: str | Integrator = "rk4",
    n_steps: int = 10,
    t_final: float = 1.0,
    keep_stages: bool = False,
) -> FlowResult:
    """``exp(t_final v)(points)`` for the kernel field ``v`` of ``(control_points, momenta)``.

    Integrated in the layout of the kernel's backend (:func:`hamiltonian_system`): the
    inputs are converted once, the stages kept in that layout, the points converted back.
    """
    system = hamiltonian_system(kernel)
    c, m, x = system.to_layout(control_points, momenta, points)
    res = integrate_stationary(
        lambda y: system.velocity(y, c, m), x, integrator, n_steps, t_final, keep_stages
    )
    d = np.shape(points)[1]
    return FlowResult(
        system.from_layout(res.points, d), res.stages, res.integrator, res.n_steps,
        res.t_final, system,
    )  # fmt: skip


def kernel_flow_vjp(
    kernel: GaussianKernel,
    control_points,
    momenta,
    result: FlowResult,
    cot_points,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact gradient of ``<cot_points, exp(v)(x)>`` through the discrete flow.

    The field's parameters enter every stage ``k_s = v(Y_s)``; the adjoint pass
    of the Runge-Kutta scheme gives the stage cotangents ``kbar_s`` and the
    gradients with respect to ``c`` and ``m`` are the sums over all stages of
    the kernel's vector-Jacobian products.

    Parameters
    ----------
    kernel : GaussianKernel
    control_points, momenta : arrays, shape ``(n_cp, d)``
    result : FlowResult
        From :func:`kernel_flow` with ``keep_stages=True`` and the same field.
    cot_points : array, shape ``(k, d)``

    Returns
    -------
    g_points : array, shape ``(k, d)``
        Gradient with respect to the initial points ``x``.
    g_momenta, g_control_points : arrays, shape ``(n_cp, d)``
    """
    if result.stages is None:
        raise ValueError("kernel_flow_vjp: kernel_flow must be called with keep_stages=True")
    system = result.system or HamiltonianSystem(kernel)
    cp, mom, cot = system.to_layout(control_points, momenta, cot_points)
    g_mom = np.zeros_like(mom)
    g_cp = np.zeros_like(cp)

    def rhs_vjp(state, cot):
        g_x, g_c, g_m = system.velocity_vjp(state[0], cp, mom, cot[0])
        g_mom[...] += g_m
        g_cp[...] += g_c
        return (g_x,)

    h = result.t_final / result.n_steps
    (g_points,) = result.integrator.backward(rhs_vjp, result.stages, h, (cot,))
    d = np.shape(control_points)[1]
    return tuple(system.from_layout(g, d) for g in (g_points, g_mom, g_cp))


def kernel_flow_jvp(
    kernel: GaussianKernel,
    control_points,
    momenta,
    result: FlowResult,
    d_momenta=None,
    d_control_points=None,
    d_points=None,
) -> np.ndarray:
    """Exact tangent of ``exp(v)(x)`` along ``(dm, dc, dx)`` through the discrete flow.

    Every stage ``k_s = v(Y_s)`` depends on the field's parameters, which are
    constant in time: their tangents enter each stage's Jacobian-vector product.

    Parameters
    ----------
    kernel : GaussianKernel
    control_points, momenta : arrays, shape ``(n_cp, d)``
    result : FlowResult
        From :func:`kernel_flow` with ``keep_stages=True`` and the same field.
    d_momenta, d_control_points : arrays, shape ``(n_cp, d)``, optional
    d_points : array, shape ``(k, d)``, optional

    Returns
    -------
    array, shape ``(k, d)``
        The tangent of the flowed points.
    """
    if result.stages is None:
        raise ValueError("kernel_flow_jvp: kernel_flow must be called with keep_stages=True")
    system = result.system or HamiltonianSystem(kernel)
    cp = np.asarray(control_points, dtype=float)
    mom = np.asarray(momenta, dtype=float)
    dm = np.zeros_like(mom) if d_momenta is None else np.asarray(d_momenta, dtype=float)
    dc = np.zeros_like(cp) if d_control_points is None else np.asarray(d_control_points, float)
    x0 = result.points
    dx = np.zeros_like(x0) if d_points is None else np.asarray(d_points, dtype=float)
    cp, mom, dc, dm, dx = system.to_layout(cp, mom, dc, dm, dx)

    def rhs_jvp(state, tan):
        return (system.velocity_jvp(state[0], cp, mom, tan[0], dc, dm),)

    h = result.t_final / result.n_steps
    out = result.integrator.forward(rhs_jvp, result.stages, h, (dx,))[0]
    return system.from_layout(out, x0.shape[1])


@dataclass(frozen=True)
class StationaryFlow:
    """The group exponential ``exp(t v)`` of a stationary field, as a map on point sets.

    Parameters
    ----------
    velocity : callable ``(k, d) array -> (k, d) array``
        The field ``v``.
    integrator : {"euler", "rk2", "rk4"} or Integrator, default "rk4"
    n_steps : int, default 10
        Steps of the integration of ``exp(t v)`` (whatever ``t``).
    time : float, default 1
        The ``t`` of ``exp(t v)``: :meth:`scaled` multiplies it, :meth:`inverse` negates it.

    Examples
    --------
    >>> import numpy as np
    >>> phi = StationaryFlow(lambda x: x @ np.array([[0.0, -1.0], [1.0, 0.0]]).T)
    >>> x = np.array([[1.0, 0.0]])
    >>> np.allclose(phi.inverse()(phi(x)), x, atol=1e-5)
    True
    """

    velocity: Velocity
    integrator: str | Integrator = "rk4"
    n_steps: int = 10
    time: float = 1.0

    @classmethod
    def from_momenta(
        cls,
        kernel: GaussianKernel,
        control_points,
        momenta,
        integrator: str | Integrator = "rk4",
        n_steps: int = 10,
    ) -> StationaryFlow:
        """``exp(v)`` for the kernel field of ``(control_points, momenta)``."""
        return cls(kernel_velocity(kernel, control_points, momenta), integrator, n_steps)

    def __call__(self, points) -> np.ndarray:
        """``exp(t v)(points)``, shape ``(k, d)``."""
        if self.time == 0.0:
            return np.array(points, dtype=float, copy=True)
        res = integrate_stationary(
            self.velocity, points, self.integrator, self.n_steps, t_final=self.time
        )
        return res.points

    def scaled(self, factor: float) -> StationaryFlow:
        """``exp(factor t v)`` (same integrator and number of steps)."""
        return StationaryFlow(self.velocity, self.integrator, self.n_steps, factor * self.time)

    def inverse(self) -> StationaryFlow:
        """``exp(-t v)``, the inverse of ``exp(t v)`` up to the integration error."""
        return self.scaled(-1.0)


class StationaryKernelFlow(FlowModel):
    """SVF: the flow of the stationary field ``v(x) = sum_j K(x, c_j) m_j`` (c, m fixed in time)."""

    label = "SVF"
    default_integrator = "rk4"

    def forward(self, template, control_points, momenta, keep_stages=False, dense=False):
        res = kernel_flow(
            self.kernel,
            control_points,
            momenta,
            template,
            self.integrator,
            self.n_steps,
            keep_stages=keep_stages,
        )
        velocity = self.kernel.convolve(control_points, control_points, momenta)
        return FlowPass(
            deformed=res.points,
            control_points=control_points,
            momenta=momenta,
            norm_sq=float((momenta * velocity).sum()),
            velocity=velocity,
            state=res,
        )

    def adjoint(self, flow_pass, cot):
        _, g_m, g_c = kernel_flow_vjp(
            self.kernel, flow_pass.control_points, flow_pass.momenta, flow_pass.state, cot
        )
        return g_c, g_m

    def tangent(self, flow_pass, d_c, d_mu):
        return kernel_flow_jvp(
            self.kernel,
            flow_pass.control_points,
            flow_pass.momenta,
            flow_pass.state,
            d_momenta=d_mu,
            d_control_points=d_c,
        )
