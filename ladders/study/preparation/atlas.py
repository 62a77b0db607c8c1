"""The LDDMM atlas of a cohort's end-diastolic meshes (the paper's template ``T``).

The atlas is the Fréchet (Karcher) mean in the LDDMM landmark space
(:func:`ladders.frechet_mean`): from a start ``T``, register ``T`` onto every
subject, average the momenta at ``T``'s control points and shoot ``T`` with the
average, until an iteration moves ``T`` by less than a tolerance. When the meshes are in correspondence the
targets are the subjects' vertices (the squared-distance data term); when they
are not, each target is a varifold (or current) data term towards the
subject's mesh, and the atlas keeps the triangulation of its start. The start
is a chosen subject or, for corresponding meshes, their vertex-wise mean shape;
every mesh is first aligned rigidly onto it (Procrustes with correspondence,
ICP without). Each iteration reports the total registration objective
``sum_i C_i`` and the norm of the averaged momenta; the result carries a
convergence flag.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ladders.frechet_mean import frechet_mean
from manifolds.data_terms.mesh_geometry import check_mesh
from manifolds.lddmm import LDDMMLandmarks
from manifolds.validation import check_float, check_int

from .alignment import SimilarityTransform, icp_align, procrustes
from .correspondence import CorrespondenceSettings

__all__ = ["AtlasResult", "estimate_atlas"]


@dataclass
class AtlasResult:
    """Outcome of :func:`estimate_atlas`.

    Attributes
    ----------
    vertices : array, shape ``(k, 3)``
    faces : int array, shape ``(f, 3)``
    converged : bool
        An iteration moved the atlas by at most ``tol``.
    n_iter : int
    objectives : list of float
        ``sum_i C_i`` (registration objectives of the current atlas onto every subject),
        per iteration, the start first.
    gradient_norms : list of float
        RKHS norm of the averaged momenta per iteration.
    transforms : list of SimilarityTransform
        The rigid alignment of each mesh onto the start.
    corresponding : bool
        Whether the meshes were in correspondence (squared distance) or not (surface term).
    message : str
    """

    vertices: np.ndarray
    faces: np.ndarray
    converged: bool
    n_iter: int
    objectives: list = field(default_factory=list)
    gradient_norms: list = field(default_factory=list)
    transforms: list = field(default_factory=list)
    corresponding: bool = False
    message: str = ""


def _start(meshes, initial, corresponding):
    if isinstance(initial, tuple):
        return check_mesh(*initial, "estimate_atlas: initial")
    if initial == "mean":
        if not corresponding:
            raise ValueError(
                "estimate_atlas: initial: 'mean' needs meshes in correspondence; choose a "
                "subject (an index) or give (vertices, faces)"
            )
        v0, f0 = meshes[0]
        aligned = [procrustes(v, v0).apply(v) for v, _ in meshes]
        return np.mean(aligned, axis=0), f0
    index = 0 if initial == "first" else check_int(initial, "estimate_atlas: initial", minimum=0)
    if index >= len(meshes):
        raise ValueError(f"estimate_atlas: initial: subject {index} of {len(meshes)} meshes")
    return meshes[index]


def _aligned_targets(meshes, start_v, start_f, corresponding, align, settings):
    """The rigid alignment of each mesh onto the start and the registration targets."""
    transforms = []
    for v, f in meshes:
        if not align:
            transforms.append(SimilarityTransform.identity())
        elif corresponding:
            transforms.append(procrustes(v, start_v))
        else:
            transforms.append(icp_align(v, f, start_v, start_f)[0])
    moved = [(t.apply(v), f) for t, (v, f) in zip(transforms, meshes)]
    if corresponding:
        return transforms, np.stack([v for v, _ in moved])
    return transforms, [settings.data_term_for(v, f, start_f) for v, f in moved]


def estimate_atlas(
    meshes,
    settings: CorrespondenceSettings | None = None,
    *,
    initial="first",
    align: bool = True,
    tol: float = 0.1,
    max_iter: int = 10,
    progress: Callable | None = None,
) -> AtlasResult:
    """LDDMM atlas of ``meshes`` (see the module).

    Parameters
    ----------
    meshes : list of ``(vertices (k_i, 3), faces (f_i, 3))``
        The subjects' end-diastolic meshes, in one unit.
    settings : CorrespondenceSettings, optional
        Registration settings, ``alpha`` and the surface data term (used when
        the meshes do not correspond).
    initial : "first", "mean", int or ``(vertices, faces)``
        The start: a subject (by index), the mean shape (corresponding meshes
        only) or a given mesh, whose triangulation the atlas keeps.
    align : bool, default True
        Align every mesh rigidly onto the start first.
    tol : float, default 0.1
        Stop when an iteration moves the atlas by at most ``tol`` (per-vertex RMS,
        the meshes' unit). (The RKHS norm of the averaged momenta, also reported,
        need not vanish: momenta at control points far from the shape barely move
        it.)
    max_iter : int, default 10
    progress : callable, optional
        ``progress(iteration, objective, gradient_norm)`` after every iteration.

    Returns
    -------
    AtlasResult
    """
    settings = settings or CorrespondenceSettings()
    tol = check_float(tol, "estimate_atlas: tol", minimum=0.0)
    if len(meshes) == 0:
        raise ValueError("estimate_atlas: meshes: no mesh given")
    meshes = [check_mesh(v, f, f"estimate_atlas: mesh {i}") for i, (v, f) in enumerate(meshes)]
    v0, f0 = meshes[0]
    corresponding = all(v.shape == v0.shape and np.array_equal(f, f0) for v, f in meshes)
    start_v, start_f = _start(meshes, initial, corresponding)
    corresponding = corresponding and start_v.shape == v0.shape and np.array_equal(start_f, f0)
    transforms, targets = _aligned_targets(meshes, start_v, start_f, corresponding, align, settings)
    space = LDDMMLandmarks(len(start_v), 3, alpha=settings.alpha, settings=settings.registration,
                           cache_size=len(meshes) + 1)  # fmt: skip
    objectives, previous = [], [start_v]

    def report(it, x, gnorm):
        objectives.append(float(sum(space.register(x, t).objective for t in targets)))
        moved = float(np.sqrt(((x - previous[-1]) ** 2).sum(1).mean()))
        previous.append(x)
        if progress is not None:
            progress(it, objectives[-1], gnorm)
        return it > 0 and moved <= tol

    res = frechet_mean(space, targets, initial=start_v, tol=0.0, max_iter=max_iter, callback=report)
    return AtlasResult(
        np.array(res.mean), start_f, res.converged, res.n_iter, objectives, res.gradient_norms,
        transforms, corresponding, res.message,
    )  # fmt: skip
