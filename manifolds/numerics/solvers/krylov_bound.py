"""How few gradients any Krylov-type solver needs on a quadratic model: a lower bound.

On the quadratic ``q(x) = 1/2 (x - x*)^T H (x - x*)`` started at ``x0``, the ``k``-th
iterate of a method that builds its steps from gradients or Hessian-vector products
(gradient descent, CG, L-BFGS with a scaled-identity start, Newton-CG) lies in the
affine Krylov space ``x0 + K_k(H, g0)``, ``g0 = H (x0 - x*)``. The error it can reach
after ``k`` products is therefore at least

    e_k = min over x in x0 + K_k(H, g0) of |J (x - x*)|,

for whatever output map ``J`` measures the error (for a registration: the Jacobian of
the deformed template, so that ``e_k`` is in the shapes' unit). :func:`krylov_lower_bound`
computes ``e_k`` for every ``k`` from an orthonormal Krylov basis (Lanczos with full
reorthogonalisation) and one QR factorisation of ``J V``, and, for comparison, the
iterations conjugate gradients take (CG minimises the ``H``-norm of the error over the
same spaces, so it needs at least as many as the bound when ``J^T J != H``).

A bound in one set of variables: a preconditioner changes ``H`` and the spaces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["KrylovBound", "krylov_lower_bound"]


@dataclass(frozen=True)
class KrylovBound:
    """Output of :func:`krylov_lower_bound`.

    Attributes
    ----------
    errors : array, shape ``(m,)``
        ``errors[k - 1] = e_k / sqrt(n_points)`` (per-point RMS) for ``k = 1..m``,
        ``m`` the dimension the Krylov spaces reach.
    start_error : float
        The same measure at ``x0``.
    cg_errors : array
        The error of CG's ``k``-th iterate, same measure, until it meets ``tol`` or
        ``max_cg`` iterations.
    """

    errors: np.ndarray
    start_error: float
    cg_errors: np.ndarray

    def first_below(self, tol: float) -> int | None:
        """Smallest ``k`` with ``e_k <= tol`` (None if no Krylov space reaches it)."""
        hits = np.flatnonzero(self.errors <= tol)
        return int(hits[0]) + 1 if hits.size else None

    def cg_first_below(self, tol: float) -> int | None:
        """Iterations CG took to reach ``tol`` (None if it did not within its budget)."""
        hits = np.flatnonzero(self.cg_errors <= tol)
        return int(hits[0]) + 1 if hits.size else None


def _rms(v: np.ndarray, n_points: int) -> float:
    return float(np.sqrt(max(float(v @ v), 0.0) / n_points))


def krylov_lower_bound(
    H, J, x0, x_star, *, n_points: int | None = None, tol: float = 0.0, max_cg: int | None = None
) -> KrylovBound:
    """Smallest error any Krylov-type method can reach after each number of products.

    Parameters
    ----------
    H : array, shape ``(n, n)``
        Symmetric positive definite Hessian of the quadratic model.
    J : array, shape ``(m, n)``
        Output map the error is measured with.
    x0, x_star : arrays, shape ``(n,)``
        Start and minimiser.
    n_points : int, optional
        The errors are ``|J e| / sqrt(n_points)`` (per-point RMS of ``(n_points, d)``
        outputs); default ``m`` (RMS per entry).
    tol : float
        CG stops once its error is at most this.
    max_cg : int, optional
        CG's iteration budget (default ``20 n``).

    Returns
    -------
    KrylovBound
    """
    H = np.asarray(H, dtype=float)
    J = np.asarray(J, dtype=float)
    n = H.shape[0]
    if H.shape != (n, n) or J.ndim != 2 or J.shape[1] != n:
        raise ValueError(
            f"krylov_lower_bound: H must be (n, n) and J (m, n); got {H.shape} and {J.shape}"
        )
    if not (np.isfinite(H).all() and np.isfinite(J).all()):
        raise ValueError("krylov_lower_bound: H and J must be finite")
    n_points = J.shape[0] if n_points is None else int(n_points)
    e0 = np.asarray(x0, dtype=float) - np.asarray(x_star, dtype=float)
    g0 = H @ e0
    base = J @ e0
    start = _rms(base, n_points)
    if not np.linalg.norm(g0) > 0:
        return KrylovBound(np.array([start]), start, np.array([start]))
    V = np.zeros((n, n))
    V[:, 0] = g0 / np.linalg.norm(g0)
    size, scale = 1, np.linalg.norm(H, 2)
    for k in range(1, n):
        w = H @ V[:, k - 1]
        for _ in range(2):  # full reorthogonalisation, twice is enough
            w -= V[:, :k] @ (V[:, :k].T @ w)
        norm = np.linalg.norm(w)
        if norm <= 1e-13 * scale:  # the spaces stop growing
            break
        V[:, k] = w / norm
        size = k + 1
    # nested spans: with J V = Q R, min_y |base + J V_k y|^2 = |base - Q_k Q_k^T base|^2,
    # the part of base outside span(Q) plus the components along Q_{k+1..size}: a sum of
    # squares, summed from the smallest (|base|^2 - |Q_k^T base|^2 would lose all digits
    # below sqrt(eps) |base| to cancellation)
    Q, _ = np.linalg.qr(J @ V[:, :size])
    coef = Q.T @ base
    outside = base - Q @ coef
    tail = np.concatenate([np.cumsum((coef**2)[::-1])[::-1][1:], [0.0]])
    errors = np.sqrt((float(outside @ outside) + tail) / n_points)
    # CG on H e = 0 from e0
    e, r = e0.copy(), -g0
    p = r.copy()
    cg = []
    for _ in range(20 * n if max_cg is None else int(max_cg)):
        hp = H @ p
        curvature = p @ hp
        if not curvature > 0:
            break
        step = (r @ r) / curvature
        e += step * p
        r_new = r - step * hp
        cg.append(_rms(J @ e, n_points))
        if cg[-1] <= tol or not np.linalg.norm(r_new) > 0:
            break
        p = r_new + (r_new @ r_new) / (r @ r) * p
        r = r_new
    return KrylovBound(errors, start, np.array(cg))
