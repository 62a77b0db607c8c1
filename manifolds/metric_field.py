"""A Riemannian manifold given by a field of metric matrices on an open set of R^n.

The geometry is computed from the metric alone: Christoffel symbols, the
Riemann tensor and its covariant derivative by automatic differentiation
(:mod:`autograd`), ``exp`` and parallel transport by integrating ODEs
(:mod:`manifolds.numerics.geodesic_ode`), ``log`` by Newton shooting
(:mod:`manifolds.numerics.shooting`).

Curvature sign convention (used by :meth:`MetricField.curvature`)::

    R(X, Y) Z = nabla_X nabla_Y Z - nabla_Y nabla_X Z - nabla_[X, Y] Z,

in coordinates ``R(d_i, d_j) d_k = R^l_ijk d_l`` with
``R^l_ijk = d_i Gamma^l_jk - d_j Gamma^l_ik + Gamma^l_im Gamma^m_jk - Gamma^l_jm Gamma^m_ik``,
so that the sectional curvature is ``K(u, v) = <R(u, v) v, u> / (|u|^2 |v|^2 - <u, v>^2)``
(``+1`` on the unit sphere).
"""

from __future__ import annotations

from collections.abc import Callable

import autograd.numpy as anp
import numpy as np
from autograd import jacobian

from .errors import ManifoldError, NotOnManifoldError
from .numerics.geodesic_ode import GeodesicIntegrator
from .numerics.shooting import ShootingSolver
from .riemannian import RiemannianManifold
from .validation import check_array, check_float, check_n_samples, check_rng

__all__ = ["MetricField", "christoffel_from_jet"]


def christoffel_from_jet(g, dg, d2g=None):
    """Christoffel symbols (and their derivative) from the metric and its derivatives.

    Parameters
    ----------
    g : array, shape ``(n, n)``
        Metric matrix ``g_ab``.
    dg : array, shape ``(n, n, n)``
        ``dg[a, b, l] = d_l g_ab``.
    d2g : array, shape ``(n, n, n, n)``, optional
        ``d2g[a, b, l, m] = d_l d_m g_ab``.

    Returns
    -------
    gamma : array, shape ``(n, n, n)``
        ``gamma[k, i, j] = Gamma^k_ij = 1/2 g^km (d_i g_mj + d_j g_mi - d_m g_ij)``.
    dgamma : array, shape ``(n, n, n, n)``, only if ``d2g`` is given
        ``dgamma[k, i, j, l] = d_l Gamma^k_ij``.
    """
    n = g.shape[0]
    ginv = np.linalg.inv(g)
    low = 0.5 * (dg.transpose(0, 2, 1) + dg - dg.transpose(2, 0, 1))  # [m, i, j]
    gamma = (ginv @ low.reshape(n, n * n)).reshape(n, n, n)
    if d2g is None:
        return gamma
    dlow = 0.5 * (d2g.transpose(0, 2, 1, 3) + d2g - d2g.transpose(2, 0, 1, 3))  # [m, i, j, l]
    dlow = dlow - np.einsum("mbl,bij->mijl", dg, gamma)
    dgamma = (ginv @ dlow.reshape(n, n * n * n)).reshape(n, n, n, n)
    return gamma, dgamma


class MetricField(RiemannianManifold):
    """Open set of ``R^n`` with the metric ``g(x)`` and its Levi-Civita connection.

    Parameters
    ----------
    metric_matrix : callable
        ``x -> g(x)``, the symmetric positive-definite ``(n, n)`` metric at the
        coordinates ``x`` (shape ``(n,)``), written with :mod:`autograd.numpy`
        so that it can be differentiated three times.
    dim : int
        Dimension ``n``.
    domain : callable, optional
        ``x -> bool``, the open set where ``g`` is defined (e.g. ``x[1] > 0``);
        default: all of ``R^n``.
    metric_jet : callable, optional
        Fast closed form ``(x, order) -> (g, dg)`` for ``order = 1`` and
        ``(g, dg, d2g)`` for ``order = 2`` with ``dg[a, b, l] = d_l g_ab`` and
        ``d2g[a, b, l, m] = d_l d_m g_ab``, used by the ODEs instead of autograd.
        Curvature always comes from autograd on ``metric_matrix``.
    integrator : GeodesicIntegrator, optional
        ODE integrator (default DOP853 with ``rtol = atol = 1e-12``).
    shooting : ShootingSolver, optional
        Newton shooting solver used by :meth:`log`.
    sampling_box : pair of arrays, optional
        ``(low, high)`` corners of the box where :meth:`random_point` samples
        (default ``[-1, 1]^n``), intersected with ``domain``.

    Notes
    -----
    One point per call (``supports_batch = False``). The curvature follows
    ``R(X, Y) Z = nabla_X nabla_Y Z - nabla_Y nabla_X Z - nabla_[X, Y] Z``.
    """

    is_symmetric = False
    supports_batch = False

    def __init__(
        self,
        metric_matrix: Callable,
        dim: int,
        domain: Callable[[np.ndarray], bool] | None = None,
        *,
        metric_jet: Callable | None = None,
        integrator: GeodesicIntegrator | None = None,
        shooting: ShootingSolver | None = None,
        sampling_box=None,
    ):
        if not callable(metric_matrix):
            raise TypeError("metric_matrix: expected a callable x -> (n, n) array")
        if isinstance(dim, bool) or int(dim) != dim or dim < 1:
            raise ValueError(f"dim: expected a positive integer, got {dim!r}")
        if domain is not None and not callable(domain):
            raise TypeError("domain: expected a callable x -> bool or None")
        self.dim = int(dim)
        self.point_shape = (self.dim,)
        self.metric_matrix = metric_matrix
        self.domain = domain
        self.metric_jet = metric_jet
        self.integrator = GeodesicIntegrator() if integrator is None else integrator
        self.shooting = ShootingSolver() if shooting is None else shooting
        if sampling_box is None:
            low, high = -np.ones(self.dim), np.ones(self.dim)
        else:
            low = check_array(sampling_box[0], self.point_shape, "sampling_box[0]")
            high = check_array(sampling_box[1], self.point_shape, "sampling_box[1]")
            if not np.all(high > low):
                raise ValueError("sampling_box: expected high > low in every coordinate")
        self.sampling_box = (np.array(low, dtype=float), np.array(high, dtype=float))
        self._dg = jacobian(metric_matrix)
        self._d2g = jacobian(self._dg)
        self._dgamma_ag = jacobian(self._gamma_ag)
        self._driemann_ag = jacobian(self._riemann_ag)

    # ------------------------------------------------------------ input checks
    def _in_domain(self, x) -> bool:
        return bool(np.isfinite(x).all()) and (self.domain is None or bool(self.domain(x)))

    def belongs(self, point, atol: float | None = None):
        """Whether ``point`` has shape ``(..., n)``, is finite and lies in the domain."""
        arr = np.asarray(point, dtype=float)
        if arr.ndim < 1 or arr.shape[-1] != self.dim:
            return False
        flat = arr.reshape(-1, self.dim)
        ok = np.array([self._in_domain(x) for x in flat], dtype=bool)
        return ok.reshape(arr.shape[:-1]) if arr.ndim > 1 else bool(ok[0])

    def _belongs_hint(self, point) -> str:
        return ": it lies outside the domain of the metric"

    def _single(self, arr: np.ndarray, name: str) -> np.ndarray:
        if arr.ndim != 1:
            raise ManifoldError(
                f"{self.name}: {name} must be a single point of shape ({self.dim},) "
                f"(batches are not supported), got shape {arr.shape}"
            )
        return arr

    def _point(self, point, name: str = "point") -> np.ndarray:
        arr = check_array(point, self.point_shape, f"{self.name}: {name}")
        self._single(arr, name)
        if not self._in_domain(arr):
            raise NotOnManifoldError(
                f"{self.name}: {name} = {arr.tolist()} lies outside the domain of the metric"
            )
        return arr

    def _vector(self, vector, name: str = "tangent") -> np.ndarray:
        arr = check_array(vector, self.point_shape, f"{self.name}: {name}")
        return self._single(arr, name)

    # ------------------------------------------------------------ metric and Christoffel
    def metric(self, point) -> np.ndarray:
        """Metric matrix ``g(point)``, shape ``(n, n)``."""
        x = self._point(point)
        g = np.asarray(self.metric_matrix(x), dtype=float)
        if g.shape != (self.dim, self.dim):
            raise ValueError(
                f"metric_matrix: expected an array of shape {(self.dim, self.dim)}, got {g.shape}"
            )
        return g

    def _jet(self, x: np.ndarray, order: int):
        if self.metric_jet is not None:
            return self.metric_jet(x, order)
        g = np.asarray(self.metric_matrix(x), dtype=float)
        if order == 1:
            return g, self._dg(x)
        return g, self._dg(x), self._d2g(x)

    def _christoffel(self, x: np.ndarray) -> np.ndarray:
        return christoffel_from_jet(*self._jet(x, 1))

    def _christoffel_jet(self, x: np.ndarray):
        return christoffel_from_jet(*self._jet(x, 2))

    def christoffel(self, point) -> np.ndarray:
        """Christoffel symbols ``Gamma[k, i, j] = Gamma^k_ij`` at ``point`` by autograd.

        ``nabla_{d_i} d_j = Gamma^k_ij d_k``; shape ``(n, n, n)``.
        """
        return np.asarray(self._gamma_ag(self._point(point)), dtype=float)

    # ------------------------------------------------------------ autograd tensors
    def _gamma_ag(self, x):
        g = self.metric_matrix(x)
        dg = self._dg(x)
        low = 0.5 * (anp.transpose(dg, (0, 2, 1)) + dg - anp.transpose(dg, (2, 0, 1)))
        return anp.einsum("km,mij->kij", anp.linalg.inv(g), low)

    def _riemann_ag(self, x):
        gam = self._gamma_ag(x)
        dgam = self._dgamma_ag(x)  # [l, j, k, i] = d_i Gamma^l_jk
        return (
            anp.transpose(dgam, (0, 3, 1, 2))
            - anp.transpose(dgam, (0, 1, 3, 2))
            + anp.einsum("lim,mjk->lijk", gam, gam)
            - anp.einsum("ljm,mik->lijk", gam, gam)
        )

    def riemann_tensor(self, point) -> np.ndarray:
        """Riemann tensor ``R[l, i, j, k] = R^l_ijk`` with ``R(d_i, d_j) d_k = R^l_ijk d_l``.

        Convention ``R(X, Y) Z = nabla_X nabla_Y Z - nabla_Y nabla_X Z - nabla_[X, Y] Z``;
        shape ``(n, n, n, n)``.
        """
        return np.asarray(self._riemann_ag(self._point(point)), dtype=float)

    def riemann_derivative(self, point) -> np.ndarray:
        """Covariant derivative ``DR[l, i, j, k, m] = (nabla_m R)^l_ijk``, shape ``(n,)*5``.

        ``(nabla_m R)^l_ijk = d_m R^l_ijk + Gamma^l_mp R^p_ijk - Gamma^p_mi R^l_pjk
        - Gamma^p_mj R^l_ipk - Gamma^p_mk R^l_ijp``.
        """
        x = self._point(point)
        gam = np.asarray(self._gamma_ag(x), dtype=float)
        r = np.asarray(self._riemann_ag(x), dtype=float)
        dr = np.asarray(self._driemann_ag(x), dtype=float)  # [l, i, j, k, m]
        return (
            dr
            + np.einsum("lmp,pijk->lijkm", gam, r)
            - np.einsum("pmi,lpjk->lijkm", gam, r)
            - np.einsum("pmj,lipk->lijkm", gam, r)
            - np.einsum("pmk,lijp->lijkm", gam, r)
        )

    def curvature(self, point, u, v, w):
        """``R(u, v) w`` at ``point`` (convention in the module docstring), shape ``(n,)``."""
        r = self.riemann_tensor(point)
        u, v, w = (self._vector(a, nm) for a, nm in ((u, "u"), (v, "v"), (w, "w")))
        return np.einsum("lijk,i,j,k->l", r, u, v, w)

    def curvature_derivative(self, point, x, u, v, w):
        """``(nabla_x R)(u, v) w`` at ``point``, shape ``(n,)`` (paper, Section 2.4)."""
        dr = self.riemann_derivative(point)
        vecs = [self._vector(a, nm) for a, nm in ((x, "x"), (u, "u"), (v, "v"), (w, "w"))]
        x, u, v, w = vecs
        return np.einsum("lijkm,m,i,j,k->l", dr, x, u, v, w)

    def sectional_curvature(self, point, u, v) -> float:
        """``K(u, v) = <R(u, v) v, u> / (|u|^2 |v|^2 - <u, v>^2)``."""
        num = self.inner(point, self.curvature(point, u, v, v), u)
        den = self.inner(point, u, u) * self.inner(point, v, v) - self.inner(point, u, v) ** 2
        if not den > 0:
            raise ManifoldError(f"{self.name}: u and v must be linearly independent")
        return float(num / den)

    # ------------------------------------------------------------ maps
    def _shoot(self, x: np.ndarray, v: np.ndarray, transport=None, variational=False):
        return self.integrator.integrate(
            self._christoffel,
            x,
            v,
            transport=transport,
            christoffel_jet=self._christoffel_jet if variational else None,
            domain=self.domain,
        )

    def exp(self, point, tangent):
        """``Exp_point(tangent)``: the geodesic ODE integrated to ``t = 1``, shape ``(n,)``.

        Raises :class:`~manifolds.numerics.geodesic_ode.GeodesicDomainError`
        (a :class:`~manifolds.errors.ConvergenceError`) if the geodesic leaves the domain.
        """
        x = self._point(point)
        v = self._vector(tangent)
        return self._shoot(x, v).position

    def exp_with_jacobian(self, point, tangent):
        """``Exp_point(tangent)`` and its differential ``dExp_point(tangent)``, shape ``(n, n)``."""
        x = self._point(point)
        v = self._vector(tangent)
        sol = self._shoot(x, v, variational=True)
        return sol.position, sol.jacobian

    def log(self, point, other):
        """``Log_point(other)`` by Newton shooting; raises ConvergenceError on failure."""
        x = self._point(point)
        y = self._point(other, "other")

        def exp_jac(v):
            sol = self._shoot(x, v, variational=True)
            return sol.position, sol.jacobian

        return self.shooting.solve(exp_jac, x, y)

    def transport_along(self, point, tangent, vectors):
        """Exp and parallel transport along ``t -> Exp_point(t tangent)``, ``t in [0, 1]``.

        Parameters
        ----------
        point, tangent : arrays, shape ``(n,)``
        vectors : array, shape ``(m, n)`` or ``(n,)``

        Returns
        -------
        end : array, shape ``(n,)``
        transported : array, same shape as ``vectors``
        """
        x = self._point(point)
        v = self._vector(tangent)
        vecs = check_array(vectors, self.point_shape, f"{self.name}: vectors")
        sol = self._shoot(x, v, transport=vecs.reshape(-1, self.dim))
        return sol.position, sol.transported.reshape(vecs.shape)

    def parallel_transport(self, point, end, tangent):
        """Parallel transport of ``tangent`` along the geodesic ``point -> end`` (ODE)."""
        x = self._point(point)
        self._point(end, "end")
        w = self._vector(tangent)
        return self.transport_along(x, self.log(x, end), w)[1]

    def inner(self, point, u, v):
        """``<u, v>_point = u^T g(point) v``."""
        g = self.metric(point)
        return float(self._vector(u, "u") @ g @ self._vector(v, "v"))

    # ------------------------------------------------------------ sampling
    def random_point(self, rng: np.random.Generator, n_samples: int | None = None):
        """Uniform in ``sampling_box`` intersected with the domain (rejection)."""
        n_samples = check_n_samples(n_samples)
        check_rng(rng)
        low, high = self.sampling_box
        count = 1 if n_samples is None else n_samples
        out = []
        for _ in range(1000 * count):
            x = low + (high - low) * rng.random(self.dim)
            if self._in_domain(x):
                out.append(x)
                if len(out) == count:
                    break
        if len(out) < count:
            raise ManifoldError(f"{self.name}: sampling_box hardly meets the domain")
        return out[0] if n_samples is None else np.stack(out)

    def random_tangent(self, point, rng: np.random.Generator, scale: float = 1.0):
        """``scale * L^-T z`` with ``g = L L^T`` and ``z`` standard normal (isotropic in g)."""
        low = np.linalg.cholesky(self.metric(point))
        check_rng(rng)
        scale = check_float(scale, f"{self.name}: scale", minimum=0.0)
        return scale * np.linalg.solve(low.T, rng.standard_normal(self.dim))

    def __repr__(self) -> str:
        return f"{self.name}(dim={self.dim})"
