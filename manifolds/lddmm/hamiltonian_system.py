"""The Hamiltonian system of LDDMM (paper, eq. 2) as an ODE in the kernel backend's layout.

The state is ``(c, mu[, x])``: control points, momenta and, optionally, points
carried by the flow. A system gives the right-hand side and its two derivatives
(the vector-Jacobian product of the adjoint pass and the Jacobian-vector product
of the tangent-linear pass) on states stored the way its backend computes with
them, so that a shooting converts its inputs once on the way in
(:meth:`HamiltonianSystem.to_layout`) and its outputs once on the way out
(:meth:`HamiltonianSystem.from_layout`), not at every kernel sum. The kernel field of
fixed control points and momenta (:meth:`HamiltonianSystem.velocity` and its
derivatives) serves the stationary flows in the same layout
(:func:`~manifolds.lddmm.stationary_flow.kernel_flow`):

* :class:`HamiltonianSystem` (the ``"numpy"`` backend, the reference): ``(n, d)``
  arrays, the sums of :class:`~manifolds.lddmm.kernels.GaussianKernel`;
* :class:`CompiledHamiltonianSystem` (the ``"numba"`` backend): contiguous
  ``(3, n)`` coordinate arrays (2-D points padded with a zero coordinate), and the
  compiled loops of :mod:`manifolds.lddmm.kernels_numba` called directly.

:func:`hamiltonian_system` returns the one for a kernel's backend; a new backend
registers its system with :func:`register_system`.
"""

from __future__ import annotations

import numpy as np

from .kernels import GaussianKernel

__all__ = [
    "HamiltonianSystem",
    "CompiledHamiltonianSystem",
    "hamiltonian_system",
    "register_system",
]

State = tuple


class HamiltonianSystem:
    """Right-hand side of eq. 2 and its derivatives on ``(n, d)`` arrays (numpy backend).

    Parameters
    ----------
    kernel : GaussianKernel

    Notes
    -----
    ``dc/dt = K(c, c) mu``, ``dmu/dt = (2/sigma^2) sum_j (mu_i . mu_j) K_ij (c_i - c_j)``
    and ``dx/dt = K(x, c) mu`` for carried points.
    """

    def __init__(self, kernel: GaussianKernel):
        self.kernel = kernel

    def to_layout(self, *arrays) -> State:
        """``(n, d)`` arrays in the system's layout (here: as they are, in float64)."""
        return tuple(np.asarray(a, dtype=float) for a in arrays)

    def from_layout(self, arr: np.ndarray, d: int) -> np.ndarray:
        """One array of the system's layout back to ``(n, d)``."""
        return arr

    def velocity(self, x, c, mom):
        """The kernel field ``v(x_i) = sum_j K(x_i, c_j) mom_j`` (all in the layout)."""
        return self.kernel.convolve(x, c, mom)

    def velocity_vjp(self, x, c, mom, cot) -> State:
        """Gradients ``(g_x, g_c, g_mom)`` of ``<cot, velocity(x, c, mom)>``."""
        return self.kernel.convolve_vjp(x, c, mom, cot)

    def velocity_jvp(self, x, c, mom, dx, dc, dmom):
        """Tangent of ``velocity(x, c, mom)`` along ``(dx, dc, dmom)``."""
        return self.kernel.convolve_jvp(x, c, mom, dx, dc, dmom)

    def rhs(self, state: State) -> State:
        """``(dc/dt, dmu/dt[, dx/dt])`` at ``state = (c, mu[, x])``."""
        c, mu = state[0], state[1]
        dc, dmu = self.kernel.hamiltonian_rhs(c, mu)
        if len(state) == 2:
            return dc, dmu
        return dc, dmu, self.kernel.convolve(state[2], c, mu)

    def rhs_vjp(self, state: State, cot: State) -> State:
        """Gradient of ``<cot, rhs(state)>`` with respect to ``state``."""
        c, mu = state[0], state[1]
        g_c, g_mu = self.kernel.hamiltonian_vjp(c, mu, cot[0], cot[1])
        if len(state) == 2:
            return g_c, g_mu
        g_x, g_c2, g_mu2 = self.kernel.convolve_vjp(state[2], c, mu, cot[2])
        return g_c + g_c2, g_mu + g_mu2, g_x

    def rhs_jvp(self, state: State, tan: State) -> State:
        """Tangent of ``rhs`` at ``state`` along ``tan``."""
        c, mu = state[0], state[1]
        d_dc, d_dmu = self.kernel.hamiltonian_jvp(c, mu, tan[0], tan[1])
        if len(state) == 2:
            return d_dc, d_dmu
        return d_dc, d_dmu, self.kernel.convolve_jvp(state[2], c, mu, tan[2], tan[0], tan[1])


class CompiledHamiltonianSystem(HamiltonianSystem):
    """The same system on ``(3, n)`` arrays with the compiled loops (numba backend).

    Every sum picks its serial or parallel loop by its number of pairs
    (:func:`~manifolds.kernels.numba_primitives.use_parallel`); the loops, hence the
    results, are those of the kernel's own ``(n, d)`` methods, without their layout
    conversions.
    """

    def __init__(self, kernel: GaussianKernel):
        super().__init__(kernel)
        from ..kernels.numba_primitives import check_dim, from_soa, to_soa, use_parallel
        from . import kernels_numba as nb
        from . import kernels_numba_jvp as nbj

        self._check, self._to, self._from, self._par = check_dim, to_soa, from_soa, use_parallel
        self._s = float(kernel.inv_s2)
        self._rhs, self._conv = nb.LOOPS["hamiltonian_rhs"], nb.LOOPS["convolve"]
        self._hvjp, self._cvjp = nb.LOOPS["hamiltonian_vjp"], nb.LOOPS["convolve_vjp"]
        self._hjvp, self._cjvp = nbj.LOOPS["hamiltonian_jvp"], nbj.LOOPS["convolve_jvp"]
        self._chunks = nb.CVJP_CHUNKS

    def to_layout(self, *arrays) -> State:
        arrays = tuple(np.asarray(a, dtype=float) for a in arrays)
        self._check(*arrays)
        return tuple(self._to(a) for a in arrays)

    def from_layout(self, arr: np.ndarray, d: int) -> np.ndarray:
        return self._from(arr, d)

    def velocity(self, x, c, mom):
        v = np.empty((3, x.shape[1]))
        self._conv[self._par(x.shape[1] * c.shape[1])](x, c, mom, self._s, v)
        return v

    def velocity_vjp(self, x, c, mom, cot) -> State:
        n = c.shape[1]
        chunks = max(1, min(self._chunks, x.shape[1]))
        g_x = np.empty((3, x.shape[1]))
        buf_c, buf_m = np.zeros((chunks, 3, n)), np.zeros((chunks, 3, n))
        self._cvjp[self._par(x.shape[1] * n)](x, c, mom, cot, self._s, g_x, buf_c, buf_m)
        return g_x, buf_c.sum(axis=0), buf_m.sum(axis=0)

    def velocity_jvp(self, x, c, mom, dx, dc, dmom):
        t_x = np.empty((3, x.shape[1]))
        self._cjvp[self._par(x.shape[1] * c.shape[1])](x, c, mom, dx, dc, dmom, self._s, t_x)
        return t_x

    def rhs(self, state: State) -> State:
        c, mu = state[0], state[1]
        n = c.shape[1]
        dc, dmu = np.empty((3, n)), np.empty((3, n))
        self._rhs[self._par(n * n)](c, mu, self._s, dc, dmu)
        if len(state) == 2:
            return dc, dmu
        x = state[2]
        v = np.empty((3, x.shape[1]))
        self._conv[self._par(x.shape[1] * n)](x, c, mu, self._s, v)
        return dc, dmu, v

    def rhs_vjp(self, state: State, cot: State) -> State:
        c, mu = state[0], state[1]
        n = c.shape[1]
        g_c, g_mu = np.empty((3, n)), np.empty((3, n))
        self._hvjp[self._par(n * n)](c, mu, cot[0], cot[1], self._s, g_c, g_mu)
        if len(state) == 2:
            return g_c, g_mu
        x = state[2]
        chunks = max(1, min(self._chunks, x.shape[1]))
        g_x = np.empty((3, x.shape[1]))
        buf_c, buf_m = np.zeros((chunks, 3, n)), np.zeros((chunks, 3, n))
        self._cvjp[self._par(x.shape[1] * n)](x, c, mu, cot[2], self._s, g_x, buf_c, buf_m)
        return g_c + buf_c.sum(axis=0), g_mu + buf_m.sum(axis=0), g_x

    def rhs_jvp(self, state: State, tan: State) -> State:
        c, mu = state[0], state[1]
        n = c.shape[1]
        t_c, t_mu = np.empty((3, n)), np.empty((3, n))
        self._hjvp[self._par(n * n)](c, mu, tan[0], tan[1], self._s, t_c, t_mu)
        if len(state) == 2:
            return t_c, t_mu
        x = state[2]
        t_x = np.empty((3, x.shape[1]))
        self._cjvp[self._par(x.shape[1] * n)](x, c, mu, tan[2], tan[0], tan[1], self._s, t_x)
        return t_c, t_mu, t_x


_SYSTEMS: dict[str, type[HamiltonianSystem]] = {
    "numpy": HamiltonianSystem,
    "numba": CompiledHamiltonianSystem,
}


def register_system(backend: str, system: type[HamiltonianSystem]) -> None:
    """Use ``system`` for the kernels of ``backend`` (a backend of :mod:`manifolds.kernels`)."""
    if not (isinstance(system, type) and issubclass(system, HamiltonianSystem)):
        raise TypeError(
            f"register_system: system: expected a HamiltonianSystem subclass, got {system!r}"
        )
    _SYSTEMS[str(backend)] = system


def hamiltonian_system(kernel: GaussianKernel) -> HamiltonianSystem:
    """The Hamiltonian system of eq. 2 for ``kernel``, in its backend's layout."""
    return _SYSTEMS.get(kernel.backend, HamiltonianSystem)(kernel)
