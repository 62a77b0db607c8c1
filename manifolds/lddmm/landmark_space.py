"""What the LDDMM and SVF landmark spaces share: shapes, control points, kernel, registration cache.

A point is a shape ``T`` of ``k`` landmarks in ``R^d``; a tangent vector at
``T`` is a set of momenta at the control points ``c(T)`` of the control-point
policy (or a :class:`~manifolds.lddmm.LandmarkTangent` carrying its own control
points); ``Log_T(S)`` is a registration of ``T`` onto ``S`` (eq. 3), inexact
for ``alpha > 0``: ``S = Exp_T(Log_T S) + delta`` (eq. 4). The metric is the
RKHS product of the kernel fields (eq. 1).

A subclass provides the deformation model: ``flow_model`` (the
:class:`~manifolds.lddmm.flow_models.FlowModel` the registration of eq. 3 optimises
through, which also sets the default integrator and whether control points can be
optimised), ``exp`` (the deformation of the momenta applied to the shape) and
``flow`` (the same deformation applied to any points).
"""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Callable

import numpy as np

from ..connection import Connection
from ..data_terms import DataTerm
from ..errors import ManifoldError
from ..numerics.integrators import get_integrator
from ..validation import check_array, check_float, check_int, check_n_samples, check_rng
from .control_points import check_vertex_indices
from .flow_models import FlowModel
from .inverse_consistency import inverse_consistency
from .registration import register as register_with_flow
from .registration_cache import RegistrationCache, registration_key
from .registration_result import RegistrationResult
from .settings import RegistrationSettings
from .shapes import random_shape
from .tangent import LandmarkTangent

__all__ = ["KernelLandmarkSpace"]


class KernelLandmarkSpace(Connection):
    """Landmark shapes ``(k, d)`` deformed by Gaussian-kernel fields; ``log`` is a registration.

    Parameters
    ----------
    n_landmarks : int
        Number of landmarks (mesh vertices) ``k``.
    dim : int
        Ambient dimension ``d`` (2 or 3).
    sigma : float, optional
        Width of the Gaussian kernel ``K(x, y) = exp(-|x - y|^2 / sigma^2)``
        (``settings.sigma`` when ``settings`` is given).
    alpha : float
        Regularisation of the registration: ``C = D(phi(T)) + alpha^2 ||v||_H^2``.
    settings : RegistrationSettings, optional
        Every setting of the registrations (kernel, control points, integrator,
        solver, stopping rule). Keyword arguments named after its fields
        (``control_points="grid"``, ``n_steps=20``, ``stopping="shape"``, ...)
        override it; without ``settings`` they build one with ``sigma``. An
        integrator left to None is the flow model's ``default_integrator``.
    cache_size : int, default 16
        Number of registrations kept (LRU) so that ``log``, ``log_with_residual``
        and ``register`` on the same pair register only once.
    block_size : int, optional
        Kernel-matrix entries per block of the numpy kernel backend (memory only).

    Attributes
    ----------
    settings : RegistrationSettings
        The settings in use (integrator resolved).
    n_registrations : int
        Registrations computed (cache hits excluded).
    n_unconverged : int
        Among them, those that stopped before meeting the stopping rule.
    n_iterations : int
        Optimiser iterations of those registrations.
    n_flow_evaluations : int
        Flow passes (forward, adjoint, tangent-linear) of those registrations.
    max_gradient_norm : float
        Largest final gradient (:attr:`RegistrationResult.gradient_norm`) among them.
    """

    is_symmetric = False
    supports_batch = False
    #: The deformation model of the registrations (set by each subclass).
    flow_model: type[FlowModel]

    def __init__(
        self,
        n_landmarks: int,
        dim: int,
        sigma: float | None = None,
        alpha: float | None = None,
        settings: RegistrationSettings | None = None,
        *,
        cache_size: int = 16,
        block_size: int | None = None,
        **overrides,
    ):
        name = type(self).__name__
        settings = self._make_settings(sigma, settings, overrides)
        if settings.optimize_control_points and not self.flow_model.moves_control_points:
            raise ManifoldError(
                f"{name}: optimize_control_points: this space keeps its control points fixed "
                "(only LDDMMLandmarks optimises them)"
            )
        if alpha is None:
            raise ManifoldError(f"{name}: alpha: the regularisation weight is required")
        n_landmarks = check_int(n_landmarks, f"{name}: n_landmarks", minimum=1)
        if isinstance(dim, bool) or dim not in (2, 3):
            raise ManifoldError(f"{name}: dim: expected 2 or 3, got {dim!r}")
        self.alpha = check_float(alpha, f"{name}: alpha", minimum=0.0)
        self.point_shape = (n_landmarks, int(dim))
        policy = settings.control_points_policy
        if not isinstance(policy, str) and policy.shape[1] != dim:
            raise ManifoldError(
                f"{name}: control_points must have shape (n_cp, {dim}), got {policy.shape}"
            )
        if settings.control_point_indices is not None:
            check_vertex_indices(settings.control_point_indices, n_landmarks, f"{name}: ")
        self.settings = settings
        self.kernel = settings.make_kernel(block_size)
        self.integrator = get_integrator(settings.integrator)
        self.cache_size = check_int(cache_size, f"{name}: cache_size", minimum=0)
        self._cache = RegistrationCache(self.cache_size)
        self.n_registrations = 0
        self.n_unconverged = 0
        self.n_iterations = 0
        self.n_flow_evaluations = 0
        self.max_gradient_norm = 0.0

    def _make_settings(self, sigma, settings, overrides) -> RegistrationSettings:
        name = type(self).__name__
        if settings is None:
            if sigma is None:
                raise ManifoldError(f"{name}: sigma: the kernel width is required")
            settings = RegistrationSettings(sigma=sigma)
        elif not isinstance(settings, RegistrationSettings):
            raise TypeError(
                f"{name}: settings: expected RegistrationSettings, got {type(settings).__name__}"
            )
        elif sigma is not None:
            overrides = {"sigma": sigma, **overrides}
        try:
            settings = settings.replace(**overrides)
        except ManifoldError as exc:
            raise ManifoldError(f"{name}: {exc}") from None
        if settings.integrator is None:
            settings = settings.replace(integrator=self.flow_model.default_integrator)
        return settings

    # ------------------------------------------------------------ settings views
    @property
    def sigma(self) -> float:
        """Kernel width."""
        return self.settings.sigma

    @property
    def n_steps(self) -> int:
        """Time steps of the flow."""
        return self.settings.n_steps

    @property
    def control_points_policy(self):
        """Control-point policy name, or the user's control points ``(n_cp, d)``."""
        return self.settings.control_points_policy

    @property
    def optimize_control_points(self) -> bool:
        """Whether ``log`` optimises the control points with the momenta."""
        return self.settings.optimize_control_points

    def __repr__(self) -> str:
        k, d = self.point_shape
        policy = self.control_points_policy
        policy = policy if isinstance(policy, str) else f"array{policy.shape}"
        return (
            f"{self.name}(k={k}, d={d}, sigma={self.sigma:g}, alpha={self.alpha:g}, "
            f"control_points={policy!r}, integrator={self.integrator.name!r}, "
            f"n_steps={self.n_steps}"
            + (", optimize_control_points=True)" if self.optimize_control_points else ")")
        )

    # ------------------------------------------------------------ deformation model
    @abstractmethod
    def flow(self, template, momenta, points, control_points=None) -> np.ndarray:
        """The deformation of ``momenta`` at ``control_points`` (default ``c(template)``)
        applied to ``points`` ``(n, d)``."""

    def _flow_inputs(self, template, momenta, points, control_points):
        """Checked ``(control points, momenta, points)`` of :meth:`flow`."""
        template = self.check_point(template, "template")
        cp = (
            self.control_points(template)
            if control_points is None
            else check_array(control_points, (self.point_shape[1],), f"{self.name}: control_points")
        )
        momenta = self._check_momenta(cp, momenta, "momenta")
        pts = check_array(points, (self.point_shape[1],), f"{self.name}: points")
        return cp, momenta, pts

    # ------------------------------------------------------------ building blocks
    def control_points(self, point) -> np.ndarray:
        """Control points ``c(T)`` of the template ``point``, shape ``(n_cp, d)``."""
        return self.settings.resolve_control_points(self.check_point(point))

    def kernel_matrix(self, control_points) -> np.ndarray:
        """``K(c, c)``, shape ``(n_cp, n_cp)``."""
        return self.kernel.matrix(np.asarray(control_points, dtype=float))

    def kernel_solve(self, control_points, rhs, nugget: float = 0.0) -> np.ndarray:
        """Solve ``K(c, c) X = rhs`` (velocities at the control points back to momenta)."""
        return self.kernel.solve(np.asarray(control_points, dtype=float), rhs, nugget)

    def _check_momenta(self, cp: np.ndarray, momenta, name: str) -> np.ndarray:
        arr = check_array(momenta, (cp.shape[1],), f"{self.name}: {name}")
        if arr.shape != cp.shape:
            raise ManifoldError(
                f"{self.name}: {name}: expected momenta of shape {cp.shape} "
                f"(n_cp, d) at the control points, got {arr.shape}"
            )
        return arr

    def _split_tangent(self, point, tangent, name: str):
        """Control points and momenta of ``tangent`` at ``point`` (a :class:`LandmarkTangent`
        or plain momenta at the policy's control points)."""
        if isinstance(tangent, LandmarkTangent):
            cp = check_array(
                tangent.control_points,
                (self.point_shape[1],),
                f"{self.name}: {name}.control_points",
            )
            return cp, self._check_momenta(cp, tangent.momenta, f"{name}.momenta")
        cp = self.control_points(point)
        return cp, self._check_momenta(cp, tangent, name)

    def _tangent(self, control_points, momenta):
        """``momenta`` as returned by ``log``: plain, or with their control points."""
        momenta = np.array(momenta, dtype=float)
        if self.optimize_control_points:
            return LandmarkTangent(control_points, momenta)
        return momenta

    # ------------------------------------------------------------ registration
    def _check_target(self, target, name: str):
        """A target shape ``(k, d)``, or a :class:`~manifolds.data_terms.DataTerm` as given."""
        if not isinstance(target, DataTerm):
            return self.check_point(target, name)
        n_points = getattr(target, "n_points", self.point_shape[0])
        if n_points != self.point_shape[0]:
            raise ManifoldError(
                f"{self.name}: {name}: the data term reads {n_points} template points, "
                f"the space has {self.point_shape[0]} landmarks"
            )
        return target

    def _warm_start(self, template, initial_momenta):
        """``(control points, initial momenta, start key)`` of a registration from ``template``."""
        cp = self.control_points(template)
        if isinstance(initial_momenta, LandmarkTangent):
            c0, momenta = self._split_tangent(template, initial_momenta, "initial_momenta")
            if self.optimize_control_points:
                return c0, momenta, c0
            if c0.shape != cp.shape or not np.array_equal(c0, cp):
                raise ManifoldError(
                    f"{self.name}: initial_momenta: control points differ from the policy's "
                    "and the space does not optimise them"
                )
            return cp, momenta, None
        if initial_momenta is not None:
            initial_momenta = self._check_momenta(cp, initial_momenta, "initial_momenta")
        return cp, initial_momenta, None

    def register(self, template, target, initial_momenta=None) -> RegistrationResult:
        """Register ``template`` onto ``target`` (eq. 3), cached per pair and parameters.

        ``target`` is a shape ``(k, d)`` in correspondence or any
        :class:`~manifolds.data_terms.DataTerm` (e.g. a
        :class:`~manifolds.data_terms.VarifoldDistance` to a mesh with another
        triangulation; cached when it has a ``key()``).

        ``initial_momenta`` (warm start) are momenta at the policy's control points,
        or, with ``optimize_control_points``, a :class:`LandmarkTangent` whose
        control points are the optimiser's start as well.
        """
        template = self.check_point(template, "template")
        target = self._check_target(target, "target")
        cp, initial_momenta, start = self._warm_start(template, initial_momenta)
        params = (type(self).__name__, self.point_shape, self.alpha, self.settings.key())
        key = registration_key(params, template, target, initial_momenta, start)
        cached = self._cache.get(key)
        if cached is not None:
            return cached
        result = register_with_flow(
            template, target, self.alpha, self.settings, flow=self.flow_model,
            control_points=cp, initial_momenta=initial_momenta, kernel=self.kernel,
        )  # fmt: skip
        self.n_registrations += 1
        self.n_unconverged += not result.converged
        self.n_iterations += result.n_iter
        self.n_flow_evaluations += result.n_flow_evaluations
        self.max_gradient_norm = max(self.max_gradient_norm, result.gradient_norm)
        self._cache.put(key, result)
        return result

    def clear_cache(self) -> None:
        """Forget cached registrations."""
        self._cache.clear()

    # ------------------------------------------------------------ connection
    def log(self, point, other):
        """``Log_T(S)``: the registration momenta at ``c(T)``, shape ``(n_cp, d)``.

        ``other`` is a shape or a :class:`~manifolds.data_terms.DataTerm` (see
        :meth:`register`). With ``optimize_control_points`` a
        :class:`LandmarkTangent` holding the optimised control points and the momenta.
        """
        point = self.check_point(point, "point")
        res = self.register(point, self._check_target(other, "other"))
        return self._tangent(res.control_points, res.momenta)

    def log_near(self, point, other, start):
        """``Log_T(S)`` registered from the momenta ``start`` (a warm start, see :meth:`register`);
        ``other`` a shape or a data term, as in :meth:`log`."""
        point = self.check_point(point, "point")
        other = self._check_target(other, "other")
        res = self.register(point, other, initial_momenta=start)
        return self._tangent(res.control_points, res.momenta)

    def symmetry_near(self, center, point, start):
        """``s_M(P) = Exp_M(-Log_M(P))`` with the registration started from ``start``."""
        return self.exp(center, -self.log_near(center, point, start))

    def log_with_residual(self, point, other):
        """``(Log_T(S), delta)`` with ``delta = S - Exp_T(Log_T S)`` (eq. 4), one registration."""
        point = self.check_point(point, "point")
        other = self._check_target(other, "other")
        if isinstance(other, DataTerm) and not other.corresponds:
            raise ManifoldError(
                f"{self.name}: other: the residual (eq. 4) needs a target in correspondence, "
                f"got {type(other).__name__}"
            )
        res = self.register(point, other)
        return self._tangent(res.control_points, res.momenta), res.residual.copy()

    def inverse_consistency(self, template, shape, distance: str | Callable = "rms") -> float:
        """Inverse consistency error of the registrations between ``template`` and ``shape``
        (paper, Table 1): :func:`manifolds.lddmm.inverse_consistency.inverse_consistency`."""
        return inverse_consistency(self, template, shape, distance)

    def is_tangent(self, point, vector, atol: float | None = None):
        """Whether ``vector`` is finite momenta ``(n_cp, d)`` at the policy's control
        points of ``point``, or a :class:`LandmarkTangent` with finite entries."""
        if isinstance(vector, LandmarkTangent):
            c, mu = vector.control_points, vector.momenta
            return c.shape[1] == self.point_shape[1] and bool(
                np.isfinite(c).all() and np.isfinite(mu).all()
            )
        mu = np.asarray(vector, dtype=float)
        cp = self.control_points(point)
        return mu.shape == cp.shape and bool(np.isfinite(mu).all())

    # ------------------------------------------------------------ metric
    def inner(self, point, u, v):
        """RKHS product ``sum_ij K(c_i, c_j) u_i . v_j`` (eq. 1) at the tangents' control points."""
        cp, u_mu = self._split_tangent(point, u, "u")
        cp_v, v_mu = self._split_tangent(point, v, "v")
        if cp_v.shape != cp.shape or not np.array_equal(cp_v, cp):
            raise ManifoldError(f"{self.name}: inner: u and v are at different control points")
        return self.kernel.rkhs_inner(cp, u_mu, v_mu)

    def norm(self, point, v):
        """RKHS norm ``||v||_H`` of momenta ``v`` at ``point``."""
        return float(np.sqrt(max(self.inner(point, v, v), 0.0)))

    # ------------------------------------------------------------ sampling
    def random_point(self, rng: np.random.Generator, n_samples: int | None = None):
        """A smooth random shape of ``k`` landmarks (:func:`manifolds.lddmm.shapes.random_shape`)."""
        n_samples = check_n_samples(n_samples)
        check_rng(rng)
        k, d = self.point_shape
        if n_samples is not None:
            return np.stack([random_shape(rng, k, d) for _ in range(n_samples)])
        return random_shape(rng, k, d)

    def random_tangent(self, point, rng: np.random.Generator, scale: float = 1.0):
        """Random momenta at ``c(point)`` whose velocity at the control points has RMS ``scale``."""
        cp = self.control_points(point)
        check_rng(rng)
        scale = check_float(scale, f"{self.name}: scale", minimum=0.0)
        z = rng.standard_normal(cp.shape)
        vel = self.kernel.convolve(cp, cp, z)
        rms = np.sqrt((vel * vel).sum(axis=1).mean())
        return self._tangent(cp, scale * z / rms)
