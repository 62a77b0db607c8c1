"""Which subjects an atlas of a large cohort is estimated from: a stratified subset.

Each iteration of the atlas registers it onto every subject it is estimated from,
so its cost grows with their number; the atlas is a mean shape, which a well-chosen
subset estimates as well as the whole cohort (``docs/preparation.md``, "Atlas at
population scale", measures how well). :func:`choose_atlas_subset` picks ``n``
subjects by a stated, deterministic rule:

* ``"stratified"`` (the default): every mesh is summarised by a cheap descriptor
  that neither a rigid motion nor the triangulation changes
  (:func:`shape_descriptor`: the surface's principal RMS extents, in mm); the
  descriptors, each column scaled to unit standard deviation, are divided into
  ``n`` strata by k-means (seeded, so the same inputs give the same strata), and
  each stratum is represented by its member closest to the stratum's centre,
  weighted by the stratum's share of the cohort. The weighted mean of the subset
  is the stratified estimate of the cohort's mean: every part of the shape
  distribution counts as much as it holds subjects.
* ``"random"``: ``n`` subjects drawn without replacement with the seed, equal weights.

The subset's weights are those of the Karcher mean (:func:`~.atlas.estimate_atlas`'s
``weights``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manifolds.data_terms.mesh_geometry import check_mesh
from manifolds.validation import check_int

from .alignment import second_moments

__all__ = ["AtlasSubset", "SUBSET_RULES", "choose_atlas_subset", "shape_descriptor"]

#: The rules of :func:`choose_atlas_subset`.
SUBSET_RULES = ("stratified", "random")


@dataclass(frozen=True)
class AtlasSubset:
    """Outcome of :func:`choose_atlas_subset`.

    Attributes
    ----------
    indices : int array, shape ``(n,)``
        The subjects chosen, ascending.
    weights : array, shape ``(n,)``
        Their weights in the mean, summing to one (a stratum's share of the cohort, or
        equal).
    rule : str
    seed : int
    """

    indices: np.ndarray
    weights: np.ndarray
    rule: str
    seed: int


def shape_descriptor(vertices, faces) -> np.ndarray:
    """The principal RMS extents of a surface about its centroid, largest first.

    The square roots of the eigenvalues of the surface's area-weighted second-moment
    tensor (:func:`~.alignment.second_moments`): unchanged by a rigid motion and, up to the
    discretisation, by the triangulation.

    Parameters
    ----------
    vertices : array, shape ``(k, 3)``
    faces : int array, shape ``(f, 3)``

    Returns
    -------
    array, shape ``(3,)``
        In the meshes' unit.
    """
    v, f = check_mesh(vertices, faces, "shape_descriptor:")
    _, moments = second_moments(v, f)
    if not np.isfinite(moments).all():
        raise ValueError("shape_descriptor: the surface has no area")
    return np.sqrt(np.clip(np.linalg.eigvalsh(moments)[::-1], 0.0, None))


def choose_atlas_subset(
    descriptors, n: int, rule: str = "stratified", seed: int = 0
) -> AtlasSubset:
    """``n`` subjects to estimate the atlas from (see the module).

    Parameters
    ----------
    descriptors : array, shape ``(m, d)``
        One row per subject (:func:`shape_descriptor`).
    n : int
        Subjects to choose; all of them (equal weights) when ``n >= m``.
    rule : {"stratified", "random"}
    seed : int, default 0
        Seed of the k-means starts or of the draw.

    Returns
    -------
    AtlasSubset
    """
    x = np.asarray(descriptors, dtype=float)
    if x.ndim != 2 or len(x) == 0 or not np.isfinite(x).all():
        raise ValueError(
            f"choose_atlas_subset: descriptors: expected a finite (m, d) array with m >= 1, "
            f"got shape {x.shape}"
        )
    n = check_int(n, "choose_atlas_subset: n", minimum=1)
    seed = check_int(seed, "choose_atlas_subset: seed", minimum=0)
    if rule not in SUBSET_RULES:
        raise ValueError(f"choose_atlas_subset: rule: expected one of {SUBSET_RULES}, got {rule!r}")
    m = len(x)
    if n >= m:
        return AtlasSubset(np.arange(m), np.full(m, 1.0 / m), rule, seed)
    if rule == "random":
        chosen = np.sort(np.random.default_rng(seed).choice(m, n, replace=False))
        return AtlasSubset(chosen, np.full(n, 1.0 / n), rule, seed)
    return _stratified(x, n, seed)


def _stratified(x: np.ndarray, n: int, seed: int) -> AtlasSubset:
    from sklearn.cluster import KMeans

    spread = x.std(axis=0)
    z = (x - x.mean(axis=0)) / np.where(spread > 0, spread, 1.0)
    labels = KMeans(n_clusters=n, n_init=10, random_state=seed).fit_predict(z)
    chosen, sizes = [], []
    for k in np.unique(labels):
        members = np.flatnonzero(labels == k)
        centre = z[members].mean(axis=0)
        chosen.append(members[np.argmin(((z[members] - centre) ** 2).sum(1))])
        sizes.append(len(members))
    order = np.argsort(chosen)
    sizes = np.asarray(sizes, dtype=float)[order]
    return AtlasSubset(np.asarray(chosen)[order], sizes / sizes.sum(), "stratified", seed)
