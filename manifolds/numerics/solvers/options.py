"""What a solver needs besides its problem and stopping rule: one small, validated object.

:class:`SolverOptions` holds the knobs of the library's solvers and their defaults
(written here only: :class:`~manifolds.lddmm.RegistrationSettings` takes its
defaults from this class). A solver reads the fields it uses and ignores the others;
:meth:`SolverOptions.in_effect` names the fields a given solver reads, so that a
settings key can leave out the others.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["SolverOptions"]

#: Fields each solver reads (``refresh_every`` only on problems whose metric is refreshed).
_READS = {
    "lbfgsb": ("max_corrections", "max_line_search", "refresh_every", "blas_threads"),
    "gauss-newton": ("max_inner", "blas_threads"),
}


def _positive_int(value, name: str, minimum: int) -> int:
    if isinstance(value, bool) or int(value) != value or int(value) < minimum:
        raise ValueError(f"SolverOptions: {name}: expected an integer >= {minimum}, got {value!r}")
    return int(value)


@dataclass(frozen=True)
class SolverOptions:
    """Options of the registration solvers.

    Attributes
    ----------
    max_corrections : int
        Memory of the quasi-Newton solvers (correction pairs).
    max_line_search : int
        Function evaluations per line search.
    max_inner : int
        Inner (conjugate-gradient) iterations per step of the Newton-type solvers.
    refresh_every : int
        Restart a problem whose metric depends on the iterate (``problem.refreshable``)
        in refreshed variables every this many iterations (0: never).
    blas_threads : int or None
        BLAS threads during the run (None keeps the process setting).
    """

    max_corrections: int = 100
    max_line_search: int = 30
    max_inner: int = 50
    refresh_every: int = 20
    blas_threads: int | None = 1

    def __post_init__(self):
        put = object.__setattr__
        for name in ("max_corrections", "max_line_search", "max_inner"):
            put(self, name, _positive_int(getattr(self, name), name, 1))
        put(self, "refresh_every", _positive_int(self.refresh_every, "refresh_every", 0))
        if self.blas_threads is not None:
            put(self, "blas_threads", _positive_int(self.blas_threads, "blas_threads", 1))

    @staticmethod
    def in_effect(solver: str) -> tuple[str, ...]:
        """The fields the solver named ``solver`` reads."""
        return _READS.get(solver, tuple(SolverOptions.__dataclass_fields__))
