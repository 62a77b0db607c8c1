"""All the settings of a kernel-landmark registration in one frozen, validated object.

:class:`RegistrationSettings` holds everything a registration's result depends on
besides its inputs (template, target, ``alpha``): kernel width and backend,
control-point policy and whether they are optimised, integrator and time steps,
solver, stopping rule, tolerances and iteration limit. :func:`manifolds.lddmm.register`
(with either flow model), the landmark spaces and the study take it.

Its :meth:`~RegistrationSettings.key` is a stable hash of the fields (with the
kernel backend resolved, since the compiled kernels' results differ from numpy's
in the last bits): the study keys its caches and result folders with it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass
from importlib import metadata
from typing import Any

import numpy as np

from ..errors import ManifoldError
from ..kernels.backends import resolve_backend
from ..numerics.integrators import INTEGRATORS, Integrator
from ..numerics.solvers import SOLVERS, SolverOptions, StoppingRule
from ..validation import check_array, check_float, check_int
from .control_points import farthest_point_indices, policy_spacing, resolve_control_points
from .kernels import GaussianKernel

__all__ = ["RegistrationSettings", "STOPPING_RULES", "SETTINGS_SCHEMA"]

#: Version of the settings' serialisation; part of :meth:`RegistrationSettings.key`.
SETTINGS_SCHEMA = 2
#: ``"objective"``: the relative decrease of the objective and the largest gradient
#: entry (``ftol``, ``gtol``); ``"shape"``: the change of the deformed template and
#: the gradient's predicted change in the shapes' unit (``shape_tol``).
STOPPING_RULES = ("objective", "shape")
_POLICIES = ("auto", "dense", "grid", "finegrid", "vertices")
_BACKENDS = ("auto", "numpy", "numba")
#: The defaults of the solvers' options and of the stopping rule, written once, there.
_SOLVER = SolverOptions()
_RULE = StoppingRule()
#: Policies whose control points are spaced by ``control_point_spacing`` ("auto" may
#: choose a grid).
_SPACED_POLICIES = ("auto", "grid", "finegrid", "vertices")


def library_version() -> str:
    """The installed version of the library (part of :meth:`RegistrationSettings.key`)."""
    try:
        return metadata.version("symladders")
    except metadata.PackageNotFoundError:  # pragma: no cover - run from a source tree
        return "unknown"


def _check_choice(value, choices, name: str) -> str:
    if not isinstance(value, str) or value.lower() not in choices:
        raise ManifoldError(
            f"RegistrationSettings: {name}: expected one of {list(choices)}, got {value!r}"
        )
    return value.lower()


@dataclass(frozen=True)
class RegistrationSettings:
    """Settings of a registration (paper, eq. 3) of kernel-landmark shapes.

    Attributes
    ----------
    sigma : float
        Width of the Gaussian kernel ``exp(-|x - y|^2 / sigma^2)``, in the shapes' unit.
    control_points : {"auto", "dense", "grid", "finegrid", "vertices"} or array ``(n_cp, d)``
        Control-point policy (:mod:`manifolds.lddmm.control_points`); an array is
        stored as a tuple of tuples so that the settings stay hashable.
    control_point_spacing : float or None
        Spacing of the ``"grid"``, ``"finegrid"`` and ``"vertices"`` policies, in the
        shapes' unit; None: the policy's default multiple of ``sigma`` (1, 1/2 and
        :data:`~manifolds.lddmm.control_points.VERTEX_SPACING`).
    control_point_indices : tuple of int or None
        With the ``"vertices"`` policy: the indices of the vertices that carry the
        momenta, the same for every shape (landmarks in correspondence), so that the
        control points are material points that move with the shapes. None: a
        farthest-point sample of each template itself.
        :meth:`fix_control_point_indices` draws them from a reference shape.
    optimize_control_points : bool
        Minimise eq. (3) over the control points and the momenta jointly.
    control_point_scale : float or None
        The optimiser's variable for a control point is ``c / scale`` (default ``sigma``).
    integrator : {"euler", "rk2", "rk4"} or None
        Time integrator of the flow; None lets the space choose its default
        (Euler for LDDMM, RK4 for SVF).
    n_steps : int
        Time steps of the flow over ``[0, 1]``.
    solver : str
        Name of the optimiser (:data:`manifolds.numerics.solvers.SOLVERS`).
    stopping : {"objective", "shape"}
        Stopping rule (:class:`manifolds.numerics.solvers.StoppingRule`).
    shape_tol : float
        Tolerance of the ``"shape"`` rule: per-vertex RMS change of the deformed
        template, in the shapes' unit.
    ftol, gtol : float
        Tolerances of the ``"objective"`` rule: relative decrease of the
        (normalised) objective and largest entry of its gradient.
    max_iter : int
        Iteration limit of the optimiser.
    max_corrections : int
        Memory of the quasi-Newton solvers (correction pairs).
    max_line_search : int
        Function evaluations per line search.
    max_inner : int
        Inner (conjugate-gradient) iterations per step of the Newton-type solvers.
    joint_metric : bool
        With optimised control points, whiten ``(c, mu)`` together with the joint
        linearised Gauss-Newton matrix (:mod:`manifolds.lddmm.joint_preconditioner`);
        False: the momenta's preconditioner and ``c / control_point_scale``.
    refresh_every : int
        Rebuild the joint preconditioner every this many iterations (0: never).
    precondition : bool
        Optimise preconditioned momenta (:mod:`manifolds.lddmm.preconditioner`).
    rel_ridge : float
        Ridge of the preconditioner, relative to the mean of its diagonal.
    kernel_backend : {"auto", "numpy", "numba"}
        Kernel sums; ``"auto"`` is numba when it imports.
    auto_threshold : int
        Vertex count above which the ``"auto"`` policy uses a grid.
    max_control_points : int
        Budget of a grid of control points (a ``sigma`` in the wrong unit is refused).
    blas_threads : int or None
        BLAS threads during the optimisation (None keeps the process setting).
    """

    sigma: float
    control_points: Any = "auto"
    control_point_spacing: float | None = None
    control_point_indices: tuple | None = None
    optimize_control_points: bool = False
    control_point_scale: float | None = None
    integrator: str | None = None
    n_steps: int = 10
    solver: str = "lbfgsb"
    stopping: str = "objective"
    shape_tol: float = _RULE.shape_tol
    ftol: float = _RULE.ftol
    gtol: float = _RULE.gtol
    max_iter: int = _RULE.max_iter
    max_corrections: int = _SOLVER.max_corrections
    max_line_search: int = _SOLVER.max_line_search
    max_inner: int = _SOLVER.max_inner
    joint_metric: bool = True
    refresh_every: int = _SOLVER.refresh_every
    precondition: bool = True
    rel_ridge: float = 1e-2
    kernel_backend: str = "auto"
    auto_threshold: int = 1000
    max_control_points: int = 20_000
    blas_threads: int | None = _SOLVER.blas_threads

    def __post_init__(self):
        name = "RegistrationSettings"
        put = object.__setattr__
        put(self, "sigma", check_float(self.sigma, f"{name}: sigma", minimum=0.0, strict=True))
        put(self, "control_points", self._check_policy(self.control_points))
        for flag in ("optimize_control_points", "precondition", "joint_metric"):
            value = getattr(self, flag)
            if not isinstance(value, bool | np.bool_):
                raise ManifoldError(f"{name}: {flag}: expected True or False, got {value!r}")
            put(self, flag, bool(value))
        for key in ("control_point_spacing", "control_point_scale"):  # optional, > 0
            if getattr(self, key) is not None:
                put(self, key, check_float(getattr(self, key), f"{name}: {key}", 0.0, strict=True))
        if self.control_point_indices is not None:
            put(self, "control_point_indices", self._check_indices(self.control_point_indices))
        if self.integrator is not None:
            integ = self.integrator
            if isinstance(integ, Integrator):
                integ = integ.name
            put(self, "integrator", _check_choice(integ, tuple(INTEGRATORS), "integrator"))
        put(self, "solver", _check_choice(self.solver, tuple(SOLVERS), "solver"))
        put(self, "stopping", _check_choice(self.stopping, STOPPING_RULES, "stopping"))
        put(self, "kernel_backend", _check_choice(self.kernel_backend, _BACKENDS, "kernel_backend"))
        for key in ("n_steps", "max_iter", "max_corrections", "max_line_search", "max_inner"):
            put(self, key, check_int(getattr(self, key), f"{name}: {key}", minimum=1))
        for key in ("auto_threshold", "refresh_every"):
            put(self, key, check_int(getattr(self, key), f"{name}: {key}", minimum=0))
        put(
            self,
            "max_control_points",
            check_int(self.max_control_points, f"{name}: max_control_points", minimum=1),
        )
        for key in ("shape_tol", "ftol", "gtol", "rel_ridge"):
            put(self, key, check_float(getattr(self, key), f"{name}: {key}", minimum=0.0))
        if self.blas_threads is not None:
            put(self, "blas_threads", check_int(self.blas_threads, f"{name}: blas_threads", 1))

    @staticmethod
    def _check_policy(policy):
        if isinstance(policy, str):
            return _check_choice(policy, _POLICIES, "control_points")
        arr = check_array(policy, (), "RegistrationSettings: control_points")
        if arr.ndim != 2 or arr.shape[1] not in (2, 3) or arr.shape[0] < 1:
            raise ManifoldError(
                "RegistrationSettings: control_points: expected a policy name among "
                f"{list(_POLICIES)} or an array of shape (n_cp, 2 or 3), got shape {arr.shape}"
            )
        return tuple(tuple(float(v) for v in row) for row in arr)

    def _check_indices(self, indices) -> tuple:
        field_name = "RegistrationSettings: control_point_indices"
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

    # ------------------------------------------------------------ derived
    @property
    def control_points_policy(self):
        """The policy name, or the user's control points as an array ``(n_cp, d)``."""
        if isinstance(self.control_points, str):
            return self.control_points
        return np.array(self.control_points, dtype=float)

    @property
    def spacing(self) -> float | None:
        """Spacing between control points of the policy (in the shapes' unit), or None
        for the policies without one (:func:`~manifolds.lddmm.control_points.policy_spacing`)."""
        return policy_spacing(self.control_points_policy, self.sigma, self.control_point_spacing)

    def resolve_control_points(self, template: np.ndarray) -> np.ndarray:
        """The control points of ``template`` ``(k, d)`` under these settings, ``(n_cp, d)``."""
        return resolve_control_points(
            template,
            self.control_points_policy,
            self.sigma,
            self.auto_threshold,
            self.max_control_points,
            self.control_point_spacing,
            self.control_point_indices,
        )

    def fix_control_point_indices(self, reference: np.ndarray) -> RegistrationSettings:
        """These settings with the ``"vertices"`` sample drawn once, on ``reference``.

        The farthest-point sample of ``reference`` ``(k, d)`` at the policy's spacing
        becomes :attr:`control_point_indices`: every shape in correspondence with
        ``reference`` then carries its momenta at the same vertices. Settings of another
        policy, or whose indices are already fixed, are returned unchanged.
        """
        if self.control_points != "vertices" or self.control_point_indices is not None:
            return self
        indices = farthest_point_indices(np.asarray(reference, dtype=float), self.spacing)
        return self.replace(control_point_indices=tuple(int(i) for i in indices))

    def resolved_backend(self) -> str:
        """The kernel backend that runs: ``"auto"`` resolved on this machine."""
        return resolve_backend(self.kernel_backend, "RegistrationSettings: kernel_backend")

    def make_kernel(self, block_size: int | None = None):
        """The :class:`~manifolds.lddmm.GaussianKernel` of these settings."""
        return GaussianKernel(self.sigma, backend=self.kernel_backend, block_size=block_size)

    def replace(self, **changes) -> RegistrationSettings:
        """A copy with ``changes`` (validated); unknown names raise a :class:`ManifoldError`."""
        unknown = sorted(set(changes) - {f.name for f in dataclasses.fields(self)})
        if unknown:
            raise ManifoldError(
                f"RegistrationSettings: unknown setting(s) {unknown}; expected names among "
                f"{sorted(f.name for f in dataclasses.fields(self))}"
            )
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict:
        """Plain JSON-ready fields (control points as nested lists)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        if not isinstance(self.control_points, str):
            out["control_points"] = [list(row) for row in self.control_points]
        if self.control_point_indices is not None:
            out["control_point_indices"] = list(self.control_point_indices)
        return out

    @classmethod
    def from_dict(cls, data: dict) -> RegistrationSettings:
        """Settings from :meth:`as_dict`'s output (unknown keys raise)."""
        if not isinstance(data, dict) or "sigma" not in data:
            raise ManifoldError(
                f"RegistrationSettings.from_dict: expected a dict with at least 'sigma', got "
                f"{type(data).__name__}"
            )
        base = cls(sigma=data["sigma"])
        return base.replace(**{k: v for k, v in data.items() if k != "sigma"})

    def solver_options(self) -> SolverOptions:
        """The options the solver takes (:class:`~manifolds.numerics.solvers.SolverOptions`)."""
        return SolverOptions(**{f: getattr(self, f) for f in SolverOptions.__dataclass_fields__})

    def stopping_rule(self) -> StoppingRule:
        """The stopping rule of these settings (a new one: a rule records its run)."""
        return StoppingRule(self.stopping, self.ftol, self.gtol, self.shape_tol, self.max_iter)

    def in_effect(self) -> tuple[str, ...]:
        """The fields that change a registration's result under these settings.

        Left out: the tolerances of the stopping rule not in use (``shape_tol`` under
        ``"objective"``, ``ftol`` and ``gtol`` under ``"shape"``), the options of the
        solvers not in use, the joint metric's fields without optimised control points
        and a preconditioner, ``rel_ridge`` without a preconditioner, ``auto_threshold``
        but for the ``"auto"`` policy, the spacing and vertex indices of the policies
        that do not read them, and ``max_control_points`` (a
        budget that refuses settings, never changes a result). ``blas_threads`` stays:
        threaded BLAS products may sum in another order (the last bits).
        """
        out = ["sigma", "control_points", "optimize_control_points", "integrator", "n_steps",
               "solver", "stopping", "max_iter", "precondition", "kernel_backend"]  # fmt: skip
        out += ["shape_tol"] if self.stopping == "shape" else ["ftol", "gtol"]
        policy = self.control_points if isinstance(self.control_points, str) else "array"
        if policy in _SPACED_POLICIES:
            out.append("control_point_spacing")
        if policy == "vertices":
            out.append("control_point_indices")
        if policy == "auto":
            out.append("auto_threshold")
        if self.precondition:
            out.append("rel_ridge")
        solver_fields = set(SolverOptions.in_effect(self.solver))
        joint = self.optimize_control_points and self.precondition and self.joint_metric
        if not joint:
            solver_fields.discard("refresh_every")
        if self.optimize_control_points:
            out.append("control_point_scale")
            if self.precondition:
                out.append("joint_metric")
        out += sorted(solver_fields)
        return tuple(out)

    def key(self) -> str:
        """Stable hash (hex) of what changes a result: :meth:`in_effect`'s fields, the
        kernel backend that runs (``"auto"`` resolved: the compiled kernels' results
        differ from numpy's in the last bits) and the library's version.

        Two settings objects with the same key give the same registrations to the
        last bit on the same machine.
        """
        full = self.as_dict()
        payload = {name: full[name] for name in self.in_effect()}
        payload["kernel_backend"] = self.resolved_backend()
        payload["schema"] = SETTINGS_SCHEMA
        payload["library_version"] = library_version()
        text = json.dumps(payload, sort_keys=True, separators=(",", ":"), default=repr)
        return hashlib.sha256(text.encode()).hexdigest()[:20]
