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

import numpy as np

__all__ = ["StoppingRule"]


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
        self.shape_changes: list = []

    @classmethod
    def from_settings(cls, settings) -> StoppingRule:
        """The rule of a :class:`~manifolds.lddmm.RegistrationSettings`."""
        return cls(
            settings.stopping, settings.ftol, settings.gtol, settings.shape_tol, settings.max_iter
        )

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
        self._previous_shape = (
            np.array(problem.shape(x0), dtype=float) if self.kind == "shape" else None
        )
        self.shape_changes = []

    def met(self, problem, x, f, g) -> str | None:
        """After an iteration to ``x`` (objective ``f``, gradient ``g``): the reason to
        stop as converged, or None."""
        f = float(f)
        previous, self._previous_f = self._previous_f, f
        if self.kind == "objective":
            if previous is not None:
                rel = (previous - f) / max(abs(previous), abs(f), 1.0)
                if rel <= self.ftol:
                    return f"relative decrease {rel:.3g} <= ftol"
            if np.max(np.abs(g), initial=0.0) <= self.gtol:
                return "largest gradient entry <= gtol"
            return None
        shape = np.array(problem.shape(x), dtype=float)
        change = _rms(shape - self._previous_shape)
        self._previous_shape = shape
        self.shape_changes.append(change)
        if change > self.shape_tol:
            return None
        predicted = float(problem.predicted_change(x, g))
        if predicted <= self.shape_tol:
            return f"shape change {change:.3g} and predicted change {predicted:.3g} <= shape_tol"
        return None

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
