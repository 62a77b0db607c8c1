"""What a solver returns, and the problem interface solvers work on."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

__all__ = ["OptimizationResult", "SolverProblem"]


class SolverProblem(Protocol):
    """The minimisation problem as a solver sees it (duck-typed).

    ``x`` is a flat float vector of :attr:`size` entries (the optimiser's
    variables, e.g. preconditioned momenta). Solvers call
    :meth:`value_and_gradient`; the stopping rule calls :meth:`shape` and
    :meth:`predicted_change`. Optional methods (``jvp``, ``vjp``,
    ``gauss_newton_product``, ``refresh_metric``) serve second-order solvers.

    Solvers ask :meth:`value_and_gradient` again at an iterate already evaluated
    (L-BFGS-B at every accepted iterate, for the stopping rule), and call it
    directly: a costly problem keeps its latest evaluation
    (:class:`~manifolds.lddmm.registration_problem.RegistrationProblem` does).
    """

    size: int

    def value_and_gradient(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """Objective and gradient at ``x`` (the objective may be normalised)."""

    def shape(self, x: np.ndarray) -> np.ndarray:
        """The model's output at ``x`` (the deformed template), for the shape rule."""

    def predicted_change(self, x: np.ndarray, gradient: np.ndarray) -> float:
        """Per-vertex RMS change of the output that the preconditioned Newton step
        from ``x`` would make, estimated from ``gradient``."""


@dataclass
class OptimizationResult:
    """Outcome of a solver run.

    Attributes
    ----------
    x : array
        Final iterate.
    fun : float
        Objective at ``x`` (as the solver saw it).
    grad : array
        Gradient at ``x``.
    n_iter : int
        Iterations.
    n_evals : int
        Objective-and-gradient evaluations.
    history : list of float
        Objective at the start and after every iteration.
    converged : bool
        Whether the stopping rule was met (not the iteration limit or a failure).
    message : str
        Why the run stopped.
    trace : list of TraceRow
        Every iteration as the stopping rule recorded it (flow passes, objective,
        gradient, change of the output, predicted change).
    """

    x: np.ndarray
    fun: float
    grad: np.ndarray
    n_iter: int
    n_evals: int
    history: list = field(default_factory=list)
    converged: bool = False
    message: str = ""
    trace: list = field(default_factory=list)
