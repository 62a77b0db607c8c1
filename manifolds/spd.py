"""Symmetric positive definite matrices with the affine-invariant metric.

``SPD(n) = GL(n) / O(n)`` is a Riemannian symmetric space of non-positive
curvature, used to validate :mod:`ladders` on a space whose curvature is not
constant (the pole ladder is still exact there: paper, eq. 4 with ``nabla R = 0``).
All matrix functions are computed from ``eigh`` of symmetric matrices.
"""

from __future__ import annotations

import numpy as np

from .errors import NotOnManifoldError, NotTangentError
from .riemannian import RiemannianManifold
from .validation import (
    as_float_array,
    check_batch_shapes,
    check_finite,
    check_finite_result,
    check_float,
    check_int,
    check_n_samples,
    check_rng,
    check_shape,
)

__all__ = ["SPDMatrices"]


def _tr(a):
    return np.swapaxes(a, -1, -2)


def _sym(a):
    return 0.5 * (a + _tr(a))


def _fun(vals, vecs, f):
    """``U f(diag) U^T`` for an eigendecomposition ``(vals, vecs)``."""
    return (vecs * f(vals)[..., None, :]) @ _tr(vecs)


def _asym(a):
    """Largest asymmetry ``max|A - A^T|`` and scale ``max(1, max|A|)`` per matrix."""
    return np.abs(a - _tr(a)).max(axis=(-2, -1)), np.maximum(np.abs(a).max(axis=(-2, -1)), 1.0)


class SPDMatrices(RiemannianManifold):
    """``n x n`` symmetric positive definite matrices, affine-invariant metric.

    Metric ``<U, V>_P = tr(P^-1 U P^-1 V)``. With ``P^1/2`` and the whitened
    vector ``X = P^-1/2 V P^-1/2``:

    * ``Exp_P(V) = P^1/2 expm(X) P^1/2``, ``Log_P(Q) = P^1/2 logm(P^-1/2 Q P^-1/2) P^1/2``;
    * transport from ``P`` to ``Q``: ``E U E^T`` with ``E = P^1/2 W^1/2 P^-1/2`` and
      ``W = P^-1/2 Q P^-1/2`` (``= P^1/2 expm(1/2 P^-1/2 Log_P(Q) P^-1/2) P^-1/2``);
    * symmetry ``s_M(S) = M S^-1 M``, midpoint ``P^1/2 W^1/2 P^1/2``.

    The whitening is done in the eigenbasis ``P = U diag(l) U^T`` (never with a
    general ``expm``/``logm``) and outputs are symmetrised.

    Curvature convention: ``R(u, v) w = nabla_u nabla_v w - nabla_v nabla_u w -
    nabla_[u,v] w``, sectional curvature ``<R(u, v) v, u> / (|u|^2 |v|^2 -
    <u, v>^2)``. Here ``R(u, v) w = -1/4 P^1/2 [[X, Y], Z] P^1/2`` with ``X, Y, Z``
    the whitened ``u, v, w``, so that ``<R(u, v) v, u> = -1/4 |[X, Y]|_F^2 <= 0``.

    Membership: ``max|P - P^T| <= atol max(1, max|P|)`` and all eigenvalues ``> 0``.

    Parameters
    ----------
    n : int
        Matrix size.
    """

    is_symmetric = True
    supports_batch = True

    def __init__(self, n: int):
        self.n = check_int(n, "SPDMatrices: n", minimum=1)
        self.dim = self.n * (self.n + 1) // 2
        self.point_shape = (self.n, self.n)

    def __repr__(self) -> str:
        return f"SPDMatrices({self.n})"

    # ------------------------------------------------------------------ checks
    def belongs(self, point, atol: float | None = None):
        """Whether ``point`` is symmetric (within ``atol``, relative) and positive definite."""
        tol = self.atol if atol is None else atol
        arr = np.asarray(point, dtype=float)
        if arr.ndim < 2 or arr.shape[-2:] != self.point_shape:
            return False
        finite = np.isfinite(arr).all(axis=(-2, -1))
        arr = np.where(finite[..., None, None], arr, np.eye(self.n))
        asym, scale = _asym(arr)
        return finite & (asym <= tol * scale) & (np.linalg.eigvalsh(_sym(arr))[..., 0] > 0)

    def _belongs_hint(self, point) -> str:
        arr = np.asarray(point, dtype=float)
        asym, scale = _asym(arr)
        if not (asym <= self.atol * scale).all():
            return f": not symmetric (max |P - P^T| = {asym.max():.3g})"
        low = np.linalg.eigvalsh(_sym(arr))[..., 0].min()
        return f": not positive definite (smallest eigenvalue {low:.3g})"

    def is_tangent(self, point, vector, atol: float | None = None):
        """Whether ``vector`` is symmetric within ``atol`` (relative to its size)."""
        tol = self.atol if atol is None else atol
        v = np.asarray(vector, dtype=float)
        if v.ndim < 2 or v.shape[-2:] != self.point_shape:
            return False
        asym, scale = _asym(v)
        return asym <= tol * scale

    def _fail(self, arr, name: str):
        self.check_point(arr, name)
        raise NotOnManifoldError(f"{self.name}: {name} is not positive definite")

    def _matrix(self, point, name: str) -> np.ndarray:
        """Symmetrised point after the shape, finiteness and symmetry checks (no PD test)."""
        label = f"{self.name}: {name}"
        arr = check_finite(
            check_shape(as_float_array(point, label), self.point_shape, label), label
        )
        asym, scale = _asym(arr)
        if not (asym <= self.atol * scale).all():
            self._fail(arr, name)
        return _sym(arr)

    def _eig(self, point, name: str):
        """Validated point with its eigendecomposition ``(P, l, U)``."""
        arr = self._matrix(point, name)
        vals, vecs = np.linalg.eigh(arr)
        if not (vals[..., 0] > 0).all():
            self._fail(arr, name)
        return arr, vals, vecs

    def _pd(self, point, name: str) -> np.ndarray:
        """Validated point, positive definiteness tested with a Cholesky factorisation."""
        arr = self._matrix(point, name)
        try:
            np.linalg.cholesky(arr)
        except np.linalg.LinAlgError:
            self._fail(arr, name)
        return arr

    def _vector(self, vector, name: str) -> np.ndarray:
        label = f"{self.name}: {name}"
        arr = check_finite(
            check_shape(as_float_array(vector, label), self.point_shape, label), label
        )
        if not np.all(self.is_tangent(None, arr)):
            raise NotTangentError(f"{self.name}: {name} is not a symmetric matrix")
        return _sym(arr)

    def _batch(self, **arrays) -> None:
        """Raise a named error if the batch axes of ``arrays`` do not broadcast."""
        check_batch_shapes(2, self.name, **arrays)

    def _whiten_other(self, vals, vecs, other, name: str, first: str = "point"):
        """Eigendecomposition of ``P^-1/2 Q P^-1/2`` (in the eigenbasis of ``P``).

        ``Q`` is positive definite if and only if this congruent matrix is, so the
        test of its eigenvalues validates ``Q`` without another factorisation.
        """
        q = self._matrix(other, name)
        check_batch_shapes(2, self.name, **{first: vecs, name: q})
        s = np.sqrt(vals)
        b = (_tr(vecs) @ q @ vecs) / (s[..., :, None] * s[..., None, :])
        mu, w = np.linalg.eigh(_sym(b))
        if not (mu[..., 0] > 0).all():
            self._fail(q, name)
        return s, mu, w

    @staticmethod
    def _unwhiten(s, vecs, x):
        """``P^1/2 X P^1/2`` for ``X`` given in the eigenbasis of ``P``."""
        return _sym(vecs @ (s[..., :, None] * x * s[..., None, :]) @ _tr(vecs))

    # ------------------------------------------------------------------ closed forms
    def exp(self, point, tangent):
        """Exponential map ``P^1/2 expm(P^-1/2 V P^-1/2) P^1/2``.

        Parameters
        ----------
        point : array, shape ``(..., n, n)``
        tangent : array, shape ``(..., n, n)``, symmetric (broadcast against ``point``)

        Returns
        -------
        array, shape ``(..., n, n)``
        """
        p, vals, vecs = self._eig(point, "point")
        v = self._vector(tangent, "tangent")
        self._batch(point=p, tangent=v)
        s = np.sqrt(vals)
        x = (_tr(vecs) @ v @ vecs) / (s[..., :, None] * s[..., None, :])
        mu, w = np.linalg.eigh(_sym(x))
        with np.errstate(over="ignore"):
            big = np.exp(mu)
        check_finite_result(
            big,
            f"{self.name}: tangent",
            f"too large for exp in float64 (whitened eigenvalues up to {np.max(mu):.4g})",
        )
        out = self._unwhiten(s, vecs, _fun(mu, w, np.exp))
        return check_finite_result(out, f"{self.name}: tangent", "too large for exp in float64")

    def log(self, point, other):
        """Logarithm map ``P^1/2 logm(P^-1/2 Q P^-1/2) P^1/2`` (defined everywhere).

        Parameters
        ----------
        point, other : array, shape ``(..., n, n)``

        Returns
        -------
        array, shape ``(..., n, n)``, symmetric
        """
        _, vals, vecs = self._eig(point, "point")
        s, mu, w = self._whiten_other(vals, vecs, other, "other")
        return self._unwhiten(s, vecs, _fun(mu, w, np.log))

    def inner(self, point, u, v):
        """``tr(P^-1 U P^-1 V)``, shape ``(...)``."""
        p, vals, vecs = self._eig(point, "point")
        u, v = self._vector(u, "u"), self._vector(v, "v")
        self._batch(point=p, u=u, v=v)
        ut = _tr(vecs) @ u @ vecs
        vt = _tr(vecs) @ v @ vecs
        return (ut * vt / (vals[..., :, None] * vals[..., None, :])).sum(axis=(-2, -1))

    def dist(self, a, b):
        """``|logm(A^-1/2 B A^-1/2)|_F`` from the eigenvalues of the whitened ``B``."""
        _, vals, vecs = self._eig(a, "a")
        _, mu, _ = self._whiten_other(vals, vecs, b, "b", "a")
        return np.sqrt((np.log(mu) ** 2).sum(axis=-1))

    def squared_dist(self, a, b):
        """Squared affine-invariant distance."""
        return self.dist(a, b) ** 2

    def midpoint(self, a, b):
        """Geometric mean ``A^1/2 (A^-1/2 B A^-1/2)^1/2 A^1/2`` (paper, Section 2.3)."""
        _, vals, vecs = self._eig(a, "a")
        s, mu, w = self._whiten_other(vals, vecs, b, "b", "a")
        return self._unwhiten(s, vecs, _fun(mu, w, np.sqrt))

    def symmetry(self, center, point):
        """Geodesic symmetry ``s_M(S) = M S^-1 M``, computed as ``(M U) diag(1/l) (M U)^T``."""
        m = self._pd(center, "center")
        p, vals, vecs = self._eig(point, "point")
        self._batch(center=m, point=p)
        k = m @ vecs
        out = _sym((k / vals[..., None, :]) @ _tr(k))
        return check_finite_result(out, f"{self.name}: point", "too close to singular")

    def parallel_transport(self, point, end, tangent):
        """Transport ``E U E^T`` along the geodesic ``point -> end``, ``E = P^1/2 W^1/2 P^-1/2``.

        Parameters
        ----------
        point, end : array, shape ``(..., n, n)``
        tangent : array, shape ``(..., n, n)``, symmetric

        Returns
        -------
        array, shape ``(..., n, n)``, symmetric, tangent at ``end``
        """
        _, vals, vecs = self._eig(point, "point")
        s, mu, w = self._whiten_other(vals, vecs, end, "end")
        tangent = self._vector(tangent, "tangent")
        self._batch(point=vecs, end=w, tangent=tangent)
        u = _tr(vecs) @ tangent @ vecs
        e = s[..., :, None] * _fun(mu, w, np.sqrt) / s[..., None, :]
        return _sym(vecs @ (e @ u @ _tr(e)) @ _tr(vecs))

    def curvature(self, point, u, v, w):
        """``R(u, v) w = -1/4 P^1/2 [[X, Y], Z] P^1/2`` (whitened ``X, Y, Z``; class doc)."""
        _, vals, vecs = self._eig(point, "point")
        s = np.sqrt(vals)
        den = s[..., :, None] * s[..., None, :]
        u, v, w = (self._vector(a, n) for a, n in ((u, "u"), (v, "v"), (w, "w")))
        self._batch(point=vecs, u=u, v=v, w=w)
        x, y, z = (_tr(vecs) @ a @ vecs / den for a in (u, v, w))
        xy = x @ y - y @ x
        return self._unwhiten(s, vecs, -0.25 * (xy @ z - z @ xy))

    def curvature_derivative(self, point, x, u, v, w):
        """``(nabla_x R)(u, v) w = 0``: ``SPD(n)`` is a symmetric space."""
        arrays = [self._pd(point, "point")]
        arrays += [self._vector(a, n) for a, n in ((x, "x"), (u, "u"), (v, "v"), (w, "w"))]
        return np.zeros(np.broadcast_shapes(*(a.shape for a in arrays)))

    # ------------------------------------------------------------------ sampling
    def _gaussian_sym(self, rng, lead, scale):
        """Symmetric Gaussian matrices with ``E|G|_F^2 = scale^2``."""
        g = rng.standard_normal((*lead, self.n, self.n))
        return _sym(g) * (scale / np.sqrt(self.dim))

    def random_point(self, rng: np.random.Generator, n_samples: int | None = None):
        """``expm(G)`` with ``G`` symmetric Gaussian, ``E|G|_F^2 = 1``."""
        n_samples = check_n_samples(n_samples)
        lead = () if n_samples is None else (n_samples,)
        vals, vecs = np.linalg.eigh(self._gaussian_sym(check_rng(rng), lead, 1.0))
        return _sym(_fun(vals, vecs, np.exp))

    def random_tangent(self, point, rng: np.random.Generator, scale: float = 1.0):
        """``P^1/2 G P^1/2`` with ``G`` symmetric Gaussian, so ``E|V|_P^2 = scale^2``."""
        _, vals, vecs = self._eig(point, "point")
        check_rng(rng)
        scale = check_float(scale, f"{self.name}: scale", minimum=0.0)
        g = self._gaussian_sym(rng, vals.shape[:-1], scale)
        return self._unwhiten(np.sqrt(vals), vecs, g)
