"""Statistics of tangent vectors at one base point: mean, tangent PCA, modes.

Everything here uses only the connection API: ``space.exp(point, tangent)`` and,
for the metric, ``space.inner(point, u, v)``. Tangent vectors are arrays of the
space's tangent shape or objects with ``+``, ``-`` and scalar ``*`` (e.g.
:class:`manifolds.ResidualTangent`, momenta with a residual).

:func:`tangent_pca` is a dual (Gram-matrix) PCA: with ``G_ij = <u_i - m, u_j - m>``
in the space's inner product at the base point (the kernel metric on momenta for
LDDMM, the affine-invariant metric for SPD matrices, the flat metric for the point
distribution model), the eigenvectors ``a_k`` of ``G`` give the components
``e_k = sum_i a_ik (u_i - m) / sqrt(lambda_k)``, orthonormal in that metric, with
variances ``lambda_k / (n - 1)`` and scores ``sqrt(lambda_k) a_ik``. It needs only
``n (n + 1) / 2`` inner products and works for tangents of any type.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["tangent_mean", "TangentPCA", "tangent_pca", "mode_shapes", "METRICS"]

#: The metrics of :func:`tangent_pca`.
METRICS = ("auto", "space", "flat")


def _as_list(tangents, name: str = "tangents") -> list:
    if isinstance(tangents, np.ndarray):
        if tangents.ndim < 1 or tangents.shape[0] == 0:
            raise ValueError(
                f"{name}: expected a sequence of tangent vectors, got shape {tangents.shape}"
            )
        items = list(np.asarray(tangents, dtype=float))
    else:
        try:
            items = list(tangents)
        except TypeError:
            raise ValueError(f"{name}: expected a sequence of tangent vectors") from None
    if not items:
        raise ValueError(f"{name}: expected at least one tangent vector, got none")
    for i, u in enumerate(items):
        if isinstance(u, np.ndarray) and not np.all(np.isfinite(u)):
            raise ValueError(f"{name}[{i}]: contains NaN or infinite values")
    return items


def _linear_combination(weights, vectors):
    out = None
    for w, v in zip(weights, vectors):
        term = float(w) * v
        out = term if out is None else out + term
    return out


def tangent_mean(space, base, tangents):
    """The arithmetic mean of tangent vectors at ``base``.

    Parameters
    ----------
    space : manifolds.Connection
        Unused but for the signature shared with the other statistics (the mean of
        tangent vectors at one point is linear).
    base : point of ``space``
    tangents : sequence of tangents, or an array ``(n, *tangent_shape)``

    Returns
    -------
    tangent
    """
    items = _as_list(tangents)
    return _linear_combination(np.full(len(items), 1.0 / len(items)), items)


def _flat_inner(u, v) -> float:
    if not (isinstance(u, np.ndarray) and isinstance(v, np.ndarray)):
        raise TypeError(
            "metric='flat' needs array tangents; use metric='space' for tangents of type "
            f"{type(u).__name__}"
        )
    return float(np.sum(u * v))


def _metric(space, base, metric: str) -> tuple[Callable, str]:
    """The inner product to use and the name of the metric it is."""
    if metric not in METRICS:
        raise ValueError(f"metric: expected one of {METRICS}, got {metric!r}")
    if metric == "flat":
        return _flat_inner, "flat"

    def by_space(u, v):
        return float(space.inner(base, u, v))

    if metric == "space":
        return by_space, "space"
    return by_space, "auto"


@dataclass(frozen=True)
class TangentPCA:
    """Principal components of tangent vectors at one base point (:func:`tangent_pca`).

    Attributes
    ----------
    base : point
    mean : tangent
    components : tuple of tangents
        Orthonormal in :attr:`metric`, by decreasing variance.
    variances : ndarray, shape (m,)
        Variance along each component (``1 / (n - 1)`` convention).
    explained_variance_ratio : ndarray, shape (m,)
        Each variance over the total variance of the data.
    scores : ndarray, shape (n, m)
        Coordinates of each centred tangent on the components.
    metric : str
        ``"space"`` (the space's inner product) or ``"flat"`` (Frobenius).
    """

    base: object
    mean: object
    components: tuple
    variances: np.ndarray
    explained_variance_ratio: np.ndarray
    scores: np.ndarray
    metric: str
    _inner: Callable = None

    @property
    def n_components(self) -> int:
        """Number of components kept."""
        return len(self.components)

    @property
    def standard_deviations(self) -> np.ndarray:
        """Square roots of :attr:`variances`."""
        return np.sqrt(self.variances)

    def transform(self, space, tangents) -> np.ndarray:
        """Scores ``(n, m)`` of tangents at the same base point (centred on :attr:`mean`)."""
        items = _as_list(tangents)
        inner = self._inner or _metric(space, self.base, self.metric)[0]
        return np.array([[inner(u - self.mean, e) for e in self.components] for u in items])

    def reconstruct(self, scores) -> list:
        """The tangents ``mean + sum_k scores_k e_k`` of score rows ``(n, m)``."""
        s = np.atleast_2d(np.asarray(scores, dtype=float))
        if s.shape[1] != self.n_components:
            raise ValueError(f"scores: expected {self.n_components} columns, got {s.shape[1]}")
        return [self.mean + _linear_combination(row, self.components) for row in s]


def _gram(space, base, centred: list, inner, used: str) -> np.ndarray:
    """``G_ij = <c_i, c_j>``: one broadcast call for array tangents of a batched space."""
    n = len(centred)
    if all(isinstance(c, np.ndarray) for c in centred):
        stack = np.stack(centred)
        if used == "flat":
            flat = stack.reshape(n, -1)
            return flat @ flat.T
        if getattr(space, "supports_batch", False):
            try:
                gram = np.asarray(space.inner(base, stack[:, None], stack[None, :]), dtype=float)
            except Exception:  # noqa: BLE001 - a space that does not broadcast: the loop below
                gram = None
            if gram is not None and gram.shape == (n, n):
                return 0.5 * (gram + gram.T)
    gram = np.empty((n, n))
    for i in range(n):
        for j in range(i, n):
            gram[i, j] = gram[j, i] = inner(centred[i], centred[j])
    return gram


def tangent_pca(
    space,
    base,
    tangents,
    n_components: int | None = None,
    metric: str = "auto",
    rtol: float = 1e-10,
) -> TangentPCA:
    """Tangent PCA at ``base`` with the space's inner product (see the module).

    Parameters
    ----------
    space : manifolds.Connection
    base : point of ``space``
    tangents : sequence of tangents at ``base``, or an array ``(n, *tangent_shape)``
        At least two.
    n_components : int, optional
        Components kept (default all, at most the rank of the centred data, ``n - 1``).
    metric : {"auto", "space", "flat"}
        ``"space"``: ``space.inner``; ``"flat"``: the Frobenius product of the
        arrays; ``"auto"``: the space's inner product where it has one, else flat.
    rtol : float
        Eigenvalues below ``rtol`` times the largest are dropped (rank deficiency).

    Returns
    -------
    TangentPCA
        Each component's sign is fixed so that its largest-magnitude score is positive.
    """
    items = _as_list(tangents)
    n = len(items)
    if n < 2:
        raise ValueError(f"tangents: tangent PCA needs at least 2 tangent vectors, got {n}")
    inner, used = _metric(space, base, metric)
    mean = tangent_mean(space, base, items)
    centred = [u - mean for u in items]
    if used == "auto":
        try:
            inner(centred[0], centred[0])
            used = "space"
        except NotImplementedError:
            inner, used = _flat_inner, "flat"
    gram = _gram(space, base, centred, inner, used)
    values, vectors = np.linalg.eigh(gram)
    order = np.argsort(values)[::-1]
    values, vectors = values[order], vectors[:, order]
    total = float(values[values > 0].sum())
    keep = values > rtol * max(values[0], 0.0) if values[0] > 0 else np.zeros(n, dtype=bool)
    rank = int(keep.sum())
    if n_components is not None:
        if isinstance(n_components, bool) or int(n_components) < 1:
            raise ValueError(f"n_components: expected an int >= 1, got {n_components!r}")
        rank = min(rank, int(n_components))
    values, vectors = values[:rank], vectors[:, :rank]
    scores = vectors * np.sqrt(values)
    flip = np.sign(scores[np.argmax(np.abs(scores), axis=0), np.arange(rank)])
    flip[flip == 0] = 1.0
    scores, vectors = scores * flip, vectors * flip
    components = tuple(_linear_combination(vectors[:, k] / np.sqrt(values[k]), centred)
                       for k in range(rank))  # fmt: skip
    return TangentPCA(
        base, mean, components, values / (n - 1),
        values / total if total > 0 else np.zeros(rank), scores, used, inner,
    )  # fmt: skip


def mode_shapes(
    space, base, pca: TangentPCA, mode: int = 0, ks: Sequence[float] = (-2, -1, 0, 1, 2)
) -> np.ndarray:
    """The points ``Exp_base(mean + k sd_mode e_mode)`` for each ``k`` (a mode's shapes).

    Returns
    -------
    ndarray, shape ``(len(ks), *point_shape)``
    """
    if not 0 <= int(mode) < pca.n_components:
        raise ValueError(f"mode: expected 0 <= mode < {pca.n_components}, got {mode!r}")
    sd = pca.standard_deviations[mode]
    e = pca.components[mode]
    return np.stack([np.asarray(space.exp(base, pca.mean + (float(k) * sd) * e)) for k in ks])
