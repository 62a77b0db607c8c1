"""The LDDMM landmark space: shapes as point sets deformed by Gaussian-kernel flows.

Paper, Section 2.1. A point is a shape ``T`` of ``k`` landmarks in ``R^d``
(e.g. the vertices of a mesh, in correspondence across shapes). A tangent
vector at ``T`` is a set of initial momenta ``mu`` at the control points
``c(T)`` chosen by the control-point policy; ``Exp_T(mu) = phi_1(T)`` is the
flow of the geodesic shot from ``(c(T), mu)`` and ``Log_T(S)`` is the
registration of ``T`` onto ``S`` (eq. 3), which is inexact for ``alpha > 0``:
``S = Exp_T(Log_T S) + delta`` (eq. 4).
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import asdict

import numpy as np

from ..connection import Connection
from ..errors import ManifoldError
from ..numerics.integrators import Integrator, get_integrator
from ..numerics.optimizers import LBFGSOptions
from ..point_distance import point_distance
from ..validation import (
    check_array,
    check_finite_result,
    check_float,
    check_int,
    check_n_samples,
    check_rng,
)
from .control_points import AUTO_THRESHOLD, MAX_CONTROL_POINTS, resolve_control_points
from .kernels import GaussianKernel
from .registration import RegistrationResult, register
from .shapes import random_shape
from .shooting import shoot
from .tangent import LandmarkTangent

__all__ = ["LDDMMLandmarks"]


class LDDMMLandmarks(Connection):
    """Landmark shapes ``(k, d)`` with the LDDMM exponential and registration as logarithm.

    Parameters
    ----------
    n_landmarks : int
        Number of landmarks (mesh vertices) ``k``.
    dim : int
        Ambient dimension ``d`` (2 or 3).
    sigma : float
        Width of the Gaussian kernel ``K(x, y) = exp(-|x - y|^2 / sigma^2)``.
    alpha : float
        Regularisation of the registration: ``C = ||S - phi_1(T)||^2 + alpha^2 ||v_0||_H^2``.
    control_points : {"auto", "dense", "grid"} or array of shape ``(n_cp, d)``, default "auto"
        Control-point policy (see :mod:`manifolds.lddmm.control_points`).
    integrator : {"euler", "rk2", "rk4"} or Integrator, default "euler"
    n_steps : int, default 10
    optimizer : LBFGSOptions or dict, optional
        Settings of the registration's L-BFGS-B.
    cache_size : int, default 16
        Number of registrations kept (LRU) so that ``log``, ``log_with_residual``
        and ``register`` on the same pair register only once.
    backend : {"auto", "numpy", "numba"}, default "auto"
    block_size : int, optional
        Kernel-matrix entries per block of the numpy backend.
    auto_threshold : int
        Vertex count above which ``"auto"`` switches from dense to grid control points.
    precondition : bool, default True
        Preconditioned L-BFGS variables (see ``docs/lddmm.md``).
    optimize_control_points : bool, default False
        Register over the control points and the momenta (eq. 3), starting from
        the policy's control points. ``log`` then returns a
        :class:`~manifolds.lddmm.LandmarkTangent` carrying its control points;
        ``exp`` accepts those and plain momenta at the policy's control points.
    max_control_points : int, default 20000
        Budget of a grid of control points: a ``sigma`` so small against the
        template's extent that the grid would exceed it raises an error before
        anything is allocated (see :mod:`manifolds.lddmm.control_points`).
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
        integrator: str | Integrator = "euler",
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
        name = "LDDMMLandmarks"
        n_landmarks = check_int(n_landmarks, f"{name}: n_landmarks", minimum=1)
        if isinstance(dim, bool) or dim not in (2, 3):
            raise ManifoldError(f"{name}: dim: expected 2 or 3, got {dim!r}")
        sigma = check_float(sigma, f"{name}: sigma", minimum=0.0, strict=True)
        alpha = check_float(alpha, f"{name}: alpha", minimum=0.0)
        n_steps = check_int(n_steps, f"{name}: n_steps", minimum=1)
        self.point_shape = (n_landmarks, int(dim))
        self.kernel = GaussianKernel(sigma, backend=backend, block_size=block_size)
        self.sigma = self.kernel.sigma
        self.alpha = alpha
        self.max_control_points = check_int(
            max_control_points, f"{name}: max_control_points", minimum=1
        )
        if isinstance(control_points, str):
            resolve_control_points(np.zeros((1, dim)), control_points, self.sigma)
            self.control_points_policy = control_points
        else:
            self.control_points_policy = check_array(control_points, (dim,), "control_points")
            if self.control_points_policy.ndim != 2:
                raise ManifoldError(
                    f"LDDMMLandmarks: control_points must have shape (n_cp, {dim}), "
                    f"got {self.control_points_policy.shape}"
                )
        self.integrator = get_integrator(integrator)
        self.n_steps = n_steps
        self.optimizer = LBFGSOptions.coerce(optimizer, f"{name}: optimizer")
        self.cache_size = check_int(cache_size, f"{name}: cache_size", minimum=0)
        self.auto_threshold = check_int(auto_threshold, f"{name}: auto_threshold", minimum=0)
        self.precondition = bool(precondition)
        self.optimize_control_points = bool(optimize_control_points)
        self._cache: OrderedDict = OrderedDict()
        self.n_registrations = 0

    def __repr__(self) -> str:
        k, d = self.point_shape
        policy = self.control_points_policy
        policy = policy if isinstance(policy, str) else f"array{policy.shape}"
        return (
            f"LDDMMLandmarks(k={k}, d={d}, sigma={self.sigma:g}, alpha={self.alpha:g}, "
            f"control_points={policy!r}, integrator={self.integrator.name!r}, "
            f"n_steps={self.n_steps}"
            + (", optimize_control_points=True)" if self.optimize_control_points else ")")
        )

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

    def shoot(
        self,
        template,
        momenta,
        control_points=None,
        return_trajectory: bool = False,
        integrator: str | Integrator | None = None,
    ):
        """Deformed template ``phi_1(T)`` for the geodesic shot from ``(c, momenta)``.

        Parameters
        ----------
        template : array, shape ``(k, d)``
        momenta : array, shape ``(n_cp, d)``
        control_points : array, shape ``(n_cp, d)``, optional
            Defaults to the policy's control points of ``template``.
        return_trajectory : bool
            Also return the list of ``n_steps + 1`` states ``(c, mu, x)`` (for
            dense control points the template is carried as ``c``, and the states
            are ``(c, mu)``).
        integrator : optional
            Overrides the space's integrator (e.g. ``"rk2"`` for the fanning scheme).
        """
        template = self.check_point(template, "template")
        if control_points is None:
            cp = resolve_control_points(
                template,
                self.control_points_policy,
                self.sigma,
                self.auto_threshold,
                self.max_control_points,
            )
        else:
            cp = check_array(control_points, (self.point_shape[1],), f"{self.name}: control_points")
        momenta = self._check_momenta(cp, momenta, "momenta")
        dense = cp is template
        res = shoot(
            self.kernel,
            cp,
            momenta,
            self.integrator if integrator is None else integrator,
            self.n_steps,
            points=None if dense else template,
            return_trajectory=return_trajectory,
        )
        deformed = res.control_points if dense else res.points
        check_finite_result(
            deformed,
            f"{self.name}: momenta (tangent)",
            f"the shooting diverged (largest momentum {np.max(np.abs(momenta)):.4g}, "
            f"sigma {self.sigma:g}): momenta too large for the kernel width",
        )
        return (deformed, res.trajectory) if return_trajectory else deformed

    def flow(self, template, momenta, points, control_points=None) -> np.ndarray:
        """``phi_1(points)`` for the deformation shot from the template's control points."""
        template = self.check_point(template, "template")
        cp = (
            self.control_points(template)
            if control_points is None
            else check_array(control_points, (self.point_shape[1],), "control_points")
        )
        momenta = self._check_momenta(cp, momenta, "momenta")
        pts = check_array(points, (self.point_shape[1],), f"{self.name}: points")
        res = shoot(self.kernel, cp, momenta, self.integrator, self.n_steps, points=pts)
        return res.points

    # ------------------------------------------------------------ connection
    def exp(self, point, tangent):
        """``Exp_T(mu) = phi_1(T)``, shot from the tangent's control points.

        ``tangent`` is a :class:`LandmarkTangent` or momenta ``(n_cp, d)`` at ``c(T)``.
        """
        point = self.check_point(point, "point")
        if isinstance(tangent, LandmarkTangent):
            cp, momenta = self._split_tangent(point, tangent, "tangent")
            return self.shoot(point, momenta, control_points=cp)
        cp = self.control_points(point)
        tangent = self._check_momenta(cp, tangent, "tangent")
        return self.shoot(point, tangent, control_points=None)

    def _key(self, template, target, initial_momenta, start=None) -> bytes:
        h = hashlib.blake2b(digest_size=20)
        for arr in (template, target, initial_momenta, start):
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
            self.optimize_control_points,
        )
        h.update(repr(params).encode())
        return h.digest()

    def register(self, template, target, initial_momenta=None) -> RegistrationResult:
        """Register ``template`` onto ``target`` (eq. 3), cached per pair and parameters.

        ``initial_momenta`` (warm start) are momenta at the policy's control points,
        or, with ``optimize_control_points``, a :class:`LandmarkTangent` whose
        control points are the optimiser's start as well.
        """
        template = self.check_point(template, "template")
        target = self.check_point(target, "target")
        cp = self.control_points(template)
        start = None
        if isinstance(initial_momenta, LandmarkTangent):
            c0, initial_momenta = self._split_tangent(template, initial_momenta, "initial_momenta")
            if self.optimize_control_points:
                cp = start = c0
            elif c0.shape != cp.shape or not np.array_equal(c0, cp):
                raise ManifoldError(
                    f"{self.name}: initial_momenta: control points differ from the policy's "
                    "and the space does not optimise them"
                )
        elif initial_momenta is not None:
            initial_momenta = self._check_momenta(cp, initial_momenta, "initial_momenta")
        key = self._key(template, target, initial_momenta, start)
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        result = register(
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
            optimize_control_points=self.optimize_control_points,
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

    def clear_cache(self) -> None:
        """Forget cached registrations."""
        self._cache.clear()

    def inverse_consistency(self, template, shape, distance: str | Callable = "rms") -> float:
        """Inverse consistency error of the registrations between ``template`` and ``shape``.

        With ``phi_TS`` the deformation registering ``T`` onto ``S`` and ``phi_ST``
        the one registering ``S`` onto ``T`` (each shot from its own template's
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
        forward = self.register(template, shape)
        backward = self.register(shape, template)
        dist = point_distance(distance, self.point_shape)
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
        """RKHS product ``sum_ij K(c_i, c_j) u_i . v_j`` at the control points of ``point``."""
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
