"""Fanning scheme: parallel transport of momenta along an LDDMM geodesic (Louis et al. 2018).

The transported vector is carried along the geodesic ``(c(t), mu(t))`` as a
Jacobi field. At each of the ``n`` steps of size ``h = 1/n``:

1. shoot two perturbed geodesics for one step from ``c_i`` with momenta
   ``mu_i + eps w_i`` and ``mu_i - eps w_i``;
2. the central difference of their control points, divided by ``2 eps h``,
   approximates the transported vector as a velocity at ``c_{i+1}``;
3. convert it back to momenta by solving with ``K(c_{i+1}, c_{i+1})``;
4. keep what parallel transport conserves: the component along the geodesic
   momenta ``mu_{i+1}`` (``<w, mu>`` is constant) and the RKHS norm ``|w|``.

Every step, of the geodesic and of the two perturbed shots, is one step of the
space's own integrator on its own geodesic equations
(:meth:`~manifolds.lddmm.LDDMMLandmarks.geodesic_step`: Euler in the study's
default settings, RK2 or RK4 when the space's settings say so). With ``n`` equal
to the space's ``n_steps`` the fanning therefore follows exactly the discrete
geodesic the space shoots, and the scheme measures transport, not a mismatch of
integrators. The scheme is first order: its error decreases as ``O(1/n)``. With a
flat geometry (e.g. a single control point) it is exact.

It needs a space with a flow of momenta (:class:`MomentumFlowSpace`: a kernel,
an integrator and a geodesic step); other spaces raise :class:`NoMomentumFlowError`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from manifolds.errors import ConvergenceError, ManifoldError
from manifolds.lddmm.tangent import LandmarkTangent
from manifolds.validation import as_float_array, check_finite, check_float, check_int

__all__ = [
    "FanningResult",
    "MomentumFlowSpace",
    "NoMomentumFlowError",
    "fanning_scheme",
    "fanning_transport",
]


@runtime_checkable
class MomentumFlowSpace(Protocol):
    """A space with a flow of momenta: what the fanning scheme needs.

    ``kernel`` (``rkhs_inner``, ``convolve``, ``solve``), ``integrator`` and
    ``geodesic_step(control_points, momenta, h) -> (control_points, momenta)``,
    one step of the space's integrator on its geodesic equations, e.g.
    :class:`manifolds.lddmm.LDDMMLandmarks`.
    """

    kernel: object
    integrator: object

    def geodesic_step(self, control_points, momenta, h: float): ...


class NoMomentumFlowError(TypeError):
    """The space has no flow of momenta (:class:`MomentumFlowSpace`), e.g. an SVF space."""


def _require_momentum_flow(space, caller: str) -> None:
    if not isinstance(space, MomentumFlowSpace):
        raise NoMomentumFlowError(
            f"{caller}: space: expected a space with a flow of momenta (kernel, integrator, "
            f"geodesic_step), e.g. manifolds.LDDMMLandmarks, got {type(space).__name__}"
        )


@dataclass
class FanningResult:
    """Output of :func:`fanning_scheme`.

    Attributes
    ----------
    momenta : array, shape ``(n_cp, d)``
        Transported momenta at the end of the geodesic.
    control_points : array, shape ``(n_cp, d)``
        Control points at the end of the geodesic (where ``momenta`` live).
    norm_drift : float
        Largest relative correction of the norm applied at one step.
    """

    momenta: np.ndarray
    control_points: np.ndarray
    norm_drift: float


def _checked_inputs(control_points, geodesic_momenta, tangent):
    """``(c, mu, w)`` as finite float arrays of one shape ``(n_cp, d)``."""
    c = check_finite(as_float_array(control_points, "control_points"), "control_points")
    if c.ndim != 2 or c.shape[0] == 0:
        raise ManifoldError(f"control_points: expected shape (n_cp, d), got {c.shape}")
    mu = as_float_array(geodesic_momenta, "geodesic_momenta")
    w = as_float_array(tangent, "tangent")
    for name, arr in (("geodesic_momenta", mu), ("tangent", w)):
        if arr.shape != c.shape:
            raise ValueError(
                f"{name}: expected shape {c.shape} (that of control_points), got {arr.shape}"
            )
        if not np.isfinite(arr).all():
            raise ValueError(f"{name}: contains NaN or infinite values")
    return c, mu, w


def fanning_scheme(
    space,
    control_points: np.ndarray,
    geodesic_momenta: np.ndarray,
    tangent: np.ndarray,
    n_steps: int = 10,
    epsilon: float | None = None,
    max_norm_drift: float = 0.5,
) -> FanningResult:
    """Transport ``tangent`` along the geodesic shot from ``(control_points, geodesic_momenta)``.

    Parameters
    ----------
    space : MomentumFlowSpace
        E.g. :class:`manifolds.lddmm.LDDMMLandmarks`: its kernel gives the metric and
        its integrator every step of the geodesic and of the perturbed shots.
    control_points : array, shape ``(n_cp, d)``
        Initial control points ``c_0``.
    geodesic_momenta : array, shape ``(n_cp, d)``
        Initial momenta ``mu_0`` of the geodesic (e.g. a registration's momenta).
    tangent : array, shape ``(n_cp, d)``
        Momenta ``w_0`` at ``c_0`` to transport.
    n_steps : int, default 10
        Number of steps ``n`` (the step is ``h = 1/n``).
    epsilon : float, optional
        Size of the perturbation of the momenta; default ``h`` (Louis et al.).
    max_norm_drift : float, default 0.5
        Largest relative change of the norm that one step's renormalisation may
        correct; beyond it the step is too coarse and :class:`ConvergenceError` is raised.

    Returns
    -------
    FanningResult

    Raises
    ------
    NoMomentumFlowError
        ``space`` has no flow of momenta.
    """
    _require_momentum_flow(space, "fanning_scheme")
    n_steps = check_int(n_steps, "n_steps", minimum=1)
    max_norm_drift = check_float(max_norm_drift, "max_norm_drift", minimum=0.0, strict=True)
    if epsilon is not None:
        epsilon = check_float(epsilon, "epsilon", minimum=0.0, strict=True)
    c, mu, w = _checked_inputs(control_points, geodesic_momenta, tangent)
    h = 1.0 / n_steps
    eps = h if epsilon is None else float(epsilon)

    def inner(cp, a, b):
        return float(space.kernel.rkhs_inner(cp, a, b))

    norm2_w = inner(c, w, w)
    dot_w_mu = inner(c, w, mu)  # <w, mu> is conserved by parallel transport
    drift = 0.0
    for _ in range(int(n_steps)):
        c_plus, _ = space.geodesic_step(c, mu + eps * w, h)
        c_minus, _ = space.geodesic_step(c, mu - eps * w, h)
        c, mu = space.geodesic_step(c, mu, h)
        velocity = (c_plus - c_minus) / (2.0 * eps * h)
        w_new = space.kernel.solve(c, velocity)
        norm2_mu = inner(c, mu, mu)
        if norm2_mu > 0:
            along = dot_w_mu / norm2_mu
            w_perp = w_new - (inner(c, w_new, mu) / norm2_mu) * mu
        else:
            along, w_perp = 0.0, w_new
        target = max(norm2_w - along**2 * norm2_mu, 0.0)
        n2 = inner(c, w_perp, w_perp)
        if target > 0 and n2 > 0:
            factor = np.sqrt(target / n2)
            drift = max(drift, abs(factor - 1.0))
            if abs(factor - 1.0) > max_norm_drift:
                raise ConvergenceError(
                    f"fanning_scheme: the norm drifted by {abs(factor - 1.0):.2g} in one step "
                    f"(max_norm_drift={max_norm_drift}); increase n_steps"
                )
            w_perp = w_perp * factor
        w = w_perp + along * mu
    return FanningResult(momenta=w, control_points=c, norm_drift=drift)


def fanning_transport(
    space, base, end, tangent, n_steps: int = 10, max_norm_drift: float = 0.5
) -> FanningResult:
    """Fanning transport of ``tangent`` from ``base`` to ``end`` on an LDDMM space.

    The same call pattern as the ladders: the geodesic is the one shot from
    ``base`` with ``Log_base(end)`` (a registration, cached by the space), and
    ``tangent`` is a set of momenta at the control points of ``base``, or a
    :class:`~manifolds.lddmm.LandmarkTangent` carrying its own control points.

    When the tangent's control points differ from the geodesic's (e.g. both
    optimised by their registrations), the tangent is first expressed at the
    geodesic's control points ``c`` by matching its velocity there:
    ``w = K(c, c)^{-1} K(c, c_w) w_0``, the RKHS-orthogonal projection of its
    velocity field onto the fields carried by ``c``.

    Parameters
    ----------
    space : MomentumFlowSpace
        E.g. :class:`manifolds.LDDMMLandmarks`; another space raises
        :class:`NoMomentumFlowError`.
    base, end : arrays, shape ``space.point_shape``
    tangent : array, shape ``(n_cp, d)``, or LandmarkTangent
        Momenta at ``space.control_points(base)``, e.g. ``space.log(base, other)``.
    n_steps : int, default 10
    max_norm_drift : float, default 0.5
        See :func:`fanning_scheme`.

    Returns
    -------
    FanningResult
        ``momenta`` carried by ``control_points`` (the control points of ``base``
        flowed to the end of the geodesic); deform a shape with them through
        ``space.shoot(shape, result.momenta, control_points=result.control_points)``.
    """
    _require_momentum_flow(space, "fanning_transport")
    n_steps = check_int(n_steps, "n_steps", minimum=1)
    check_float(max_norm_drift, "max_norm_drift", minimum=0.0, strict=True)
    c0, mu0 = _momenta_at(space, base, space.log(base, end))
    c_w, w0 = _momenta_at(space, base, tangent)
    if c_w.shape != c0.shape or not np.array_equal(c_w, c0):
        w0 = space.kernel.solve(c0, space.kernel.convolve(c0, c_w, w0))
    return fanning_scheme(space, c0, mu0, w0, n_steps=n_steps, max_norm_drift=max_norm_drift)


def _momenta_at(space, base, tangent):
    """Control points and momenta of a tangent of ``space`` at ``base``."""
    if isinstance(tangent, LandmarkTangent):
        return tangent.control_points, tangent.momenta
    return space.control_points(base), np.asarray(tangent, dtype=float)
