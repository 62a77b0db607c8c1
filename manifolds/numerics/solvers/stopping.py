"""When a registration has converged: in the objective's digits, or in the shapes' unit.

Two rules (``RegistrationSettings.stopping``):

* ``"objective"``: the relative decrease of the (normalised) objective between two
  iterations is at most ``ftol``, or the largest gradient entry at most ``gtol``
  (L-BFGS-B's own test);
* ``"shape"``: the quantities the study reads are distances between shapes, so
  the rule stops when the deformed template ``phi_1(T)`` no longer moves at the
  accuracy asked: the per-vertex RMS change of ``phi_1(T)`` over the last
  iteration, and the change that a Newton step predicted from the gradient in
  the preconditioned metric would make, are both at most ``shape_tol`` (in the
  shapes' unit, e.g. mm).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["StoppingRule", "TraceRow"]


@dataclass(frozen=True)
class TraceRow:
    """One iteration of a solver run, as the stopping rule saw it.

    Attributes
    ----------
    flow_passes : int or None
        Flow passes made so far (problems that count them), else None.
    objective : float
        Normalised objective.
    gradient : float
        Largest entry of the gradient in the optimiser's variables.
    shape_change : float
        Per-vertex RMS change of the problem's output over the iteration.
    predicted_change : float
        Change a preconditioned Newton step would make (``problem.predicted_change``).
    """

    flow_passes: int | None
    objective: float
    gradient: float
    shape_change: float
    predicted_change: float


class StoppingRule:
    """Convergence test of a solver run (see the module docstring).

    Parameters
    ----------
    kind : {"objective", "shape"}
    ftol, gtol, shape_tol : float
    max_iter : int
    """

    def __init__(
        self,
        kind: str = "objective",
        ftol: float = 1e-11,
        gtol: float = 1e-9,
        shape_tol: float = 1e-3,
        max_iter: int = 500,
    ):
        if kind not in ("objective", "shape"):
            raise ValueError(f"StoppingRule: kind: expected 'objective' or 'shape', got {kind!r}")
        self.kind = kind
        self.ftol, self.gtol, self.shape_tol = float(ftol), float(gtol), float(shape_tol)
        self.max_iter = int(max_iter)
        self._previous_f = None
        self._previous_shape = None
        self.trace: list[TraceRow] = []

    def __repr__(self) -> str:
        if self.kind == "shape":
            return f"StoppingRule('shape', shape_tol={self.shape_tol:g})"
        return f"StoppingRule('objective', ftol={self.ftol:g}, gtol={self.gtol:g})"

    def describe(self) -> str:
        """One sentence stating the rule, for reports."""
        if self.kind == "shape":
            return (
                f"the deformed template moved by at most {self.shape_tol:g} (per-vertex RMS, "
                "the shapes' unit) in the last iteration and the preconditioned gradient "
                "predicts no larger change"
            )
        return (
            f"relative decrease of the objective at most {self.ftol:g} or largest gradient "
            f"entry at most {self.gtol:g}"
        )

    def start(self, problem, x0, f0) -> None:
        """Record the starting point."""
        self._previous_f = float(f0)
        self._previous_shape = np.array(problem.shape(x0), dtype=float)
        self.trace: list[TraceRow] = []

    @property
    def shape_changes(self) -> list[float]:
        """Per-iteration changes of the output recorded so far."""
        return [row.shape_change for row in getattr(self, "trace", [])]

    def met(self, problem, x, f, g) -> str | None:
        """After an iteration to ``x`` (objective ``f``, gradient ``g``): record it in
        :attr:`trace`; return the reason to stop as converged under this rule, or None."""
        f = float(f)
        previous, self._previous_f = self._previous_f, f
        shape = np.array(problem.shape(x), dtype=float)
        change = _rms(shape - self._previous_shape)
        self._previous_shape = shape
        row = TraceRow(
            getattr(problem, "n_flow_evaluations", None),
            f,
            float(np.max(np.abs(g), initial=0.0)),
            change,
            float(problem.predicted_change(x, g)),
        )
        self.trace.append(row)
        if self.kind == "objective":
            return self._objective_reason(previous, row)
        return self._shape_reason(row)

    def _objective_reason(self, previous, row: TraceRow) -> str | None:
        if previous is not None:
            rel = (previous - row.objective) / max(abs(previous), abs(row.objective), 1.0)
            if rel <= self.ftol:
                return f"relative decrease {rel:.3g} <= ftol"
        if row.gradient <= self.gtol:
            return "largest gradient entry <= gtol"
        return None

    def _shape_reason(self, row: TraceRow) -> str | None:
        if row.shape_change <= self.shape_tol and row.predicted_change <= self.shape_tol:
            return (
                f"shape change {row.shape_change:.3g} and predicted change "
                f"{row.predicted_change:.3g} <= shape_tol"
            )
        return None

    def met_by_trace(self, trace: list[TraceRow]) -> bool:
        """Whether the last iteration of ``trace`` meets this rule (e.g. another run's trace)."""
        if not trace:
            return False
        if self.kind == "shape":
            return self._shape_reason(trace[-1]) is not None
        previous = trace[-2].objective if len(trace) > 1 else None
        return self._objective_reason(previous, trace[-1]) is not None

    def accepts_stall(self, problem, x, g) -> bool:
        """Whether a run that cannot decrease the objective further has converged."""
        if self.kind == "objective":
            return bool(np.max(np.abs(g), initial=0.0) <= 10.0 * self.gtol)
        return bool(problem.predicted_change(x, g) <= self.shape_tol)


def _rms(diff: np.ndarray) -> float:
    """Per-vertex RMS of a displacement ``(k, d)`` (or of a flat vector of points)."""
    diff = np.asarray(diff, dtype=float)
    n_points = diff.shape[0] if diff.ndim > 1 else diff.size
    return float(np.sqrt((diff * diff).sum() / max(n_points, 1)))
