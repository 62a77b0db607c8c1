"""The group structure of deformations given as flows of stationary fields.

Deformations ``phi = exp(v)``, ``psi = exp(w)`` are
:class:`~manifolds.lddmm.stationary_flow.StationaryFlow` maps on point sets;
composition is composition of maps and the inverse of ``exp(v)`` is ``exp(-v)``.
With the Cartan-Schouten connection of the group, one-parameter subgroups
``t -> exp(t v)`` are the geodesics through the identity and the geodesic
symmetry at ``phi`` is

    s_phi(psi) = phi o psi^{-1} o phi

(at the identity, the inverse). The pole ladder built from these symmetries is
a conjugation (Lorenzi and Pennec; Jia et al. 2018): with ``T <-> id``,
``S <-> exp(v)``, midpoint ``M <-> exp(v/2)`` and ``S' <-> exp(u) o exp(v)``,
``s_T o s_M(S') = exp(-v/2) o exp(u) o exp(v/2)``: the deformation ``exp(u)``
at ``exp(v)`` is transported to the identity by conjugation with ``exp(v/2)``.
Everything here is computed by composing flows on point sets; collapsing a
composition back into a single kernel field would need a projection, which
:func:`group_pole_ladder` does by a registration when asked.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .stationary_flow import StationaryFlow

__all__ = [
    "Composition",
    "compose",
    "group_symmetry",
    "conjugate",
    "svf_pole_ladder",
    "group_pole_ladder",
]

PointMap = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Composition:
    """``maps[0] o maps[1] o ... o maps[-1]`` on point sets (the last map is applied first).

    Each map takes and returns an array of shape ``(k, d)``; :meth:`inverse`
    needs every map to have an ``inverse()`` (as :class:`StationaryFlow` and
    :class:`Composition` do).
    """

    maps: tuple

    def __call__(self, points) -> np.ndarray:
        out = np.asarray(points, dtype=float)
        for f in reversed(self.maps):
            out = f(out)
        return out

    def inverse(self) -> Composition:
        """``maps[-1]^{-1} o ... o maps[0]^{-1}``."""
        return Composition(tuple(f.inverse() for f in reversed(self.maps)))


def compose(*maps: PointMap) -> Composition:
    """``maps[0] o maps[1] o ... o maps[-1]`` (the last one is applied first)."""
    if not maps:
        raise ValueError("compose: expected at least one map, got none")
    return Composition(tuple(maps))


def group_symmetry(phi: StationaryFlow, psi: StationaryFlow) -> Composition:
    """``s_phi(psi) = phi o psi^{-1} o phi`` as a map on point sets.

    It fixes ``phi`` (``s_phi(phi) = phi``) and is an involution
    (``s_phi(s_phi(psi)) = psi``), both up to the integration error of the flows.

    Parameters
    ----------
    phi, psi : StationaryFlow or Composition
        ``exp(v)`` and ``exp(w)`` (or compositions of flows); ``psi^{-1}`` is ``exp(-w)``.
    """
    return compose(phi, psi.inverse(), phi)


def conjugate(phi: StationaryFlow, psi: PointMap) -> Composition:
    """``phi^{-1} o psi o phi`` as a map on point sets."""
    return compose(phi.inverse(), psi, phi)


def svf_pole_ladder(v: StationaryFlow, u: StationaryFlow) -> Composition:
    """Transport of ``exp(u)`` from ``exp(v)`` to the identity: ``exp(-v/2) o exp(u) o exp(v/2)``.

    Parameters
    ----------
    v : StationaryFlow
        ``exp(v)``, the deformation from the identity to the start of the transport.
    u : StationaryFlow
        ``exp(u)``, the deformation to transport (acting after ``exp(v)``).

    Returns
    -------
    Composition
        The transported deformation as a map on point sets.
    """
    return conjugate(v.scaled(0.5), u)


def group_pole_ladder(space, point, v, u, return_tangent: bool = False, base=None):
    """SVF pole ladder on shapes of an :class:`~manifolds.lddmm.SVFLandmarks` space.

    With ``T = point``, ``S = Exp_T(v)`` and the tangent ``u`` at ``S``
    (``S' = Exp_S(u) = exp(u)(exp(v)(T))``), the transported shape is
    ``T' = exp(-v/2)(exp(u)(exp(v/2)(T)))``; the generic
    :func:`ladders.pole_ladder` from ``S`` to ``T`` approximates the same shape
    by registrations.

    Parameters
    ----------
    space : SVFLandmarks
    point : array, shape ``(k, d)``
        ``T``, the end of the transport.
    v : array, shape ``(n_cp, d)``
        Momenta at ``c(T)``: ``S = Exp_T(v)``.
    u : array, shape ``(n_cp', d)``
        Momenta at ``c(S)``, the tangent to transport.
    return_tangent : bool, default False
        Also return ``Log_T(T')`` (one registration), the transported tangent at ``T``.
    base : array, shape ``(k, d)``, optional
        The shape ``S`` whose control points carry ``u`` (e.g. ``u = Log_S(S')``
        from a registration, when ``Exp_T(v)`` only approximates ``S``). Defaults
        to ``Exp_T(v)``.

    Returns
    -------
    shape : array, shape ``(k, d)``
        ``T'``.
    tangent : array, shape ``(n_cp, d)``, only if ``return_tangent``
    """
    point = space.check_point(point, "point")
    phi_v = space.deformation(point, v)
    start = phi_v(point)
    carrier = start if base is None else space.check_point(base, "base")
    phi_u = space.deformation(carrier, u)
    shape = svf_pole_ladder(phi_v, phi_u)(point)
    if return_tangent:
        return shape, space.log(point, shape)
    return shape
