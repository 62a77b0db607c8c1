"""Explicit Runge-Kutta integrators with an exact discrete adjoint.

An integrator is a Butcher tableau ``(a, b)``. It advances a state, a tuple of
arrays ``y``, of an autonomous ODE ``dy/dt = f(y)`` by one step ``h``::

    Y_s = y + h sum_{r<s} a[s][r] k_r,   k_s = f(Y_s),   y' = y + h sum_s b[s] k_s.

Euler uses the values at the start of the step (Deformetrica's convention);
RK2 is the explicit midpoint rule; RK4 the classical scheme. :meth:`step_vjp`
back-propagates a cotangent exactly through one discrete step given the stage
states saved by :meth:`step`:

    kbar_s = h b[s] ybar' + h sum_{q>s} a[q][s] Ybar_q,   Ybar_s = (df(Y_s))^T kbar_s,
    ybar = ybar' + sum_s Ybar_s,

and :meth:`step_jvp` pushes a tangent forward through the same step (the
tangent-linear model of the discrete scheme):

    dY_s = dy + h sum_{r<s} a[s][r] dk_r,   dk_s = df(Y_s) dY_s,   dy' = dy + h sum_s b[s] dk_s.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Integrator", "Euler", "RK2", "RK4", "get_integrator", "INTEGRATORS"]

State = tuple[np.ndarray, ...]
Rhs = Callable[[State], State]
RhsVjp = Callable[[State, State], State]
RhsJvp = Callable[[State, State], State]


def _axpy(y: State, coefs: Sequence[tuple[float, State]]) -> State:
    """``y + sum_r coef_r * k_r`` component-wise."""
    out = []
    for i, yi in enumerate(y):
        acc = yi.copy()
        for coef, k in coefs:
            acc += coef * k[i]
        out.append(acc)
    return tuple(out)


@dataclass(frozen=True)
class Integrator:
    """Explicit Runge-Kutta scheme given by its Butcher tableau.

    Parameters
    ----------
    name : str
    a : tuple of tuples
        Strictly lower-triangular stage coefficients, ``a[s]`` has ``s`` entries.
    b : tuple of float
        Weights of the stages.
    order : int
        Convergence order (information only).
    """

    name: str
    a: tuple[tuple[float, ...], ...]
    b: tuple[float, ...]
    order: int

    @property
    def n_stages(self) -> int:
        return len(self.b)

    def step(self, rhs: Rhs, y: State, h: float) -> tuple[State, list[State]]:
        """One step; returns the new state and the stage states ``Y_s``."""
        new, all_stages = self.integrate(rhs, y, n_steps=1, t_final=h, keep_stages=True)
        return new, all_stages[0]

    def step_vjp(self, rhs_vjp: RhsVjp, stages: list[State], h: float, cot: State) -> State:
        """Pull the cotangent ``cot`` of ``y'`` back to the cotangent of ``y`` (exact)."""
        return self.backward(rhs_vjp, [stages], h, cot)

    def step_jvp(self, rhs_jvp: RhsJvp, stages: list[State], h: float, tangent: State) -> State:
        """Push the tangent ``dy`` of ``y`` forward to the tangent of ``y'`` (exact)."""
        return self.forward(rhs_jvp, [stages], h, tangent)

    def integrate(
        self,
        rhs: Rhs,
        y0: State,
        n_steps: int = 10,
        t_final: float = 1.0,
        return_trajectory: bool = False,
        keep_stages: bool = False,
        return_initial_rate: bool = False,
    ):
        """Integrate from ``t = 0`` to ``t_final`` in ``n_steps`` equal steps.

        The stages are evaluated here, step after step (:meth:`step` is one step of
        this loop), so that ``rhs`` is called directly.

        Returns
        -------
        y : State
            Final state.
        trajectory : list of State, only if ``return_trajectory``
            The ``n_steps + 1`` states at the step boundaries.
        stages : list of list of State, only if ``keep_stages``
            The stage states of every step (input of :meth:`backward`).
        initial_rate : State, only if ``return_initial_rate``
            ``f(y0)``, the rate of the first stage (every explicit scheme starts
            at ``y0``), e.g. the initial velocity of a shooting.
        """
        if int(n_steps) != n_steps or n_steps < 1:
            raise ValueError(f"{self.name}: n_steps must be a positive integer, got {n_steps}")
        h = float(t_final) / int(n_steps)
        y = tuple(np.asarray(v, dtype=float) for v in y0)
        traj = [y] if return_trajectory else None
        all_stages = [] if keep_stages else None
        initial_rate = None
        for _ in range(int(n_steps)):
            ks: list[State] = []
            stages: list[State] = []
            for s in range(self.n_stages):
                coefs = [(h * a, ks[r]) for r, a in enumerate(self.a[s]) if a != 0.0]
                ys = y if not coefs else _axpy(y, coefs)
                stages.append(ys)
                ks.append(rhs(ys))
            if initial_rate is None:
                initial_rate = ks[0]
            y = _axpy(y, [(h * b, ks[s]) for s, b in enumerate(self.b) if b != 0.0])
            if traj is not None:
                traj.append(y)
            if all_stages is not None:
                all_stages.append(stages)
        out = (y,)
        if return_trajectory:
            out += (traj,)
        if keep_stages:
            out += (all_stages,)
        if return_initial_rate:
            out += (initial_rate,)
        return out[0] if len(out) == 1 else out

    def backward(self, rhs_vjp: RhsVjp, all_stages: list[list[State]], h: float, cot: State):
        """Pull a cotangent of the final state back through all steps to ``y0`` (exact).

        Per step, from the last stage to the first (the stage loop of
        :meth:`step_vjp`, written here so that ``rhs_vjp`` is called directly)::

            kbar_s = h b[s] ybar' + h sum_{q>s} a[q][s] Ybar_q,   Ybar_s = (df(Y_s))^T kbar_s.
        """
        n = self.n_stages
        for stages in reversed(all_stages):
            ybar_stage: list[State | None] = [None] * n
            ybar = [c.copy() for c in cot]
            for s in range(n - 1, -1, -1):
                coefs = [(h * self.b[s], cot)] if self.b[s] != 0.0 else []
                coefs += [
                    (h * self.a[q][s], ybar_stage[q])
                    for q in range(s + 1, n)
                    if self.a[q][s] != 0.0
                ]
                if not coefs:
                    continue
                kbar = tuple(sum(coef * v[i] for coef, v in coefs) for i in range(len(cot)))
                ybar_stage[s] = rhs_vjp(stages[s], kbar)
                for i, g in enumerate(ybar_stage[s]):
                    ybar[i] += g
            cot = tuple(ybar)
        return cot

    def forward(self, rhs_jvp: RhsJvp, all_stages: list[list[State]], h: float, tangent: State):
        """Push a tangent of ``y0`` through all steps to the tangent of the final state (exact).

        Per step (the loop of :meth:`step_jvp`, written here so that ``rhs_jvp`` is
        called directly): ``dY_s = dy + h sum_{r<s} a[s][r] dk_r``, ``dk_s = df(Y_s) dY_s``.
        """
        for stages in all_stages:
            dks: list[State] = []
            for s in range(self.n_stages):
                coefs = [(h * a, dks[r]) for r, a in enumerate(self.a[s]) if a != 0.0]
                dys = tangent if not coefs else _axpy(tangent, coefs)
                dks.append(rhs_jvp(stages[s], dys))
            tangent = _axpy(tangent, [(h * b, dks[s]) for s, b in enumerate(self.b) if b != 0.0])
        return tangent


Euler = Integrator("euler", a=((),), b=(1.0,), order=1)
RK2 = Integrator("rk2", a=((), (0.5,)), b=(0.0, 1.0), order=2)
RK4 = Integrator(
    "rk4",
    a=((), (0.5,), (0.0, 0.5), (0.0, 0.0, 1.0)),
    b=(1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0),
    order=4,
)
INTEGRATORS = {"euler": Euler, "rk2": RK2, "rk4": RK4}


def get_integrator(integrator: str | Integrator) -> Integrator:
    """Return the integrator named ``"euler"``, ``"rk2"`` or ``"rk4"``, or the object given."""
    if isinstance(integrator, Integrator):
        return integrator
    key = str(integrator).lower()
    if key not in INTEGRATORS:
        raise ValueError(
            f"integrator: unknown name {integrator!r}; choose one of {sorted(INTEGRATORS)} "
            "or pass an Integrator"
        )
    return INTEGRATORS[key]
