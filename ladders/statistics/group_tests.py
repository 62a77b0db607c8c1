"""Two-group tests of per-vertex data with family-wise error control by permutation.

:func:`vertexwise_test` compares two groups at every vertex of a mesh: Hotelling's
``T^2`` for vectors (e.g. displacements ``(n, k, 3)``), Student's ``t`` for scalars
(e.g. area strain ``(n, k)``). The family-wise error over the ``k`` vertices is
controlled by permuting the group labels (Westfall and Young's single-step max-T):
the corrected p-value of a vertex is the fraction of permutations whose largest
statistic over all the vertices reaches the vertex's own. This holds whatever the
dependence between the vertices, with exchangeable subjects under the null.

The permutations are vectorised. The total scatter ``A_v`` of a vertex's data about
their grand mean does not depend on the labels; with ``c = n1 n2 / n`` and ``d_v``
the difference of the group means, the pooled within-group scatter is
``W_v = A_v - c d_v d_v^T`` and, by the Sherman-Morrison formula,
``T^2 = (n - 2) c q / (1 - c q)`` with ``q = d_v^T A_v^{-1} d_v``. Each vertex is
whitened once (``z = C_v^{-1} x`` with ``A_v = C_v C_v^T``), so that for a chunk of
permutations the mean differences at all the vertices are one matrix product and
``q`` a sum of squares. :func:`global_test` is the same test on one vector per
subject (e.g. the first PCA scores).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats
from tqdm.auto import tqdm

from manifolds.validation import check_rng

__all__ = [
    "check_groups",
    "VertexwiseTest",
    "vertexwise_test",
    "GlobalTest",
    "global_test",
]

_CHUNK_BYTES = 64 * 2**20  # memory of one chunk of permuted mean differences


def check_groups(groups, n: int, min_size: int = 3) -> np.ndarray:
    """The group labels as booleans (True: the first group), or raise naming ``groups``.

    Accepts booleans or the integers 0 and 1, one per subject; each group needs at
    least ``min_size`` subjects.
    """
    g = np.asarray(groups)
    if g.ndim != 1 or g.size != n:
        raise ValueError(f"groups: expected {n} labels (one per subject), got shape {g.shape}")
    if g.dtype != bool:
        if not np.issubdtype(g.dtype, np.number) or not np.isin(g, (0, 1)).all():
            raise ValueError("groups: expected booleans or 0/1 labels")
        g = g.astype(bool)
    sizes = (int(g.sum()), int((~g).sum()))
    if min(sizes) < min_size:
        raise ValueError(
            f"groups: each group needs at least {min_size} subjects, got sizes {sizes}"
        )
    return g


def _check_data(data) -> np.ndarray:
    x = np.asarray(data, dtype=float)
    if x.ndim not in (2, 3) or x.shape[0] < 1 or x.shape[1] < 1:
        raise ValueError(
            f"data: expected per-vertex values (n, k) or vectors (n, k, d), got shape {x.shape}"
        )
    if not np.isfinite(x).all():
        raise ValueError("data: contains NaN or infinite values")
    return x


@dataclass(frozen=True)
class VertexwiseTest:
    """Result of :func:`vertexwise_test`.

    Attributes
    ----------
    statistic : ndarray, shape (k,)
        Hotelling's ``T^2`` (vectors) or the signed two-sample ``t`` (scalars;
        positive where the first group's mean is larger).
    p_uncorrected : ndarray, shape (k,)
        Parametric p-value of each vertex alone (``F(d, n - d - 1)`` of the scaled
        ``T^2``; Student's ``t`` with ``n - 2`` degrees of freedom, two-sided).
    p_fwer : ndarray, shape (k,)
        Family-wise corrected p-value, ``(1 + #{max_null >= statistic}) / (P + 1)``
        (max over ``|t|`` for scalars).
    max_null : ndarray, shape (P,)
        Largest statistic over the vertices of each permutation.
    n_permutations : int
    kind : str
        ``"hotelling"`` or ``"t"``.
    dim : int
        Components per vertex ``d`` (1 for scalars).
    group_sizes : (int, int)
    """

    statistic: np.ndarray
    p_uncorrected: np.ndarray
    p_fwer: np.ndarray
    max_null: np.ndarray
    n_permutations: int
    kind: str
    dim: int
    group_sizes: tuple

    def significant(self, alpha: float = 0.05) -> np.ndarray:
        """Vertices whose family-wise corrected p-value is below ``alpha``."""
        return self.p_fwer < alpha


def _whiten(x: np.ndarray, ridge: float) -> tuple[np.ndarray, np.ndarray]:
    """Data centred and whitened per vertex by its total scatter; which vertices vary."""
    xc = x - x.mean(axis=0)
    scatter = np.einsum("nka,nkb->kab", xc, xc)
    trace = np.einsum("kaa->k", scatter)
    varies = trace > 0
    scale = trace[varies].mean() / x.shape[2] if varies.any() else 1.0
    scatter = scatter + (ridge * scale) * np.eye(x.shape[2])
    chol = np.linalg.cholesky(scatter)
    z = np.linalg.solve(chol[None], xc[..., None])[..., 0]
    return z, varies


def _q_of(weights: np.ndarray, z_flat: np.ndarray, k: int, d: int) -> np.ndarray:
    """``q`` per (labelling, vertex) for labellings given as mean-difference weights."""
    diff = (weights @ z_flat).reshape(len(weights), k, d)
    return np.einsum("mkd,mkd->mk", diff, diff)


def _weights(labels: np.ndarray) -> np.ndarray:
    n1 = labels.sum(axis=-1, keepdims=True)
    n2 = labels.shape[-1] - n1
    return np.where(labels, 1.0 / n1, -1.0 / n2)


def _t2(q, c: float, n: int) -> np.ndarray:
    return (n - 2) * c * q / np.maximum(1.0 - c * q, 1e-300)


def vertexwise_test(
    data,
    groups,
    n_permutations: int = 10000,
    rng: np.random.Generator | None = None,
    chunk_size: int | None = None,
    progress: bool = False,
    ridge: float = 1e-9,
) -> VertexwiseTest:
    """Two-group test at every vertex, family-wise error controlled by permutation (module).

    Parameters
    ----------
    data : array, shape (n, k, d) or (n, k)
        Per subject and vertex, a vector (Hotelling's ``T^2``) or a scalar (``t``).
    groups : array of bool or 0/1, shape (n,)
        True (1) for the first group; at least 3 subjects per group.
    n_permutations : int, default 10000
        Random permutations of the labels (``P``).
    rng : numpy.random.Generator
        Draws the permutations (required).
    chunk_size : int, optional
        Permutations per matrix product (default: a 64 MB budget).
    progress : bool
        A progress bar over the chunks.
    ridge : float, default 1e-9
        Added to each vertex's scatter, relative to the mean scatter over the vertices
        (a vertex without variance, e.g. one that never moves, gets statistic 0).

    Returns
    -------
    VertexwiseTest
    """
    rng = check_rng(rng)
    x = _check_data(data)
    scalar = x.ndim == 2
    if scalar:
        x = x[..., None]
    n, k, d = x.shape
    labels = check_groups(groups, n)
    if isinstance(n_permutations, bool) or int(n_permutations) < 1:
        raise ValueError(f"n_permutations: expected an int >= 1, got {n_permutations!r}")
    n_permutations = int(n_permutations)
    if n - d - 1 < 1:
        raise ValueError(f"data: {d} components per vertex need at least {d + 2} subjects, got {n}")
    n1, n2 = int(labels.sum()), int((~labels).sum())
    c = n1 * n2 / n
    z, varies = _whiten(x, float(ridge))
    z_flat = z.reshape(n, k * d)
    q_obs = _q_of(_weights(labels)[None], z_flat, k, d)[0]
    t2 = np.where(varies, _t2(q_obs, c, n), 0.0)
    if chunk_size is None:
        chunk_size = max(1, min(n_permutations, _CHUNK_BYTES // (8 * k * d)))
    max_null = np.empty(n_permutations)
    starts = range(0, n_permutations, int(chunk_size))
    for start in tqdm(starts, desc="permutations", disable=not progress, leave=False):
        m = min(int(chunk_size), n_permutations - start)
        perm = rng.permuted(np.broadcast_to(labels, (m, n)), axis=1)
        q = _q_of(_weights(perm), z_flat, k, d)
        max_null[start : start + m] = np.where(varies, _t2(q, c, n), 0.0).max(axis=1)
    sorted_null = np.sort(max_null)
    exceed = n_permutations - np.searchsorted(sorted_null, t2 * (1.0 - 1e-12), side="left")
    p_fwer = (1.0 + exceed) / (n_permutations + 1.0)
    if scalar:
        diff = x[labels, :, 0].mean(axis=0) - x[~labels, :, 0].mean(axis=0)
        statistic = np.sign(diff) * np.sqrt(t2)
        p_unc = 2.0 * stats.t.sf(np.abs(statistic), n - 2)
        kind, max_null = "t", np.sqrt(max_null)
    else:
        statistic = t2
        p_unc = stats.f.sf(t2 * (n - d - 1) / (d * (n - 2)), d, n - d - 1)
        kind = "hotelling"
    p_unc = np.where(varies, p_unc, 1.0)
    return VertexwiseTest(statistic, p_unc, p_fwer, max_null, n_permutations, kind, d, (n1, n2))


@dataclass(frozen=True)
class GlobalTest:
    """Hotelling's ``T^2`` of one vector per subject (e.g. PCA scores), by permutation."""

    statistic: float
    p_permutation: float
    p_parametric: float
    n_components: int
    n_permutations: int


def global_test(
    scores, groups, n_permutations: int = 10000, rng: np.random.Generator | None = None
) -> GlobalTest:
    """Two-group Hotelling ``T^2`` of ``scores`` ``(n, m)`` with its permutation p-value."""
    s = np.asarray(scores, dtype=float)
    if s.ndim != 2:
        raise ValueError(f"scores: expected an array (n, m), got shape {s.shape}")
    test = vertexwise_test(s[:, None, :], groups, n_permutations, rng)
    return GlobalTest(
        float(test.statistic[0]), float(test.p_fwer[0]), float(test.p_uncorrected[0]),
        s.shape[1], test.n_permutations,
    )  # fmt: skip
