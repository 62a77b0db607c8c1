"""The LDDMM landmark space and everything it is made of (paper, Section 2.1).

- :mod:`.landmark_space`: :class:`KernelLandmarkSpace`, what the LDDMM and SVF spaces
  share (control points, registration cache, log, metric, sampling);
- :mod:`.space`: :class:`LDDMMLandmarks`, the connection (``exp`` = Hamiltonian
  shooting, ``log`` = registration, inverse consistency);
- :mod:`.settings`: :class:`RegistrationSettings`, every setting of a registration
  in one frozen object (its stable ``key`` names caches and result folders);
- :mod:`.registration`: the registration objective (eq. 3), its exact gradient and
  the driver; :mod:`.registration_problem`: the problem as solvers see it;
  :mod:`.registration_result`: :class:`RegistrationResult`, what a registration returns;
  :mod:`.preconditioner`: the optimiser's change of variables;
- :mod:`.hamiltonian_shooting`: Hamiltonian shooting of control points and momenta and
  its adjoint (:mod:`manifolds.numerics.shooting` is another thing: geodesic shooting
  for the ``log`` of metric-field spaces);
- :mod:`.kernels`: Gaussian kernel sums; the kernel object chooses its backend
  (numpy reference or the compiled :mod:`.kernels_numba`);
- :mod:`.control_points`: control-point policies (dense, grid, auto);
- :mod:`.tangent`: :class:`LandmarkTangent`, momenta with their control points
  (the tangents of a space that optimises its control points);
- :mod:`.shapes`: smooth random shapes (the space's ``random_point``);
- :mod:`.svf_space`: :class:`SVFLandmarks`, the stationary-velocity-field landmark
  space (``exp`` = flow of a stationary kernel field, ``log`` = SVF registration),
  built on :mod:`.stationary_flow` (flows and their adjoint) and
  :mod:`.svf_registration`; :mod:`.svf_group`: the group symmetry and the SVF
  pole ladder on deformations given as flows.
"""

from .control_points import (
    POLICIES,
    grid_control_points,
    resolve_control_points,
    vertex_control_points,
)
from .flow_models import FlowModel
from .hamiltonian_shooting import (
    HamiltonianFlow,
    ShootingResult,
    hamiltonian,
    shoot,
    shooting_jvp,
    shooting_vjp,
)
from .hamiltonian_system import (
    CompiledHamiltonianSystem,
    HamiltonianSystem,
    hamiltonian_system,
    register_system,
)
from .kernels import GaussianKernel, numba_available
from .landmark_space import KernelLandmarkSpace
from .registration import (
    build_registration_problem,
    register,
    registration_objective,
)
from .registration_cache import RegistrationCache
from .registration_problem import RegistrationProblem
from .registration_result import RegistrationResult
from .settings import RegistrationSettings
from .settings_parts import (
    ControlPointSettings,
    FlowSettings,
    KernelSettings,
    OptimizerSettings,
    StoppingSettings,
)
from .space import LDDMMLandmarks
from .stationary_flow import (
    FlowResult,
    StationaryFlow,
    StationaryKernelFlow,
    integrate_stationary,
    kernel_flow,
    kernel_flow_jvp,
    kernel_flow_vjp,
    kernel_velocity,
)
from .svf_group import (
    Composition,
    compose,
    conjugate,
    group_pole_ladder,
    group_symmetry,
    svf_pole_ladder,
)
from .svf_registration import register_svf, svf_objective
from .svf_space import SVFLandmarks
from .tangent import LandmarkTangent

__all__ = [
    "KernelLandmarkSpace",
    "LDDMMLandmarks",
    "LandmarkTangent",
    "GaussianKernel",
    "numba_available",
    "RegistrationResult",
    "RegistrationSettings",
    "KernelSettings",
    "ControlPointSettings",
    "FlowSettings",
    "OptimizerSettings",
    "StoppingSettings",
    "RegistrationProblem",
    "build_registration_problem",
    "RegistrationCache",
    "register",
    "registration_objective",
    "FlowModel",
    "HamiltonianFlow",
    "StationaryKernelFlow",
    "ShootingResult",
    "HamiltonianSystem",
    "CompiledHamiltonianSystem",
    "hamiltonian_system",
    "register_system",
    "hamiltonian",
    "shoot",
    "shooting_vjp",
    "shooting_jvp",
    "POLICIES",
    "grid_control_points",
    "vertex_control_points",
    "resolve_control_points",
    "SVFLandmarks",
    "StationaryFlow",
    "FlowResult",
    "kernel_velocity",
    "integrate_stationary",
    "kernel_flow",
    "kernel_flow_vjp",
    "kernel_flow_jvp",
    "register_svf",
    "svf_objective",
    "Composition",
    "compose",
    "conjugate",
    "group_symmetry",
    "svf_pole_ladder",
    "group_pole_ladder",
]
