"""Permutation inference for the per-vertex general linear model, family-wise over vertices.

:func:`glm_test` tests ``C B = 0`` at every vertex (:mod:`.linear_model`: ``t``,
``F`` or Pillai's trace) and controls the family-wise error over the vertices by the
single-step maximum statistic: ``p_fwer`` of vertex ``v`` is
``(1 + #{max_null >= stat_v}) / (P + 1)`` where ``max_null`` holds the largest
statistic over the vertices of each of ``P`` permutations (``|t|`` for ``t``).

Permutation strategies (Winkler et al., NeuroImage 92, 2014). The design is split by
the contrast into the tested part and the nuisance ``Z`` (the columns ``X N`` with
``C N = 0``, which span the same space as Smith's or Winkler's partitioning):

- ``"freedman_lane"`` (default): the residuals ``R_z`` of ``Y`` under the reduced
  model ``Z`` are permuted and added back to its fit, ``Y* = P R_z + H_z Y``, and the
  full model is refitted; valid with nuisance covariates correlated with the effect;
- ``"manly"``: the rows of ``Y`` are permuted (exact without nuisance beyond the
  intercept, otherwise approximate);
- ``"draper_stoneman"``: the tested part of the design is permuted, ``Z`` kept.

Because ``H_z Y`` lies in the design's column space, the refit of ``Y*`` depends only
on ``P R_z``: with an orthonormal basis ``[U_x, U_z]`` of the design split by the
contrast, each permutation needs the ``p`` projections ``[U_x, U_z]^T P R_z`` at all
the vertices, one matrix product for a chunk of permutations; then ``H`` is the
scatter of the ``U_x`` projections and ``H + E = R_z^T R_z`` minus that of the
``U_z`` projections (:class:`~.null_maps.NullMaps`: the product, and the statistic per
permutation and vertex compiled).

``blocks`` restricts the permutations to exchangeability blocks (e.g. sites);
``enhance`` maps statistic maps to enhanced ones (e.g. threshold-free cluster
enhancement) and the family-wise error is then also computed on the enhanced maps.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from tqdm.auto import tqdm

from manifolds.validation import check_rng

from .design import Design, contrast_matrix
from .linear_model import check_model, check_responses, fit_statistic
from .null_maps import NullMaps, block_codes
from .tfce import tfce_enhancer, tfce_step

__all__ = [
    "GLMTest",
    "glm_test",
    "permutation_indices",
    "permutation_chunks",
    "two_sided",
    "tfce_from_observed",
    "METHODS",
]

#: The permutation strategies of :func:`glm_test`.
METHODS = ("freedman_lane", "manly", "draper_stoneman")

#: Memory of one chunk of permutations (their gathered design rows, projections, maps).
_CHUNK_BYTES = 128 * 2**20
#: The permutations are drawn in chunks of ``_DRAW_BYTES // (8 k (p d + d^2 + 8))``, the
#: chunks in which the maps were once computed: the permutations of a seed within
#: blocks, which depend on it, stay those of earlier versions.
_DRAW_BYTES = 64 * 2**20


@dataclass(frozen=True)
class GLMTest:
    """Result of :func:`glm_test`.

    Attributes
    ----------
    statistic : ndarray, shape (k,)
        Observed ``t`` (signed), ``F`` or Pillai's trace at every vertex.
    p_uncorrected : ndarray, shape (k,)
        Parametric p-value of each vertex alone (two-sided for ``t``).
    p_fwer : ndarray, shape (k,)
        Family-wise corrected p-value of the maximum statistic (``|t|`` for ``t``).
    max_null : ndarray, shape (P,)
        Largest statistic over the vertices of each permutation.
    kind : str
        ``"t"``, ``"F"`` or ``"pillai"``.
    df : tuple of float
        Degrees of freedom of the parametric distribution (``LinearFit.df``).
    contrast : str
        The contrast's name.
    n_permutations : int
    method : str
        One of :data:`METHODS`.
    enhanced : ndarray, shape (k,), or None
        The observed map after ``enhance``.
    p_fwer_enhanced : ndarray, shape (k,), or None
        Family-wise corrected p-value of the enhanced maps' maximum.
    max_null_enhanced : ndarray, shape (P,), or None
    effect : ndarray, shape (q, k) or (q, k, d), or None
        The contrast's estimate ``C B`` at every vertex (the observed fit's).
    """

    statistic: np.ndarray
    p_uncorrected: np.ndarray
    p_fwer: np.ndarray
    max_null: np.ndarray
    kind: str
    df: tuple
    contrast: str
    n_permutations: int
    method: str
    enhanced: np.ndarray | None = None
    p_fwer_enhanced: np.ndarray | None = None
    max_null_enhanced: np.ndarray | None = None
    effect: np.ndarray | None = None

    def significant(self, alpha: float = 0.05, enhanced: bool = False) -> np.ndarray:
        """Vertices whose family-wise corrected p-value (of the enhanced maps) is below ``alpha``."""
        if enhanced and self.p_fwer_enhanced is None:
            raise ValueError("enhanced: the test was run without an enhance function")
        return (self.p_fwer_enhanced if enhanced else self.p_fwer) < alpha


def permutation_indices(
    n_subjects: int, n_permutations: int, rng: np.random.Generator, blocks=None
) -> np.ndarray:
    """Random permutations ``(P, n)`` of the subjects, within exchangeability blocks.

    Row ``m`` maps position ``i`` to subject ``perm[m, i]``, always of the same block
    as ``i`` when ``blocks`` (labels ``(n,)``) is given.
    """
    rng = check_rng(rng)
    base = np.arange(int(n_subjects))
    shape = (int(n_permutations), base.size)
    if blocks is None:
        return rng.permuted(np.broadcast_to(base, shape), axis=1)
    codes = block_codes(blocks, base.size)
    out = np.broadcast_to(base, shape).copy()
    for code in range(codes.max() + 1):
        members = np.flatnonzero(codes == code)
        out[:, members] = rng.permuted(np.broadcast_to(members, (shape[0], members.size)), axis=1)
    return out


def permutation_chunks(n_subjects: int, n_permutations: int, rng: np.random.Generator, blocks,
                       size: int, draw: int) -> Iterator[np.ndarray]:  # fmt: skip
    """The permutations of :func:`permutation_indices` in chunks, drawn ``draw`` at a time.

    Within blocks the random stream depends on how many permutations are drawn at once,
    so the draws keep their own size: a seed gives the same permutations whatever
    ``size`` (without blocks the rows are drawn one after the other anyway).

    Parameters
    ----------
    n_subjects, n_permutations : int
    rng : numpy.random.Generator
    blocks : array, shape (n,), or None
        Exchangeability-block labels.
    size : int
        Permutations per chunk (the last chunk may be shorter).
    draw : int
        Permutations per call of :func:`permutation_indices` (ignored without blocks).

    Yields
    ------
    ndarray of int, shape (size, n)
    """
    if blocks is None:
        draw = size
    pending, drawn = np.empty((0, int(n_subjects)), dtype=np.int64), 0
    while drawn < n_permutations or len(pending):
        parts = [pending]
        have = len(pending)
        while have < size and drawn < n_permutations:
            m = min(draw, n_permutations - drawn)
            parts.append(permutation_indices(n_subjects, m, rng, blocks))
            drawn, have = drawn + m, have + m
        chunk = parts[-1] if len(parts) == 2 and not len(pending) else np.concatenate(parts)
        pending = chunk[size:]
        yield chunk[:size]


def _prefetched(items: Iterator) -> Iterator:
    """The items of ``items``, each next one made in a worker thread while the caller uses
    the current one (the permutations are drawn on one core while the maps of the previous
    chunk use the others); the items and their order are those of ``items``."""
    with ThreadPoolExecutor(max_workers=1) as pool:
        future = pool.submit(next, items, None)
        while (item := future.result()) is not None:
            future = pool.submit(next, items, None)
            yield item


def two_sided(enhance: Callable[[np.ndarray], np.ndarray]) -> Callable[[np.ndarray], np.ndarray]:
    """``maps -> enhance(max(maps, 0)) - enhance(max(-maps, 0))``: both tails of ``t``.

    For an enhancement that is zero where its input is zero and non-negative elsewhere
    (threshold-free cluster enhancement), the two terms have disjoint supports and the
    result carries the sign of ``t``; :func:`glm_test` takes the maximum of its
    absolute value, so both tails enter the family-wise error.
    """

    def enhance_both(maps: np.ndarray) -> np.ndarray:
        maps = np.asarray(maps, dtype=np.float64)
        return np.asarray(enhance(np.maximum(maps, 0.0))) - np.asarray(
            enhance(np.maximum(-maps, 0.0))
        )

    return enhance_both


def tfce_from_observed(
    observed, kind: str, adjacency, height: float = 2.0, extent: float = 1.0
) -> Callable[[np.ndarray], np.ndarray]:
    """The ``enhance`` of threshold-free cluster enhancement for one test's maps.

    The threshold step is fixed once from the observed map (:func:`~.tfce.tfce_step`),
    the same for every permuted map; a ``t`` map is enhanced in both tails
    (:func:`two_sided`). A map with nothing above zero enhances to zeros.
    """
    signed = kind == "t"
    step = tfce_step(observed, two_sided=signed)
    if step <= 0:
        return np.zeros_like
    base = tfce_enhancer(adjacency, height, extent, step=step)
    return two_sided(base) if signed else base


def _fwer(observed: np.ndarray, max_null: np.ndarray) -> np.ndarray:
    sorted_null = np.sort(max_null)
    tolerant = observed - 1e-12 * np.abs(observed)  # ties of the two ways of computing
    exceed = max_null.size - np.searchsorted(sorted_null, tolerant, side="left")
    return (1.0 + exceed) / (max_null.size + 1.0)


def _model(design, contrast) -> tuple[np.ndarray, np.ndarray, str]:
    if isinstance(design, Design):
        name, c = contrast_matrix(design, contrast)
        return design.matrix, c, name
    if isinstance(contrast, str):
        raise ValueError(f"contrast: {contrast!r} by name needs a Design (design_matrix)")
    return np.asarray(design, dtype=np.float64), np.atleast_2d(contrast), "contrast"


def _enhanced(enhance, maps: np.ndarray) -> np.ndarray:
    out = np.asarray(enhance(maps), dtype=np.float64)
    if out.shape != maps.shape or not np.isfinite(out).all():
        raise ValueError(f"enhance: expected finite maps of shape {maps.shape}, got {out.shape}")
    return out


def glm_test(
    Y,
    design: Design | np.ndarray,
    contrast,
    n_permutations: int = 10000,
    rng: np.random.Generator | None = None,
    method: str = "freedman_lane",
    blocks=None,
    enhance: Callable[[np.ndarray], np.ndarray] | None = None,
    tfce=None,
    chunk_size: int | None = None,
    progress: bool = False,
    ridge: float = 1e-9,
) -> GLMTest:
    """Test a contrast of the linear model at every vertex, family-wise error by permutation.

    Parameters
    ----------
    Y : array, shape (n, k) or (n, k, d)
        Scalars (``t`` for a one-row contrast, ``F`` otherwise) or vectors (Pillai's
        trace) per subject (rows of the design) and vertex.
    design : Design or array, shape (n, p)
        From :func:`~ladders.statistics.design_matrix`, or a matrix of full column rank.
    contrast : str or array, shape (q, p)
        By name (:func:`~ladders.statistics.contrast_matrix`, needs a ``Design``) or a matrix.
    n_permutations : int, default 10000
        Random permutations ``P``.
    rng : numpy.random.Generator
        Draws the permutations (required).
    method : {"freedman_lane", "manly", "draper_stoneman"}
    blocks : array, shape (n,), optional
        Exchangeability-block labels: subjects are permuted only within their block.
    enhance : callable, optional
        ``enhance(maps (m, k)) -> (m, k)``, called first with the observed map
        (``m = 1``) then with chunks of permutations. It receives the signed ``t``
        (use :func:`two_sided` to enhance both tails), ``F`` or Pillai's trace; the
        maximum is taken of ``|enhanced|`` for ``t``, of the enhanced map otherwise.
    tfce : scipy.sparse matrix, shape (k, k), optional
        A mesh's vertex adjacency (:func:`~.tfce.mesh_adjacency`): threshold-free cluster
        enhancement (``H = 2``, ``E = 1``, step from the observed map) as ``enhance``
        (:func:`tfce_from_observed`); not with ``enhance``.
    chunk_size : int, optional
        Permutations per matrix product (default: a 128 MB budget).
    progress : bool
        A progress bar over the chunks.
    ridge : float, default 1e-9
        Vectors only: added to the diagonal of ``H + E``, relative to the mean variance.

    Returns
    -------
    GLMTest
    """
    rng = check_rng(rng)
    if method not in METHODS:
        raise ValueError(f"method: expected one of {', '.join(METHODS)}, got {method!r}")
    if isinstance(n_permutations, bool) or int(n_permutations) < 1:
        raise ValueError(f"n_permutations: expected an int >= 1, got {n_permutations!r}")
    n_permutations = int(n_permutations)
    y, scalar = check_responses(Y)
    x, c, name = _model(design, contrast)
    x, c = check_model(x, c, y.shape[0], y.shape[2])
    fit = fit_statistic(y[..., 0] if scalar else y, x, c, ridge)
    null = NullMaps(y, x, c, method, scalar, float(ridge), blocks)
    if tfce is not None:
        if enhance is not None:
            raise ValueError("tfce: give tfce or enhance, not both")
        enhance = tfce_from_observed(fit.statistic, fit.kind, tfce)
    magnitude = np.abs if fit.kind == "t" else np.asarray
    observed_enhanced = None if enhance is None else _enhanced(enhance, fit.statistic[None])[0]
    draw = chunk_size
    if chunk_size is None:
        chunk_size = max(1, min(n_permutations, _CHUNK_BYTES // null.bytes_per_permutation()))
        n, k, d = y.shape
        draw = max(1, _DRAW_BYTES // (8 * k * (x.shape[1] * d + d * d + 8)))
    max_null = np.empty(n_permutations)
    max_enhanced = None if enhance is None else np.empty(n_permutations)
    chunks = _prefetched(
        permutation_chunks(y.shape[0], n_permutations, rng, blocks, int(chunk_size), draw)
    )
    total = -(-n_permutations // int(chunk_size))
    start = 0
    for perm in tqdm(chunks, total=total, desc="permutations", disable=not progress, leave=False):
        m = perm.shape[0]
        maps = null.maps(perm)
        max_null[start : start + m] = magnitude(maps).max(axis=1)
        if enhance is not None:
            max_enhanced[start : start + m] = magnitude(_enhanced(enhance, maps)).max(axis=1)
        start += m
    p_fwer = _fwer(magnitude(fit.statistic), max_null)
    p_enhanced = None if enhance is None else _fwer(magnitude(observed_enhanced), max_enhanced)
    return GLMTest(
        fit.statistic, fit.p_value, p_fwer, max_null, fit.kind, fit.df, name,
        n_permutations, method, observed_enhanced, p_enhanced, max_enhanced, fit.effect,
    )  # fmt: skip
