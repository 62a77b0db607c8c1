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
import functools
import hashlib
import json
from dataclasses import dataclass
from importlib import metadata
from typing import Any

import numpy as np

from ..errors import ManifoldError
from ..numerics.solvers import SolverOptions, StoppingRule
from .control_points import farthest_point_indices, policy_spacing, resolve_control_points
from .kernels import GaussianKernel
from .settings_parts import (
    PARTS,
    STOPPING_RULES,
    ControlPointSettings,
    FlowSettings,
    KernelSettings,
    OptimizerSettings,
    StoppingSettings,
    field_default,
)

__all__ = ["RegistrationSettings", "STOPPING_RULES", "SETTINGS_SCHEMA"]

#: Version of the settings' serialisation; part of :meth:`RegistrationSettings.key`.
SETTINGS_SCHEMA = 2
#: Policies whose control points are spaced by ``control_point_spacing`` ("auto" may
#: choose a grid).
_SPACED_POLICIES = ("auto", "grid", "finegrid", "vertices")


@functools.cache
def library_version() -> str:
    """The installed version of the library (part of :meth:`RegistrationSettings.key`)."""
    try:
        return metadata.version("symladders")
    except metadata.PackageNotFoundError:  # pragma: no cover - run from a source tree
        return "unknown"


@dataclass(frozen=True)
class RegistrationSettings:
    """Settings of a registration (paper, eq. 3) of kernel-landmark shapes.

    Made of five parts, each validating its own fields and holding their defaults
    (:mod:`manifolds.lddmm.settings_parts`): :attr:`kernel_settings` (``sigma``,
    ``kernel_backend``), :attr:`control_point_settings` (the ``control_point*`` fields,
    ``optimize_control_points``, ``auto_threshold``, ``max_control_points``),
    :attr:`flow_settings` (``integrator``, ``n_steps``), :attr:`optimizer_settings`
    (``solver``, ``precondition``, ``rel_ridge``, ``joint_metric`` and the solver's
    options) and :attr:`stopping_settings` (``stopping``, the tolerances, ``max_iter``).
    The flat fields below are those parts' fields; :meth:`from_parts` builds settings
    from parts.

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
    control_points: Any = field_default(ControlPointSettings, "control_points")
    control_point_spacing: float | None = field_default(
        ControlPointSettings, "control_point_spacing"
    )
    control_point_indices: tuple | None = field_default(
        ControlPointSettings, "control_point_indices"
    )
    optimize_control_points: bool = field_default(ControlPointSettings, "optimize_control_points")
    control_point_scale: float | None = field_default(ControlPointSettings, "control_point_scale")
    integrator: str | None = field_default(FlowSettings, "integrator")
    n_steps: int = field_default(FlowSettings, "n_steps")
    solver: str = field_default(OptimizerSettings, "solver")
    stopping: str = field_default(StoppingSettings, "stopping")
    shape_tol: float = field_default(StoppingSettings, "shape_tol")
    ftol: float = field_default(StoppingSettings, "ftol")
    gtol: float = field_default(StoppingSettings, "gtol")
    max_iter: int = field_default(StoppingSettings, "max_iter")
    max_corrections: int = field_default(OptimizerSettings, "max_corrections")
    max_line_search: int = field_default(OptimizerSettings, "max_line_search")
    max_inner: int = field_default(OptimizerSettings, "max_inner")
    joint_metric: bool = field_default(OptimizerSettings, "joint_metric")
    refresh_every: int = field_default(OptimizerSettings, "refresh_every")
    precondition: bool = field_default(OptimizerSettings, "precondition")
    rel_ridge: float = field_default(OptimizerSettings, "rel_ridge")
    kernel_backend: str = field_default(KernelSettings, "kernel_backend")
    auto_threshold: int = field_default(ControlPointSettings, "auto_threshold")
    max_control_points: int = field_default(ControlPointSettings, "max_control_points")
    blas_threads: int | None = field_default(OptimizerSettings, "blas_threads")

    def __post_init__(self):
        # each part validates its own fields; their normalised values are kept
        for part in PARTS.values():
            built = part(**{f: getattr(self, f) for f in part.__dataclass_fields__})
            for f in part.__dataclass_fields__:
                object.__setattr__(self, f, getattr(built, f))

    # ------------------------------------------------------------ parts
    @property
    def kernel_settings(self) -> KernelSettings:
        """The kernel: ``sigma`` and the backend."""
        return self._part(KernelSettings)

    @property
    def control_point_settings(self) -> ControlPointSettings:
        """The control points: policy, spacing, indices, optimisation, limits."""
        return self._part(ControlPointSettings)

    @property
    def flow_settings(self) -> FlowSettings:
        """The flow's time integration: integrator and steps."""
        return self._part(FlowSettings)

    @property
    def optimizer_settings(self) -> OptimizerSettings:
        """The solver, its variables and its options."""
        return self._part(OptimizerSettings)

    @property
    def stopping_settings(self) -> StoppingSettings:
        """The stopping rule and the iteration limit."""
        return self._part(StoppingSettings)

    def _part(self, part: type):
        return part(**{f: getattr(self, f) for f in part.__dataclass_fields__})

    @classmethod
    def from_parts(
        cls,
        kernel: KernelSettings,
        control_points: ControlPointSettings | None = None,
        flow: FlowSettings | None = None,
        optimizer: OptimizerSettings | None = None,
        stopping: StoppingSettings | None = None,
    ) -> RegistrationSettings:
        """Settings made of their parts (a part left out takes its defaults)."""
        parts = (kernel, control_points or ControlPointSettings(), flow or FlowSettings(),
                 optimizer or OptimizerSettings(), stopping or StoppingSettings())  # fmt: skip
        fields = {}
        for part, expected in zip(parts, PARTS.values()):
            if not isinstance(part, expected):
                raise ManifoldError(
                    f"RegistrationSettings.from_parts: expected a {expected.__name__}, got "
                    f"{type(part).__name__}"
                )
            fields.update(dataclasses.asdict(part))
        return cls(**fields)

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
        return self.kernel_settings.resolved_backend()

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
        return self.optimizer_settings.solver_options()

    def stopping_rule(self) -> StoppingRule:
        """The stopping rule of these settings (a new one: a rule records its run)."""
        return self.stopping_settings.rule()

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
