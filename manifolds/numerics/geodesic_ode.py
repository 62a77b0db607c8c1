"""Numerical integration of the geodesic equation in local coordinates.

For a connection with Christoffel symbols ``Gamma^k_ij(x)`` a geodesic solves

    x' = v,        v'^k = -Gamma^k_ij(x) v^i v^j,

a vector ``w`` parallel along it solves ``w'^k = -Gamma^k_ij(x) v^i w^j``, and
the derivatives ``J = dx(t)/dv_0``, ``K = dv(t)/dv_0`` of the geodesic with
respect to its initial velocity (the variational, or Jacobi, equations) solve

    J' = K,        K'^k_c = -d_l Gamma^k_ij v^i v^j J^l_c - 2 Gamma^k_ij v^i K^j_c,

with ``J(0) = 0`` and ``K(0) = I``. ``J(1)`` is the differential of ``Exp_x`` at
``v_0``, which the shooting method of :mod:`manifolds.numerics.shooting` uses
as the exact Newton Jacobian. :class:`GeodesicIntegrator` integrates all of
these together with :func:`scipy.integrate.solve_ivp`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from ..errors import ConvergenceError

__all__ = ["GeodesicIntegrator", "GeodesicSolution", "GeodesicDomainError"]

ChristoffelFn = Callable[[np.ndarray], np.ndarray]
ChristoffelJetFn = Callable[[np.ndarray], tuple]


class GeodesicDomainError(ConvergenceError):
    """The integrated geodesic left the open set where the metric is defined.

    Attributes
    ----------
    time : float
        Time of the first evaluation of the equations outside the domain
        (``nan`` when unknown).
    """

    def __init__(self, message: str, time: float):
        super().__init__(message)
        self.time = time


class _LeftDomain(Exception):
    def __init__(self, time: float, position: np.ndarray):
        super().__init__(time)
        self.time = float(time)
        self.position = np.array(position)


@dataclass
class GeodesicSolution:
    """End state of an integrated geodesic.

    Attributes
    ----------
    position : array, shape ``(n,)``
        ``x(t_final)``.
    velocity : array, shape ``(n,)``
        ``x'(t_final)``.
    transported : array, shape ``(m, n)`` or None
        The ``m`` vectors parallel transported to ``x(t_final)``.
    jacobian : array, shape ``(n, n)`` or None
        ``dx(t_final) / dv_0``, the differential of the exponential map.
    n_steps : int
        Number of accepted integration steps.
    """

    position: np.ndarray
    velocity: np.ndarray
    transported: np.ndarray | None = None
    jacobian: np.ndarray | None = None
    n_steps: int = 0


class GeodesicIntegrator:
    """Integrator of the geodesic, parallel transport and variational equations.

    Parameters
    ----------
    method : str, default ``"DOP853"``
        Any explicit method of :func:`scipy.integrate.solve_ivp`.
    rtol, atol : float, default ``1e-12``
        Relative and absolute tolerances of the adaptive step control.
    max_step : float, default ``inf``
        Largest step allowed, in units of the geodesic parameter ``t``.

    Notes
    -----
    The error control applies to the whole state; the variational block is
    included so that the Newton Jacobian of the shooting method is accurate.
    """

    def __init__(
        self,
        method: str = "DOP853",
        rtol: float = 1e-12,
        atol: float = 1e-12,
        max_step: float = np.inf,
    ):
        if not (rtol > 0 and atol > 0):
            raise ValueError(f"rtol, atol: expected positive tolerances, got {rtol!r}, {atol!r}")
        if not max_step > 0:
            raise ValueError(f"max_step: expected a positive number, got {max_step!r}")
        self.method = method
        self.rtol = float(rtol)
        self.atol = float(atol)
        self.max_step = float(max_step)

    def __repr__(self) -> str:
        return (
            f"GeodesicIntegrator(method={self.method!r}, rtol={self.rtol:g}, "
            f"atol={self.atol:g}, max_step={self.max_step:g})"
        )

    def integrate(
        self,
        christoffel: ChristoffelFn,
        point: np.ndarray,
        velocity: np.ndarray,
        t_final: float = 1.0,
        transport: np.ndarray | None = None,
        christoffel_jet: ChristoffelJetFn | None = None,
        domain: Callable[[np.ndarray], bool] | None = None,
    ) -> GeodesicSolution:
        """Integrate the geodesic from ``point`` with initial ``velocity`` up to ``t_final``.

        Parameters
        ----------
        christoffel : callable
            ``x -> Gamma``, array of shape ``(n, n, n)`` indexed ``[k, i, j]``.
        point, velocity : array, shape ``(n,)``
            Initial position and velocity.
        t_final : float, default 1
            End time; ``Exp_x(v)`` is the position at ``t = 1``.
        transport : array, shape ``(m, n)`` or ``(n,)``, optional
            Vectors at ``point`` to transport parallel along the geodesic.
        christoffel_jet : callable, optional
            ``x -> (Gamma, dGamma)`` with ``dGamma[k, i, j, l] = d_l Gamma^k_ij``.
            When given, the variational equations are integrated too and the
            solution carries ``jacobian = dx(t_final)/dv_0``.
        domain : callable, optional
            ``x -> bool``; checked at every evaluation of the equations, so
            that the metric is never evaluated outside its domain.

        Returns
        -------
        GeodesicSolution

        Raises
        ------
        GeodesicDomainError
            If the geodesic leaves ``domain`` or the state becomes non-finite.
        ConvergenceError
            If the integrator failed (e.g. step size underflow).
        """
        n = point.shape[0]
        vecs = None
        if transport is not None:
            vecs = np.atleast_2d(np.asarray(transport, dtype=float))
        m = 0 if vecs is None else vecs.shape[0]
        variational = christoffel_jet is not None
        parts = [point, velocity]
        if m:
            parts.append(vecs.ravel())
        if variational:
            parts += [np.zeros(n * n), np.eye(n).ravel()]
        y0 = np.concatenate(parts)
        i_tr = 2 * n
        i_j = i_tr + m * n
        i_k = i_j + n * n

        rhs = _geodesic_rhs(n, m, christoffel, christoffel_jet, domain)
        sol = self._solve(rhs, y0, t_final, point, velocity)
        ys = sol.y
        if not np.isfinite(ys).all():
            raise GeodesicDomainError(
                f"geodesic from {point.tolist()} with velocity {velocity.tolist()} "
                "became non-finite",
                time=float("nan"),
            )
        y1 = ys[:, -1]
        return GeodesicSolution(
            position=y1[:n].copy(),
            velocity=y1[n : 2 * n].copy(),
            transported=y1[i_tr:i_j].reshape(m, n).copy() if m else None,
            jacobian=y1[i_j:i_k].reshape(n, n).copy() if variational else None,
            n_steps=len(sol.t) - 1,
        )

    def _solve(self, rhs, y0, t_final, point, velocity):
        """``solve_ivp`` on ``[0, t_final]``, its failures turned into named errors."""
        try:
            sol = solve_ivp(
                rhs,
                (0.0, float(t_final)),
                y0,
                method=self.method,
                rtol=self.rtol,
                atol=self.atol,
                max_step=self.max_step,
            )
        except _LeftDomain as exc:
            raise GeodesicDomainError(
                f"geodesic from {point.tolist()} with velocity {velocity.tolist()} "
                f"leaves the domain of the metric near t = {exc.time:.4g} "
                f"(position {exc.position.tolist()})",
                time=exc.time,
            ) from None
        except np.linalg.LinAlgError as exc:
            raise GeodesicDomainError(
                f"geodesic from {point.tolist()} with velocity {velocity.tolist()} "
                f"reached a degenerate metric ({exc})",
                time=float("nan"),
            ) from None
        if sol.status != 0:
            raise ConvergenceError(
                f"geodesic integration from {point.tolist()} with velocity "
                f"{velocity.tolist()} failed: {sol.message}"
            )
        return sol


def _geodesic_rhs(n, m, christoffel, christoffel_jet, domain):
    """Right-hand side of the geodesic, transport and variational equations.

    The state is ``[x, v, w_1..w_m, J, dJ/dt]``: position, velocity, ``m``
    transported vectors and, when ``christoffel_jet`` is given, the Jacobian
    ``J = dx/dv_0`` and its derivative (flattened).
    """
    variational = christoffel_jet is not None
    i_tr, i_j = 2 * n, 2 * n + m * n
    i_k = i_j + n * n

    def rhs(t, y):
        x = y[:n]
        v = y[n : 2 * n]
        if not np.isfinite(x).all() or (domain is not None and not domain(x)):
            raise _LeftDomain(t, x)
        if variational:
            gam, dgam = christoffel_jet(x)
        else:
            gam = christoffel(x)
        gv = gam @ v  # [k, i] = Gamma^k_ij v^j (= Gamma^k_ji v^j by symmetry)
        out = np.empty_like(y)
        out[:n] = v
        out[n : 2 * n] = -(gv @ v)
        if m:
            w = y[i_tr:i_j].reshape(m, n)
            out[i_tr:i_j] = -(w @ gv.T).ravel()
        if variational:
            jac = y[i_j:i_k].reshape(n, n)
            kac = y[i_k:].reshape(n, n)
            hess = np.einsum("kijl,i,j->kl", dgam, v, v)
            out[i_j:i_k] = kac.ravel()
            out[i_k:] = (-(hess @ jac) - 2.0 * (gv @ kac)).ravel()
        return out

    return rhs
