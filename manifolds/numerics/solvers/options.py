"""What a solver needs besides its problem and stopping rule: one small, validated object.

:class:`SolverOptions` holds the knobs of the library's solvers and their defaults
(written here only: :class:`~manifolds.lddmm.RegistrationSettings` takes its
defaults from this class). A solver reads the fields it uses and ignores the others;
:meth:`SolverOptions.in_effect` names the fields a given solver reads, so that a
settings key can leave out the others.
"""

from __future__ import annotations

from dataclasses import dataclass

from ...validation import check_int

__all__ = ["SolverOptions"]

#: Fields each solver reads (``refresh_every`` only on problems whose metric is refreshed).
_READS = {
    "lbfgsb": ("max_corrections", "max_line_search", "refresh_every", "blas_threads"),
    "gauss-newton": ("max_inner", "blas_threads"),
}


#: The smallest value of each field.
_MINIMA = {"max_corrections": 1, "max_line_search": 1, "max_inner": 1, "refresh_every": 0,
           "blas_threads": 1}  # fmt: skip


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
        for name, minimum in _MINIMA.items():
            value = getattr(self, name)
            if value is not None or name != "blas_threads":  # blas_threads may be None
                put(self, name, check_int(value, f"SolverOptions: {name}", minimum))

    @staticmethod
    def in_effect(solver: str) -> tuple[str, ...]:
        """The fields the solver named ``solver`` reads."""
        return _READS.get(solver, tuple(SolverOptions.__dataclass_fields__))
