"""Logarithm map by geodesic shooting: Newton's method on the initial velocity.

``Log_x(y)`` is the root ``v`` of ``F(v) = Exp_x(v) - y``. Each Newton step
integrates the geodesic together with its variational equations, which give
the exact differential ``dExp_x(v)`` (see :mod:`manifolds.numerics.geodesic_ode`),
and solves ``dExp_x(v) delta = -F(v)``. A backtracking line search on the
residual norm keeps the iteration inside the domain of the metric and makes it
robust to poor initial guesses; the default guess is the coordinate difference
``y - x``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import ConvergenceError
from .geodesic_ode import GeodesicDomainError

__all__ = ["ShootingSolver"]

# exp_with_jacobian(v) -> (Exp_x(v), dExp_x(v)); may raise GeodesicDomainError.
ExpJacobianFn = Callable[[np.ndarray], tuple]


class ShootingSolver:
    """Newton shooting for the logarithm map.

    Parameters
    ----------
    tol : float, default ``1e-11``
        Convergence when ``|Exp_x(v) - y| <= tol * (1 + |y|)`` (coordinate norm).
    max_iterations : int, default 50
        Newton iterations allowed.
    max_halvings : int, default 20
        Backtracking halvings of a Newton step (and of the initial guess, when
        the geodesic it shoots leaves the domain).
    max_slow_steps : int, default 6
        Give up after this many consecutive iterations that reduce the residual
        by less than 10% (a stalled iteration, typically when no geodesic joins
        the points).

    Notes
    -----
    The residual is measured in coordinates, the space in which the shot
    endpoint and the target live; its floor is the integrator's tolerance.
    """

    def __init__(
        self,
        tol: float = 1e-11,
        max_iterations: int = 50,
        max_halvings: int = 20,
        max_slow_steps: int = 6,
    ):
        if not tol > 0:
            raise ValueError(f"tol: expected a positive number, got {tol!r}")
        if int(max_iterations) != max_iterations or max_iterations < 1:
            raise ValueError(f"max_iterations: expected a positive integer, got {max_iterations!r}")
        if int(max_halvings) != max_halvings or max_halvings < 0:
            raise ValueError(f"max_halvings: expected an integer >= 0, got {max_halvings!r}")
        self.tol = float(tol)
        self.max_iterations = int(max_iterations)
        if int(max_slow_steps) != max_slow_steps or max_slow_steps < 1:
            raise ValueError(f"max_slow_steps: expected a positive integer, got {max_slow_steps!r}")
        self.max_halvings = int(max_halvings)
        self.max_slow_steps = int(max_slow_steps)

    def __repr__(self) -> str:
        return (
            f"ShootingSolver(tol={self.tol:g}, max_iterations={self.max_iterations}, "
            f"max_halvings={self.max_halvings}, max_slow_steps={self.max_slow_steps})"
        )

    def solve(
        self,
        exp_with_jacobian: ExpJacobianFn,
        point: np.ndarray,
        target: np.ndarray,
        initial_guess: np.ndarray | None = None,
    ) -> np.ndarray:
        """Initial velocity ``v`` at ``point`` with ``Exp_point(v) = target``.

        Parameters
        ----------
        exp_with_jacobian : callable
            ``v -> (Exp_point(v), dExp_point(v))``, shapes ``(n,)`` and ``(n, n)``;
            may raise :class:`GeodesicDomainError`.
        point, target : array, shape ``(n,)``
            Coordinates of the base point and of the target.
        initial_guess : array, shape ``(n,)``, optional
            Starting velocity; defaults to ``target - point``.

        Returns
        -------
        v : array, shape ``(n,)``

        Raises
        ------
        ConvergenceError
            When the residual does not fall below the tolerance, naming the
            points, the residual reached and the reason (iterations exhausted,
            stalled line search, geodesics leaving the domain, singular Jacobian).
        """
        point = np.asarray(point, dtype=float)
        target = np.asarray(target, dtype=float)
        v = target - point if initial_guess is None else np.array(initial_guess, dtype=float)
        threshold = self.tol * (1.0 + float(np.linalg.norm(target)))
        where = f"from {point.tolist()} to {target.tolist()}"

        v, (end, jac) = self._admissible_start(exp_with_jacobian, v, where)
        residual = end - target
        res_norm = float(np.linalg.norm(residual))
        slow = 0
        exits = 0
        for iteration in range(self.max_iterations + 1):
            if res_norm <= threshold:
                return v
            if iteration == self.max_iterations:
                break
            try:
                delta = np.linalg.solve(jac, -residual)
            except np.linalg.LinAlgError:
                raise ConvergenceError(
                    f"shooting {where} failed: singular differential of Exp at v = "
                    f"{v.tolist()} (conjugate point?), residual {res_norm:.3e}"
                ) from None
            step, n_exits = self._line_search(
                exp_with_jacobian, v, delta, target, res_norm, threshold
            )
            exits += n_exits
            if not isinstance(step, tuple):
                raise ConvergenceError(
                    f"shooting {where} stalled at residual {res_norm:.3e} "
                    f"(tolerance {threshold:.1e}): {step}"
                )
            t_norm = step[3]
            slow = slow + 1 if t_norm > 0.9 * res_norm else 0
            v, jac, residual, res_norm = step
            if slow >= self.max_slow_steps and res_norm > threshold:
                raise ConvergenceError(
                    f"shooting {where} stalled at residual {res_norm:.3e} "
                    f"(tolerance {threshold:.1e}): {slow} consecutive Newton steps reduced "
                    "it by less than 10%; the points may not be joined by a geodesic"
                    + (f" ({exits} trial geodesics left the domain)" if exits else "")
                )
        raise ConvergenceError(
            f"shooting {where} did not converge in {self.max_iterations} Newton "
            f"iterations: residual {res_norm:.3e} > tolerance {threshold:.1e}"
        )

    def _admissible_start(self, exp_with_jacobian: ExpJacobianFn, v: np.ndarray, where: str):
        """Halve the initial guess until the geodesic it shoots stays in the domain.

        Returns the guess and ``exp_with_jacobian`` of it.
        """
        last_exit = None
        for _ in range(self.max_halvings + 1):
            try:
                return v, exp_with_jacobian(v)
            except GeodesicDomainError as exc:
                last_exit = exc
                v = 0.5 * v
        raise ConvergenceError(
            f"shooting {where} failed: every initial guess leaves the domain ({last_exit})"
        )

    def _line_search(self, exp_with_jacobian, v, delta, target, res_norm, threshold):
        """Backtracking along the Newton step ``delta``.

        Returns ``((v, jac, residual, res_norm), n_exits)`` for the first step that
        decreases the residual, or ``(reason, n_exits)`` when every halving failed;
        ``n_exits`` counts trial geodesics that left the domain.
        """
        step = 1.0
        exits = 0
        reason = "no decrease of the residual"
        for _ in range(self.max_halvings + 1):
            trial = v + step * delta
            try:
                t_end, t_jac = exp_with_jacobian(trial)
            except GeodesicDomainError as exc:
                reason = f"trial geodesics leave the domain ({exc})"
                exits += 1
                step *= 0.5
                continue
            t_res = t_end - target
            t_norm = float(np.linalg.norm(t_res))
            if t_norm < res_norm or t_norm <= threshold:
                return (trial, t_jac, t_res, t_norm), exits
            step *= 0.5
        return reason, exits
