"""What the LDDMM and SVF landmark spaces share: shapes, control points, kernel, registration cache.

A point is a shape ``T`` of ``k`` landmarks in ``R^d``; a tangent vector at
``T`` is a set of momenta at the control points ``c(T)`` of the control-point
policy (or a :class:`~manifolds.lddmm.LandmarkTangent` carrying its own control
points); ``Log_T(S)`` is a registration of ``T`` onto ``S`` (eq. 3), inexact
for ``alpha > 0``: ``S = Exp_T(Log_T S) + delta`` (eq. 4). The metric is the
RKHS product of the kernel fields (eq. 1).

A subclass provides the deformation model: ``exp`` (the deformation of the
momenta applied to the shape), ``flow`` (the same deformation applied to any
points) and ``_register`` (the optimisation of eq. 3 for that model).
"""

from __future__ import annotations

import hashlib
from abc import abstractmethod
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import asdict

import numpy as np

from ..connection import Connection
from ..errors import ManifoldError
from ..numerics.integrators import Integrator, get_integrator
from ..numerics.optimizers import LBFGSOptions
from ..point_distance import point_distance
from ..validation import check_array, check_float, check_int, check_n_samples, check_rng
from .control_points import AUTO_THRESHOLD, MAX_CONTROL_POINTS, resolve_control_points
from .kernels import GaussianKernel
from .registration import RegistrationResult
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
    sigma : float
        Width of the Gaussian kernel ``K(x, y) = exp(-|x - y|^2 / sigma^2)``.
    alpha : float
        Regularisation of the registration: ``C = ||S - phi(T)||^2 + alpha^2 ||v||_H^2``.
    control_points : {"auto", "dense", "grid"} or array of shape ``(n_cp, d)``, default "auto"
        Control-point policy (see :mod:`manifolds.lddmm.control_points`).
    integrator : {"euler", "rk2", "rk4"} or Integrator, optional
        Defaults to the class's ``default_integrator``.
    n_steps : int, default 10
    optimizer : LBFGSOptions or dict, optional
        Settings of the registration's L-BFGS-B.
    cache_size : int, default 16
        Number of registrations kept (LRU) so that ``log``, ``log_with_residual``
        and ``register`` on the same pair register only once.
    backend : {"auto", "numpy", "numba"}, default "auto"
        Kernel sums; ``"auto"`` uses numba when it imports.
    block_size : int, optional
        Kernel-matrix entries per block of the numpy backend.
    auto_threshold : int
        Vertex count above which ``"auto"`` switches from dense to grid control points.
    precondition : bool, default True
        Preconditioned L-BFGS variables (see ``docs/lddmm.md``).
    optimize_control_points : bool, default False
        Register over the control points and the momenta (eq. 3), starting from
        the policy's control points (spaces with ``can_optimize_control_points``).
        ``log`` then returns a :class:`~manifolds.lddmm.LandmarkTangent` carrying
        its control points; ``exp`` accepts those and plain momenta at the
        policy's control points.
    max_control_points : int, default 20000
        Budget of a grid of control points: a ``sigma`` so small against the
        template's extent that the grid would exceed it raises an error before
        anything is allocated (see :mod:`manifolds.lddmm.control_points`).

    Attributes
    ----------
    n_registrations : int
        Registrations computed (cache hits excluded).
    n_unconverged : int
        Among them, those that stopped before meeting the optimiser's tolerance.
    n_iterations : int
        Optimiser iterations of those registrations.
    max_gradient_norm : float
        Largest final gradient (:attr:`RegistrationResult.gradient_norm`) among them.
    """

    is_symmetric = False
    supports_batch = False
    #: Whether the deformation model can optimise its control points in ``log``.
    can_optimize_control_points = False
    #: Integrator used when none is given.
    default_integrator = "euler"

    def __init__(
        self,
        n_landmarks: int,
        dim: int,
        sigma: float,
        alpha: float,
        control_points="auto",
        integrator: str | Integrator | None = None,
        n_steps: int = 10,
        optimizer: LBFGSOptions | dict | None = None,
        cache_size: int = 16,
        backend: str = "auto",
        block_size: int | None = None,
        auto_threshold: int = AUTO_THRESHOLD,
        precondition: bool = True,
        optimize_control_points: bool = False,
        max_control_points: int = MAX_CONTROL_POINTS,
    ):
        name = type(self).__name__
        if optimize_control_points and not self.can_optimize_control_points:
            raise ManifoldError(
                f"{name}: optimize_control_points: this space keeps its control points fixed "
                "(only LDDMMLandmarks optimises them)"
            )
        self.optimize_control_points = bool(optimize_control_points)
        n_landmarks = check_int(n_landmarks, f"{name}: n_landmarks", minimum=1)
        if isinstance(dim, bool) or dim not in (2, 3):
            raise ManifoldError(f"{name}: dim: expected 2 or 3, got {dim!r}")
        sigma = check_float(sigma, f"{name}: sigma", minimum=0.0, strict=True)
        self.alpha = check_float(alpha, f"{name}: alpha", minimum=0.0)
        self.n_steps = check_int(n_steps, f"{name}: n_steps", minimum=1)
        self.point_shape = (n_landmarks, int(dim))
        self.kernel = GaussianKernel(sigma, backend=backend, block_size=block_size)
        self.sigma = self.kernel.sigma
        self.max_control_points = check_int(
            max_control_points, f"{name}: max_control_points", minimum=1
        )
        self.control_points_policy = self._check_policy(control_points, int(dim))
        self.integrator = get_integrator(
            self.default_integrator if integrator is None else integrator
        )
        self.optimizer = LBFGSOptions.coerce(optimizer, f"{name}: optimizer")
        self.cache_size = check_int(cache_size, f"{name}: cache_size", minimum=0)
        self.auto_threshold = check_int(auto_threshold, f"{name}: auto_threshold", minimum=0)
        self.precondition = bool(precondition)
        self._cache: OrderedDict = OrderedDict()
        self.n_registrations = 0
        self.n_unconverged = 0
        self.n_iterations = 0
        self.max_gradient_norm = 0.0

    def _check_policy(self, control_points, dim: int):
        if isinstance(control_points, str):
            resolve_control_points(np.zeros((1, dim)), control_points, self.sigma)
            return control_points
        policy = check_array(control_points, (dim,), f"{self.name}: control_points")
        if policy.ndim != 2:
            raise ManifoldError(
                f"{self.name}: control_points must have shape (n_cp, {dim}), got {policy.shape}"
            )
        return policy

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

    @abstractmethod
    def _register(self, template, target, control_points, initial_momenta) -> RegistrationResult:
        """Minimise eq. (3) from ``control_points`` (and ``initial_momenta`` if given)."""

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
        point = self.check_point(point)
        return resolve_control_points(
            point,
            self.control_points_policy,
            self.sigma,
            self.auto_threshold,
            self.max_control_points,
        )

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
    def _key(self, template, target, initial_momenta, start=None) -> bytes:
        h = hashlib.blake2b(digest_size=20)
        for arr in (template, target, initial_momenta, start):
            h.update(b"none" if arr is None else np.ascontiguousarray(arr).tobytes())
        policy = self.control_points_policy
        params = (
            type(self).__name__,
            self.point_shape,
            self.sigma,
            self.alpha,
            policy if isinstance(policy, str) else policy.tobytes(),
            self.integrator,
            self.n_steps,
            tuple(sorted(asdict(self.optimizer).items())),
            self.precondition,
            self.auto_threshold,
            self.optimize_control_points,
        )
        h.update(repr(params).encode())
        return h.digest()

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

        ``initial_momenta`` (warm start) are momenta at the policy's control points,
        or, with ``optimize_control_points``, a :class:`LandmarkTangent` whose
        control points are the optimiser's start as well.
        """
        template = self.check_point(template, "template")
        target = self.check_point(target, "target")
        cp, initial_momenta, start = self._warm_start(template, initial_momenta)
        key = self._key(template, target, initial_momenta, start)
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        result = self._register(template, target, cp, initial_momenta)
        self.n_registrations += 1
        self.n_unconverged += not result.converged
        self.n_iterations += result.n_iter
        self.max_gradient_norm = max(self.max_gradient_norm, result.gradient_norm)
        for arr in (result.momenta, result.residual, result.deformed, result.control_points):
            arr.setflags(write=False)
        if self.cache_size > 0:
            self._cache[key] = result
            while len(self._cache) > self.cache_size:
                self._cache.popitem(last=False)
        return result

    def clear_cache(self) -> None:
        """Forget cached registrations."""
        self._cache.clear()

    # ------------------------------------------------------------ connection
    def log(self, point, other):
        """``Log_T(S)``: the registration momenta at ``c(T)``, shape ``(n_cp, d)``.

        With ``optimize_control_points`` a :class:`LandmarkTangent` holding the
        optimised control points and the momenta.
        """
        point = self.check_point(point, "point")
        other = self.check_point(other, "other")
        res = self.register(point, other)
        return self._tangent(res.control_points, res.momenta)

    def log_with_residual(self, point, other):
        """``(Log_T(S), delta)`` with ``delta = S - Exp_T(Log_T S)`` (eq. 4), one registration."""
        point = self.check_point(point, "point")
        other = self.check_point(other, "other")
        res = self.register(point, other)
        return self._tangent(res.control_points, res.momenta), res.residual.copy()

    def inverse_consistency(self, template, shape, distance: str | Callable = "rms") -> float:
        """Inverse consistency error of the registrations between ``template`` and ``shape``.

        With ``phi_TS`` the deformation registering ``T`` onto ``S`` and ``phi_ST``
        the one registering ``S`` onto ``T`` (each from its own template's
        control points), returns ``d(phi_ST(phi_TS(T)), T)``, how far the
        composition is from the identity on ``T`` (paper, Table 1). It is zero
        when ``phi_ST = phi_TS^{-1}`` on ``T``.

        Parameters
        ----------
        template, shape : arrays, shape ``(k, d)``
        distance : {"rms", "frobenius", "mean"} or callable, default "rms"
            Per-vertex RMS distance ``||A - B||_F / sqrt(k)`` (the paper's unit),
            Frobenius norm, mean per-vertex distance, or ``(a, b) -> float``
            (:func:`manifolds.point_distance.point_distance`).

        Returns
        -------
        float
        """
        template = self.check_point(template, "template")
        shape = self.check_point(shape, "shape")
        dist = point_distance(distance, self.point_shape)
        forward = self.register(template, shape)
        backward = self.register(shape, template)
        back = self.flow(
            shape, backward.momenta, forward.deformed, control_points=backward.control_points
        )
        return float(dist(back, template))

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
