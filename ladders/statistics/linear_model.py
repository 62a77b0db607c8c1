"""The general linear model fitted at every vertex, and its test statistics.

At each vertex ``v`` the responses of the ``n`` subjects follow ``Y_v = X B_v + E_v``
with the design ``X`` ``(n, p)`` (full column rank) shared by all the vertices; the
hypothesis is ``C B_v = 0`` for a contrast ``C`` ``(q, p)`` of full row rank. With
``D = (X^T X)^{-1}``, ``B = D X^T Y`` and ``nu = n - p`` residual degrees of freedom:

- scalars ``(n, k)``, ``q = 1``: ``t = c B / sqrt(s^2 c D c^T)``, ``s^2 = RSS / nu``,
  Student's ``t(nu)``, two-sided;
- scalars, ``q > 1``: ``F = (CB)^T (C D C^T)^{-1} (CB) / (q s^2)``, ``F(q, nu)``;
- vectors ``(n, k, d)``: with the error scatter ``E = R^T R`` (``R`` the residuals,
  ``d x d``) and the hypothesis scatter ``H = (CB)^T (C D C^T)^{-1} (CB)``, Pillai's
  trace ``V = tr(H (H + E)^{-1})``. With ``s = min(q, d)``, ``m = (|q - d| - 1) / 2``
  and ``N = (nu - d - 1) / 2``, ``F = (2N + s + 1) / (2m + s + 1) * V / (s - V)`` is
  approximately ``F(s (2m + s + 1), s (2N + s + 1))``, exactly when ``s = 1``.

For ``q = 1``, ``H = h h^T`` has rank one (``h = (cB)^T / sqrt(c D c^T)``), so by the
Sherman-Morrison formula the Hotelling-Lawley trace ``U = tr(H E^{-1}) = h^T E^{-1} h``
and Pillai's trace are ``V = U / (1 + U)``; Hotelling's ``T^2 = nu U`` (the error
covariance is ``E / nu``), hence ``T^2 = nu V / (1 - V)``, increasing in ``V``, and
``(nu - d + 1) / (d nu) T^2 ~ F(d, nu - d + 1)``. With the design ``~ group`` this is
the two-sample ``T^2`` of :func:`~ladders.statistics.vertexwise_test` (``nu = n - 2``).

All the statistics are computed from projections on an orthonormal basis of the
design split by the contrast (:func:`contrast_bases`): ``U_x`` spans the part of the
column space of ``X`` tested by ``C`` and ``U_z`` its nuisance part (``X N`` with
``C N = 0``), so that ``H = (U_x^T Y)^T (U_x^T Y)``; one QR of ``X`` serves all the
vertices.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg, stats

__all__ = [
    "LinearFit",
    "fit_statistic",
    "contrast_bases",
    "pillai_f",
    "pillai_to_hotelling",
]


def check_responses(Y) -> tuple[np.ndarray, bool]:
    """Responses as ``(n, k, d)`` float64 and whether they were scalars ``(n, k)``."""
    y = np.asarray(Y, dtype=np.float64)
    if y.ndim not in (2, 3) or min(y.shape) < 1:
        raise ValueError(
            f"Y: expected per-vertex values (n, k) or vectors (n, k, d), got shape {y.shape}"
        )
    if not np.isfinite(y).all():
        raise ValueError("Y: contains NaN or infinite values")
    return (y[..., None], True) if y.ndim == 2 else (y, False)


def check_model(X, C, n: int, d: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """The design ``(n, p)`` and contrast ``(q, p)`` as float64, or raise naming the problem."""
    x = np.asarray(X, dtype=np.float64)
    if x.ndim != 2 or x.shape[0] != n or not np.isfinite(x).all():
        raise ValueError(f"X: expected a finite design ({n}, p), got shape {x.shape}")
    c = np.atleast_2d(np.asarray(C, dtype=np.float64))
    if c.ndim != 2 or c.shape[1] != x.shape[1] or not np.isfinite(c).all():
        raise ValueError(f"C: expected a finite contrast (q, {x.shape[1]}), got shape {c.shape}")
    if np.linalg.matrix_rank(x) < x.shape[1]:
        raise ValueError(f"X: the {x.shape[1]} columns of the design are linearly dependent")
    if np.linalg.matrix_rank(c) < c.shape[0]:
        raise ValueError(f"C: the {c.shape[0]} rows of the contrast are linearly dependent")
    if n - x.shape[1] < d:
        raise ValueError(
            f"X: {n} subjects leave {n - x.shape[1]} residual degrees of freedom for "
            f"{x.shape[1]} regressors; at least {d} are needed for {d} components"
        )
    return x, c


def contrast_bases(X, C) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal bases of the nuisance and the tested parts of the design's column space.

    Parameters
    ----------
    X : array, shape (n, p)
    C : array, shape (q, p)

    Returns
    -------
    U_z : ndarray, shape (n, p - q)
        Spans ``{X b : C b = 0}`` (the reduced model).
    U_x : ndarray, shape (n, q)
        Spans the rest of the column space, orthogonal to ``U_z``; its columns are those
        of ``G^T = X D C^T`` orthonormalised with the same orientation, so that for
        ``q = 1``, ``U_x^T Y = c B / sqrt(c D c^T)``.
    """
    x, c = np.asarray(X, dtype=np.float64), np.atleast_2d(np.asarray(C, dtype=np.float64))
    q_x, r_x = np.linalg.qr(x)
    a = linalg.solve_triangular(r_x, c.T, trans="T")  # R^{-T} C^T: G^T = Q a
    q_a, r_a = np.linalg.qr(a, mode="complete")
    signs = np.sign(np.diag(r_a)[: c.shape[0]])
    u_x = (q_x @ q_a[:, : c.shape[0]]) * np.where(signs == 0, 1.0, signs)
    u_z = q_x @ q_a[:, c.shape[0] :]
    return u_z, u_x


def pillai_f(V, q: int, d: int, df_resid: int) -> tuple[np.ndarray, float, float]:
    """The F approximation of Pillai's trace ``V``: ``(F, df1, df2)`` (module docstring)."""
    s = min(q, d)
    m, big_n = (abs(q - d) - 1) / 2.0, (df_resid - d - 1) / 2.0
    df1, df2 = s * (2 * m + s + 1), s * (2 * big_n + s + 1)
    v = np.asarray(V, dtype=np.float64)
    return df2 / df1 * v / np.maximum(s - v, 1e-300), float(df1), float(df2)


def pillai_to_hotelling(V, df_resid: int) -> np.ndarray:
    """Hotelling's ``T^2 = nu V / (1 - V)`` of Pillai's trace of a one-row contrast."""
    v = np.asarray(V, dtype=np.float64)
    return df_resid * v / np.maximum(1.0 - v, 1e-300)


def pillai_trace(sx: list, mm: list, floor) -> np.ndarray:
    """``sum_r s_r^T M^{-1} s_r`` by a Cholesky factorisation vectorised over the vertices.

    ``sx[r][i]`` is component ``i`` of projection ``r`` and ``mm[i][j]`` (``j <= i``) an
    entry of the symmetric ``M``, arrays of one shape (e.g. ``(m, k)``). Where ``M``
    is not positive definite above ``floor`` the trace is 0.
    """
    d = len(mm)
    chol = [[None] * d for _ in range(d)]
    ok = np.ones(np.broadcast(mm[0][0], sx[0][0]).shape, dtype=bool)
    for j in range(d):
        pivot = mm[j][j] - sum(chol[j][l] ** 2 for l in range(j))
        ok &= pivot > floor
        chol[j][j] = np.sqrt(np.where(ok, pivot, 1.0))
        for i in range(j + 1, d):
            chol[i][j] = (mm[i][j] - sum(chol[i][l] * chol[j][l] for l in range(j))) / chol[j][j]
    trace = np.zeros(ok.shape)
    for row in sx:
        solved = []
        for i in range(d):
            value = row[i] - sum(chol[i][l] * solved[l] for l in range(i))
            solved.append(value / chol[i][i])
            trace += solved[-1] ** 2
    return np.where(ok, trace, 0.0)


def statistic_of(sx: list, scatter: list, df_resid: int, scalar: bool, floor) -> np.ndarray:
    """The statistic from the tested projections and the scatter ``H + E`` (per vertex).

    ``sx[r][i]``: component ``i`` of the projection on the ``r``-th tested direction;
    ``scatter[i][j]``: entries of ``H + E`` (``j <= i``). Scalars: ``t`` (one row)
    or ``F``; vectors: Pillai's trace. Vertices whose ``H + E`` is below ``floor``: 0.
    """
    if not scalar:
        return pillai_trace(sx, scatter, floor)
    hyp = sum(row[0] ** 2 for row in sx)
    total = scatter[0][0]
    rss = np.maximum(total - hyp, 1e-300)
    varies = total > floor
    if len(sx) == 1:
        return np.where(varies, sx[0][0] / np.sqrt(rss / df_resid), 0.0)
    return np.where(varies, (hyp / len(sx)) / (rss / df_resid), 0.0)


def p_values(statistic, kind: str, q: int, d: int, df_resid: int) -> np.ndarray:
    """Parametric p-values: two-sided ``t``, ``F``, or Pillai's trace by its F approximation."""
    if kind == "t":
        return 2.0 * stats.t.sf(np.abs(statistic), df_resid)
    if kind == "F":
        return stats.f.sf(statistic, q, df_resid)
    f_value, df1, df2 = pillai_f(statistic, q, d, df_resid)
    return stats.f.sf(f_value, df1, df2)


def kind_and_df(scalar: bool, q: int, d: int, df_resid: int) -> tuple[str, tuple]:
    """The statistic's name and its degrees of freedom."""
    if scalar:
        return ("t", (float(df_resid),)) if q == 1 else ("F", (float(q), float(df_resid)))
    return "pillai", pillai_f(0.0, q, d, df_resid)[1:]


def scatter_entries(total: np.ndarray, ridge: float) -> tuple[list, float, float]:
    """Entries ``[i][j]`` of ``total`` ``(k, d, d)`` plus ``shift`` on the diagonal, the
    floor below which a vertex counts as without variance, and ``shift`` (``ridge``
    times the mean variance over the vertices)."""
    d = total.shape[-1]
    trace = np.einsum("kii->k", total)
    scale = trace[trace > 0].mean() / d if (trace > 0).any() else 1.0
    shift = ridge * scale
    entries = [[total[:, i, j] + (shift if i == j else 0.0) for j in range(d)] for i in range(d)]
    return entries, 1e-13 * scale, shift


@dataclass(frozen=True)
class LinearFit:
    """Result of :func:`fit_statistic`.

    Attributes
    ----------
    coefficients : ndarray, shape (p, k) or (p, k, d)
        Least-squares ``B`` at every vertex.
    effect : ndarray, shape (q, k) or (q, k, d)
        ``C B``.
    statistic : ndarray, shape (k,)
        ``t`` (signed), ``F`` or Pillai's trace ``V``; 0 at a vertex without variance.
    p_value : ndarray, shape (k,)
        Parametric p-value of each vertex alone (1 at a vertex without variance).
    kind : str
        ``"t"``, ``"F"`` or ``"pillai"``.
    df : tuple of float
        ``(nu,)`` for ``t``, ``(q, nu)`` for ``F``, the F approximation's
        ``(df1, df2)`` for Pillai's trace.
    df_resid : int
        ``nu = n - p``.
    """

    coefficients: np.ndarray
    effect: np.ndarray
    statistic: np.ndarray
    p_value: np.ndarray
    kind: str
    df: tuple
    df_resid: int

    def hotelling(self) -> np.ndarray:
        """Hotelling's ``T^2`` (Pillai's trace of a one-row contrast, or ``t^2``)."""
        if self.kind == "t":
            return self.statistic**2
        if self.kind == "pillai" and self.effect.shape[0] == 1:
            return pillai_to_hotelling(self.statistic, self.df_resid)
        raise ValueError(f"hotelling: defined for one-row contrasts, not for {self.kind!r}")


def fit_statistic(Y, X, C, ridge: float = 0.0) -> LinearFit:
    """Fit the linear model at every vertex and compute the statistic of ``C B = 0``.

    Parameters
    ----------
    Y : array, shape (n, k) or (n, k, d)
        Scalars (``t`` for one contrast row, ``F`` for several) or vectors (Pillai's
        trace) per subject and vertex.
    X : array, shape (n, p)
        Design of full column rank, ``n - p >= d``.
    C : array, shape (q, p) or (p,)
        Contrast of full row rank.
    ridge : float, default 0
        Vectors only: added to the diagonal of ``H + E``, relative to the mean
        variance over the vertices (keeps a vertex with degenerate data finite).

    Returns
    -------
    LinearFit
    """
    y, scalar = check_responses(Y)
    n, k, d = y.shape
    x, c = check_model(X, C, n, d)
    p, q = x.shape[1], c.shape[0]
    flat = y.reshape(n, k * d)
    q_x, r_x = np.linalg.qr(x)
    coefficients = linalg.solve_triangular(r_x, q_x.T @ flat)
    residuals = x @ coefficients
    residuals = np.subtract(flat, residuals, out=residuals)  # one array of the data's size
    u_z, u_x = contrast_bases(x, c)
    sx = (u_x.T @ flat).reshape(q, k, d)
    res = residuals.reshape(n, k, d)
    total = np.einsum("nki,nkj->kij", res, res) + np.einsum("rki,rkj->kij", sx, sx)
    entries, floor, _ = scatter_entries(total, float(ridge) if not scalar else 0.0)
    rows = [[sx[r, :, i] for i in range(d)] for r in range(q)]
    statistic = statistic_of(rows, entries, n - p, scalar, floor)
    kind, df = kind_and_df(scalar, q, d, n - p)
    varies = np.einsum("kii->k", total) > floor
    p_value = np.where(varies, p_values(statistic, kind, q, d, n - p), 1.0)
    shape = (k,) if scalar else (k, d)
    return LinearFit(
        coefficients.reshape(p, *shape), (c @ coefficients).reshape(q, *shape),
        statistic, p_value, kind, df, n - p,
    )  # fmt: skip
