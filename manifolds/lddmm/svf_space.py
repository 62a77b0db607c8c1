"""The SVF landmark space: shapes deformed by flows of stationary kernel fields.

A point is a shape ``T`` of ``k`` landmarks in ``R^d``. A tangent vector at
``T`` is a stationary velocity field ``v(x) = sum_j K(x, c_j) m_j`` given by its
momenta ``m`` at the control points ``c(T)`` of the control-point policy; the
control points and momenta do not move in time. ``Exp_T(v) = exp(v)(T)`` is the
time-one flow of ``v`` (the group exponential) and ``Log_T(S)`` the SVF
registration of ``T`` onto ``S``, inexact for ``alpha > 0``:
``S = Exp_T(Log_T S) + delta`` as in the paper's eq. (4), so that
:class:`manifolds.ResidualAugmented` wraps this space unchanged.

Differences with :class:`~manifolds.lddmm.LDDMMLandmarks`: the field is not a
geodesic of the kernel metric (no momentum/control-point evolution), and
``exp(v)^{-1} = exp(-v)`` exactly for the flow (up to the integrator's error).
See ``docs/svf.md``.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from dataclasses import asdict

import numpy as np

from ..connection import Connection
from ..errors import ManifoldError
from ..numerics.integrators import Integrator, get_integrator
from ..numerics.optimizers import LBFGSOptions
from ..point_distance import point_distance
from ..validation import check_array
from .control_points import AUTO_THRESHOLD, resolve_control_points
from .kernels import GaussianKernel
from .registration import RegistrationResult
from .shapes import random_shape
from .stationary_flow import StationaryFlow, kernel_flow
from .svf_registration import register_svf

__all__ = ["SVFLandmarks"]


def _check_params(n_landmarks, dim, alpha, n_steps) -> float:
    if int(n_landmarks) != n_landmarks or n_landmarks < 1:
        raise ManifoldError(f"SVFLandmarks: n_landmarks must be >= 1, got {n_landmarks}")
    if dim not in (2, 3):
        raise ManifoldError(f"SVFLandmarks: dim must be 2 or 3, got {dim}")
    alpha = float(alpha)
    if not np.isfinite(alpha) or alpha < 0:
        raise ManifoldError(f"SVFLandmarks: alpha must be a number >= 0, got {alpha}")
    if int(n_steps) != n_steps or n_steps < 1:
        raise ManifoldError(f"SVFLandmarks: n_steps must be an integer >= 1, got {n_steps}")
    return alpha


class SVFLandmarks(Connection):
    """Landmark shapes ``(k, d)`` with the SVF group exponential and registration as logarithm.

    Parameters
    ----------
    n_landmarks : int
        Number of landmarks ``k``.
    dim : int
        Ambient dimension ``d`` (2 or 3).
    sigma : float
        Width of the Gaussian kernel ``K(x, y) = exp(-|x - y|^2 / sigma^2)``.
    alpha : float
        Regularisation: ``C = ||S - exp(v)(T)||^2 + alpha^2 ||v||_V^2``.
    control_points : {"auto", "dense", "grid"} or array of shape ``(n_cp, d)``, default "auto"
        Control-point policy (see :mod:`manifolds.lddmm.control_points`).
    integrator : {"euler", "rk2", "rk4"} or Integrator, default "rk4"
    n_steps : int, default 10
    optimizer : LBFGSOptions or dict, optional
    cache_size : int, default 16
        Registrations kept (LRU): ``log``, ``log_with_residual`` and ``register``
        on the same pair register once.
    backend : {"auto", "numpy", "numba"}, default "auto"
    block_size : int, optional
    auto_threshold : int
        Vertex count above which ``"auto"`` switches from dense to grid control points.
    precondition : bool, default True
        Preconditioned L-BFGS variables (as for LDDMM).
    """

    is_symmetric = False
    supports_batch = False

    def __init__(
        self,
        n_landmarks: int,
        dim: int,
        sigma: float,
        alpha: float,
        control_points="auto",
        integrator: str | Integrator = "rk4",
        n_steps: int = 10,
        optimizer: LBFGSOptions | dict | None = None,
        cache_size: int = 16,
        backend: str = "auto",
        block_size: int | None = None,
        auto_threshold: int = AUTO_THRESHOLD,
        precondition: bool = True,
    ):
        self.alpha = _check_params(n_landmarks, dim, alpha, n_steps)
        self.point_shape = (int(n_landmarks), int(dim))
        self.kernel = GaussianKernel(sigma, backend=backend, block_size=block_size)
        self.sigma = self.kernel.sigma
        if isinstance(control_points, str):
            resolve_control_points(np.zeros((1, dim)), control_points, self.sigma)
            self.control_points_policy = control_points
        else:
            policy = check_array(control_points, (dim,), "control_points")
            if policy.ndim != 2:
                raise ManifoldError(
                    f"SVFLandmarks: control_points must have shape (n_cp, {dim}), "
                    f"got {policy.shape}"
                )
            self.control_points_policy = policy
        self.integrator = get_integrator(integrator)
        self.n_steps = int(n_steps)
        if isinstance(optimizer, dict):
            optimizer = LBFGSOptions(**optimizer)
        self.optimizer = LBFGSOptions() if optimizer is None else optimizer
        self.cache_size = int(cache_size)
        self.auto_threshold = int(auto_threshold)
        self.precondition = bool(precondition)
        self._cache: OrderedDict = OrderedDict()
        self.n_registrations = 0

    def __repr__(self) -> str:
        k, d = self.point_shape
        policy = self.control_points_policy
        policy = policy if isinstance(policy, str) else f"array{policy.shape}"
        return (
            f"SVFLandmarks(k={k}, d={d}, sigma={self.sigma:g}, alpha={self.alpha:g}, "
            f"control_points={policy!r}, integrator={self.integrator.name!r}, "
            f"n_steps={self.n_steps})"
        )

    # ------------------------------------------------------------ building blocks
    def control_points(self, point) -> np.ndarray:
        """Control points ``c(T)`` of ``point``, shape ``(n_cp, d)``."""
        point = self.check_point(point)
        return resolve_control_points(
            point, self.control_points_policy, self.sigma, self.auto_threshold
        )

    def _check_momenta(self, cp: np.ndarray, momenta, name: str) -> np.ndarray:
        arr = check_array(momenta, (cp.shape[1],), f"{self.name}: {name}")
        if arr.shape != cp.shape:
            raise ManifoldError(
                f"{self.name}: {name}: expected momenta of shape {cp.shape} "
                f"(n_cp, d) at the control points, got {arr.shape}"
            )
        return arr

    def deformation(self, point, tangent) -> StationaryFlow:
        """``exp(v)`` for the field of momenta ``tangent`` at ``c(point)``, as a map on points."""
        cp = self.control_points(point)
        tangent = self._check_momenta(cp, tangent, "tangent")
        return StationaryFlow.from_momenta(
            self.kernel, cp.copy(), tangent.copy(), self.integrator, self.n_steps
        )

    def flow(self, template, momenta, points) -> np.ndarray:
        """``exp(v)(points)`` for the field of ``momenta`` at ``c(template)``, shape ``(n, d)``."""
        template = self.check_point(template, "template")
        cp = self.control_points(template)
        momenta = self._check_momenta(cp, momenta, "momenta")
        pts = check_array(points, (self.point_shape[1],), f"{self.name}: points")
        return kernel_flow(self.kernel, cp, momenta, pts, self.integrator, self.n_steps).points

    # ------------------------------------------------------------ connection
    def exp(self, point, tangent):
        """``Exp_T(v) = exp(v)(T)``; ``tangent`` is the momenta at ``c(T)``, ``(n_cp, d)``."""
        point = self.check_point(point, "point")
        cp = self.control_points(point)
        tangent = self._check_momenta(cp, tangent, "tangent")
        if not tangent.any():
            return point.copy()
        return kernel_flow(self.kernel, cp, tangent, point, self.integrator, self.n_steps).points

    def _key(self, template, target, initial_momenta) -> bytes:
        h = hashlib.blake2b(digest_size=20)
        for arr in (template, target, initial_momenta):
            h.update(b"none" if arr is None else np.ascontiguousarray(arr).tobytes())
        policy = self.control_points_policy
        params = (
            self.point_shape,
            self.sigma,
            self.alpha,
            policy if isinstance(policy, str) else policy.tobytes(),
            self.integrator,
            self.n_steps,
            tuple(sorted(asdict(self.optimizer).items())),
            self.precondition,
            self.auto_threshold,
        )
        h.update(repr(params).encode())
        return h.digest()

    def register(self, template, target, initial_momenta=None) -> RegistrationResult:
        """SVF registration of ``template`` onto ``target``, cached per pair and parameters."""
        template = self.check_point(template, "template")
        target = self.check_point(target, "target")
        cp = self.control_points(template)
        if initial_momenta is not None:
            initial_momenta = self._check_momenta(cp, initial_momenta, "initial_momenta")
        key = self._key(template, target, initial_momenta)
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        result = register_svf(
            template,
            target,
            self.kernel,
            self.alpha,
            control_points=cp,
            integrator=self.integrator,
            n_steps=self.n_steps,
            initial_momenta=initial_momenta,
            options=self.optimizer,
            precondition=self.precondition,
        )
        self.n_registrations += 1
        for arr in (result.momenta, result.residual, result.deformed, result.control_points):
            arr.setflags(write=False)
        if self.cache_size > 0:
            self._cache[key] = result
            while len(self._cache) > self.cache_size:
                self._cache.popitem(last=False)
        return result

    def log(self, point, other):
        """``Log_T(S)``: the registration's momenta at ``c(T)``, shape ``(n_cp, d)``."""
        point = self.check_point(point, "point")
        other = self.check_point(other, "other")
        return self.register(point, other).momenta.copy()

    def log_with_residual(self, point, other):
        """``(Log_T(S), delta)`` with ``delta = S - Exp_T(Log_T S)``, from one registration."""
        point = self.check_point(point, "point")
        other = self.check_point(other, "other")
        res = self.register(point, other)
        return res.momenta.copy(), res.residual.copy()

    def clear_cache(self) -> None:
        """Forget cached registrations."""
        self._cache.clear()

    def inverse_consistency(self, template, shape, distance="rms") -> float:
        """``d(phi_ST(phi_TS(T)), T)`` for the registrations ``T -> S`` and ``S -> T``.

        Each deformation is the flow of the field registered from its own
        template's control points (paper, Table 1). The SVF inverse of
        ``phi_TS = exp(v)`` is ``exp(-v)``; this measures how far the registered
        backward deformation is from it on ``T``.

        Parameters
        ----------
        template, shape : arrays, shape ``(k, d)``
        distance : {"rms", "frobenius", "mean"} or callable, default "rms"
            See :func:`manifolds.point_distance.point_distance`.

        Returns
        -------
        float
        """
        template = self.check_point(template, "template")
        shape = self.check_point(shape, "shape")
        forward = self.register(template, shape)
        backward = self.register(shape, template)
        back = self.flow(shape, backward.momenta, forward.deformed)
        return float(point_distance(distance, self.point_shape)(back, template))

    # ------------------------------------------------------------ metric
    def inner(self, point, u, v):
        """``<u, v>_V = sum_ij K(c_i, c_j) u_i . v_j`` at the control points of ``point``."""
        cp = self.control_points(point)
        u = self._check_momenta(cp, u, "u")
        v = self._check_momenta(cp, v, "v")
        return self.kernel.rkhs_inner(cp, u, v)

    def norm(self, point, v):
        """``||v||_V`` of the field of momenta ``v`` at ``point``."""
        return float(np.sqrt(max(self.inner(point, v, v), 0.0)))

    # ------------------------------------------------------------ sampling
    def random_point(self, rng: np.random.Generator, n_samples: int | None = None):
        """A smooth random shape of ``k`` landmarks (:func:`manifolds.lddmm.shapes.random_shape`)."""
        k, d = self.point_shape
        if n_samples is not None:
            return np.stack([random_shape(rng, k, d) for _ in range(int(n_samples))])
        return random_shape(rng, k, d)

    def random_tangent(self, point, rng: np.random.Generator, scale: float = 1.0):
        """Random momenta at ``c(point)`` whose velocity at the control points has RMS ``scale``."""
        cp = self.control_points(point)
        z = rng.standard_normal(cp.shape)
        vel = self.kernel.convolve(cp, cp, z)
        rms = np.sqrt((vel * vel).sum(axis=1).mean())
        return scale * z / rms
