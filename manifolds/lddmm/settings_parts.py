"""The registration settings by concern: kernel, control points, flow, optimiser, stopping.

Each part is a small frozen dataclass that validates its own fields when it is built
and writes its defaults once (the optimiser's and the stopping rule's come from
:class:`~manifolds.numerics.solvers.SolverOptions` and
:class:`~manifolds.numerics.solvers.StoppingRule`). :class:`RegistrationSettings`
is made of them: its flat fields (``RegistrationSettings(sigma=10, max_iter=50)``, the
form the study, the CLI and the saved results use) are the parts' fields, validated by
the parts, and ``settings.kernel_settings``, ``settings.control_point_settings``, ...
give them back grouped; ``RegistrationSettings.from_parts(...)`` builds one from parts.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ManifoldError
from ..kernels.backends import resolve_backend
from ..numerics.integrators import INTEGRATORS, Integrator
from ..numerics.solvers import SOLVERS, SolverOptions, StoppingRule
from ..validation import check_array, check_float, check_int

__all__ = [
    "KernelSettings",
    "ControlPointSettings",
    "FlowSettings",
    "OptimizerSettings",
    "StoppingSettings",
    "PARTS",
    "POLICIES",
    "STOPPING_RULES",
]

#: ``"objective"``: the relative decrease of the objective and the largest gradient
#: entry (``ftol``, ``gtol``); ``"shape"``: the change of the deformed template and
#: the gradient's predicted change in the shapes' unit (``shape_tol``).
STOPPING_RULES = ("objective", "shape")
POLICIES = ("auto", "dense", "grid", "finegrid", "vertices")
_BACKENDS = ("auto", "numpy", "numba")
_SOLVER = SolverOptions()
_RULE = StoppingRule()


def _choice(owner: str, value, choices, name: str) -> str:
    if not isinstance(value, str) or value.lower() not in choices:
        raise ManifoldError(f"{owner}: {name}: expected one of {list(choices)}, got {value!r}")
    return value.lower()


def _flag(owner: str, value, name: str) -> bool:
    if not isinstance(value, bool | np.bool_):
        raise ManifoldError(f"{owner}: {name}: expected True or False, got {value!r}")
    return bool(value)


class _Part:
    """Shared helpers of the parts."""

    def _put(self, name: str, value) -> None:
        object.__setattr__(self, name, value)

    @property
    def _owner(self) -> str:
        return type(self).__name__

    def replace(self, **changes):
        """A copy with ``changes``, validated."""
        return dataclasses.replace(self, **changes)


@dataclass(frozen=True)
class KernelSettings(_Part):
    """The Gaussian kernel ``exp(-|x - y|^2 / sigma^2)``: its width and the backend of its sums."""

    sigma: float
    kernel_backend: str = "auto"

    def __post_init__(self):
        self._put("sigma", check_float(self.sigma, f"{self._owner}: sigma", 0.0, strict=True))
        self._put("kernel_backend", _choice(self._owner, self.kernel_backend, _BACKENDS,
                                            "kernel_backend"))  # fmt: skip

    def resolved_backend(self) -> str:
        """The backend that runs: ``"auto"`` resolved on this machine."""
        return resolve_backend(self.kernel_backend, f"{self._owner}: kernel_backend")


@dataclass(frozen=True)
class ControlPointSettings(_Part):
    """Where the momenta live (:mod:`manifolds.lddmm.control_points`) and whether they move."""

    control_points: Any = "auto"
    control_point_spacing: float | None = None
    control_point_indices: tuple | None = None
    optimize_control_points: bool = False
    control_point_scale: float | None = None
    auto_threshold: int = 1000
    max_control_points: int = 20_000

    def __post_init__(self):
        owner = self._owner
        self._put("control_points", self._policy(self.control_points))
        self._put("optimize_control_points",
                  _flag(owner, self.optimize_control_points, "optimize_control_points"))  # fmt: skip
        for key in ("control_point_spacing", "control_point_scale"):  # optional, > 0
            if getattr(self, key) is not None:
                self._put(key, check_float(getattr(self, key), f"{owner}: {key}", 0.0, strict=True))
        if self.control_point_indices is not None:
            self._put("control_point_indices", self._indices(self.control_point_indices))
        self._put("auto_threshold", check_int(self.auto_threshold, f"{owner}: auto_threshold", 0))
        self._put("max_control_points",
                  check_int(self.max_control_points, f"{owner}: max_control_points", 1))  # fmt: skip

    def _policy(self, policy):
        if isinstance(policy, str):
            return _choice(self._owner, policy, POLICIES, "control_points")
        arr = check_array(policy, (), f"{self._owner}: control_points")
        if arr.ndim != 2 or arr.shape[1] not in (2, 3) or arr.shape[0] < 1:
            raise ManifoldError(
                f"{self._owner}: control_points: expected a policy name among "
                f"{list(POLICIES)} or an array of shape (n_cp, 2 or 3), got shape {arr.shape}"
            )
        return tuple(tuple(float(v) for v in row) for row in arr)

    def _indices(self, indices) -> tuple:
        field_name = f"{self._owner}: control_point_indices"
        if self.control_points != "vertices":
            raise ManifoldError(
                f"{field_name}: given with the control-point policy "
                f"{self.control_points if isinstance(self.control_points, str) else 'array'!r}; "
                "vertex indices belong to the 'vertices' policy"
            )
        arr = np.asarray(indices)
        if arr.ndim != 1 or arr.size == 0 or not np.issubdtype(arr.dtype, np.integer):
            raise ManifoldError(
                f"{field_name}: expected a non-empty sequence of integers, got "
                f"{arr.dtype} array of shape {arr.shape}"
            )
        if arr.min() < 0 or np.unique(arr).size != arr.size:
            raise ManifoldError(
                f"{field_name}: expected distinct non-negative vertex indices, got "
                f"min {int(arr.min())} and {arr.size - np.unique(arr).size} repeated"
            )
        return tuple(int(i) for i in arr)


@dataclass(frozen=True)
class FlowSettings(_Part):
    """The time integration of the flow: the integrator (None: the flow model's default)
    and the number of steps over ``[0, 1]``."""

    integrator: str | None = None
    n_steps: int = 10

    def __post_init__(self):
        if self.integrator is not None:
            integ = (
                self.integrator.name if isinstance(self.integrator, Integrator) else self.integrator
            )
            self._put("integrator", _choice(self._owner, integ, tuple(INTEGRATORS), "integrator"))
        self._put("n_steps", check_int(self.n_steps, f"{self._owner}: n_steps", 1))


@dataclass(frozen=True)
class OptimizerSettings(_Part):
    """The solver, its variables (the preconditioner, the joint metric of optimised
    control points) and its options (:class:`~manifolds.numerics.solvers.SolverOptions`)."""

    solver: str = "lbfgsb"
    precondition: bool = True
    rel_ridge: float = 1e-2
    joint_metric: bool = True
    max_corrections: int = _SOLVER.max_corrections
    max_line_search: int = _SOLVER.max_line_search
    max_inner: int = _SOLVER.max_inner
    refresh_every: int = _SOLVER.refresh_every
    blas_threads: int | None = _SOLVER.blas_threads

    def __post_init__(self):
        owner = self._owner
        self._put("solver", _choice(owner, self.solver, tuple(SOLVERS), "solver"))
        for flag in ("precondition", "joint_metric"):
            self._put(flag, _flag(owner, getattr(self, flag), flag))
        self._put("rel_ridge", check_float(self.rel_ridge, f"{owner}: rel_ridge", 0.0))
        for key, value in dataclasses.asdict(self.solver_options()).items():  # validated there
            self._put(key, value)

    def solver_options(self) -> SolverOptions:
        """The options the solver takes."""
        return SolverOptions(**{f: getattr(self, f) for f in SolverOptions.__dataclass_fields__})


@dataclass(frozen=True)
class StoppingSettings(_Part):
    """When a registration has converged (:class:`~manifolds.numerics.solvers.StoppingRule`)."""

    stopping: str = _RULE.kind
    shape_tol: float = _RULE.shape_tol
    ftol: float = _RULE.ftol
    gtol: float = _RULE.gtol
    max_iter: int = _RULE.max_iter

    def __post_init__(self):
        owner = self._owner
        self._put("stopping", _choice(owner, self.stopping, STOPPING_RULES, "stopping"))
        for key in ("shape_tol", "ftol", "gtol"):
            self._put(key, check_float(getattr(self, key), f"{owner}: {key}", 0.0))
        self._put("max_iter", check_int(self.max_iter, f"{owner}: max_iter", 1))

    def rule(self) -> StoppingRule:
        """A new rule (a rule records its run)."""
        return StoppingRule(self.stopping, self.ftol, self.gtol, self.shape_tol, self.max_iter)


#: The parts of :class:`~manifolds.lddmm.RegistrationSettings`, by the name of their property.
PARTS = {
    "kernel_settings": KernelSettings,
    "control_point_settings": ControlPointSettings,
    "flow_settings": FlowSettings,
    "optimizer_settings": OptimizerSettings,
    "stopping_settings": StoppingSettings,
}


def field_default(part: type, name: str):
    """The default of the field ``name`` of ``part`` (written there once)."""
    return part.__dataclass_fields__[name].default
