"""The LDDMM atlas of a cohort's end-diastolic meshes (the paper's template ``T``).

The atlas is the Fréchet (Karcher) mean in the LDDMM landmark space
(:func:`ladders.frechet_mean`): from a start ``T``, register ``T`` onto every
subject, average the momenta at ``T``'s control points and shoot ``T`` with the
average, until an iteration moves ``T`` by less than a tolerance. When the meshes are in correspondence the
targets are the subjects' vertices (the squared-distance data term); when they
are not, each target is a varifold (or current) data term towards the
subject's mesh, and the atlas keeps the triangulation of its start. The start
is a chosen subject or, for corresponding meshes, their vertex-wise mean shape;
every mesh is first aligned rigidly onto it (Procrustes with correspondence;
without, :func:`~.rigid_fit.fit_rigid`, which keeps the input's own turn about
the long axis where the surfaces cannot tell, or follows anatomical landmarks
where given: the atlas's landmarks are then those of the aligned subjects,
averaged, with the apex and the septal point put back on the atlas's surface). Each iteration reports the total registration objective
``sum_i C_i`` and the norm of the averaged momenta; the result carries a
convergence flag. The registrations of an iteration run through the batch runner
(:class:`~.atlas_registrations.AtlasLogs`: ``jobs`` processes, or Dask), which keeps
their objectives: the report registers nothing twice.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ladders.frechet_mean import frechet_mean
from manifolds.data_terms.mesh_geometry import check_mesh
from manifolds.lddmm import LDDMMLandmarks
from manifolds.validation import check_float, check_int

from ..batch import run_batch
from .alignment import SimilarityTransform, procrustes
from .atlas_registrations import AtlasLogs, CoarseToFine
from .correspondence_settings import CorrespondenceSettings
from .landmarks import Landmarks
from .rigid_fit import fit_rigid

__all__ = ["AtlasResult", "estimate_atlas", "meshes_correspond"]


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
        Whether the targets were the meshes' vertices in correspondence (squared
        distance) or their surfaces (the surface data term).
    message : str
    landmarks : Landmarks or None
        The atlas's landmarks, when the meshes' were given.
    n_registrations : int
        Registrations run: one per subject and iterate (the start included).
    cpu_seconds : list of float
        Per iterate (the start first), the processor time of its registrations, summed
        over the subjects (core-seconds, whatever the number of workers).
    moves : list of float
        Per iteration, how far it moved the atlas (per-vertex RMS; what ``tol`` is
        compared with).
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
    landmarks: Landmarks | None = None
    n_registrations: int = 0
    cpu_seconds: list = field(default_factory=list)
    moves: list = field(default_factory=list)


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


def meshes_correspond(meshes) -> bool:
    """Whether the meshes ``[(vertices, faces), ...]`` share one vertex count and one
    triangulation (the squared-distance term applies; else a surface term)."""
    v0, f0 = meshes[0]
    return all(v.shape == v0.shape and np.array_equal(f, f0) for v, f in meshes)


def _start_and_term(meshes, initial, surface_term):
    """The start's vertices and faces, whether the meshes and the start correspond,
    and whether the targets are surfaces."""
    corresponding = meshes_correspond(meshes)
    start_v, start_f = _start(meshes, initial, corresponding)
    corresponding = corresponding and meshes_correspond([meshes[0], (start_v, start_f)])
    surface = not corresponding if surface_term is None else bool(surface_term)
    if not (surface or corresponding):
        raise ValueError(
            "estimate_atlas: surface_term: False needs meshes (and a start) in correspondence, "
            "with one vertex count and one triangulation"
        )
    return start_v, start_f, corresponding, surface


def align_onto_start(v, f, start_v, start_f, settings, landmarks=None, start_landmarks=None):
    """The rigid motion of the mesh ``(v, f)`` onto the start, by :func:`fit_rigid` (the
    batch's work function of the alignment of meshes that do not correspond)."""
    return fit_rigid(
        v, f, start_v, start_f, tolerance=settings.rotation_tolerance,
        start_tolerance=settings.start_tolerance, source_landmarks=landmarks,
        target_landmarks=start_landmarks,
    ).transform  # fmt: skip


def _aligned_targets(
    meshes, start_v, start_f, corresponding, surface, align, settings, landmarks, start_lm, jobs
):
    """The rigid alignment of each mesh onto the start (Procrustes when they correspond,
    else :func:`fit_rigid` through the batch runner, with landmarks where given) and the
    registration targets (the surface term's, coarse to fine with
    ``settings.atlas_coarse_factor`` above 1, or the vertices)."""
    if not align:
        transforms = [SimilarityTransform.identity() for _ in meshes]
    elif corresponding:
        transforms = [procrustes(v, start_v) for v, _ in meshes]
    else:
        tasks = [(v, f, start_v, start_f, settings, None if landmarks is None else landmarks[i],
                  start_lm) for i, (v, f) in enumerate(meshes)]  # fmt: skip
        transforms = list(run_batch(align_onto_start, tasks, jobs=jobs, desc="alignment"))
    moved = [(t.apply(v), f) for t, (v, f) in zip(transforms, meshes)]
    if not surface:
        return transforms, np.stack([v for v, _ in moved])
    if settings.atlas_coarse_factor == 1.0:
        return transforms, [settings.data_term_for(v, f, start_f) for v, f in moved]
    return transforms, [
        CoarseToFine(settings.data_term_for(v, f, start_f, settings.atlas_coarse_factor),
                     settings.data_term_for(v, f, start_f))
        for v, f in moved
    ]  # fmt: skip


def estimate_atlas(
    meshes,
    settings: CorrespondenceSettings | None = None,
    *,
    initial="first",
    align: bool = True,
    tol: float = 0.1,
    max_iter: int = 10,
    progress: Callable | None = None,
    surface_term: bool | None = None,
    checkpoint: Callable | None = None,
    landmarks: list | None = None,
    start_landmarks: Landmarks | None = None,
    weights=None,
    jobs: int = 1,
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
    surface_term : bool, optional
        ``None``: the surface data term when the meshes (and the start) do not
        correspond, the squared distance when they do; ``True``: the surface
        term in any case; ``False``: the squared distance, which needs meshes in
        correspondence.
    checkpoint : callable, optional
        ``checkpoint(iteration, vertices)`` with every iterate (the start first), e.g.
        to keep the last one when the estimation is interrupted.
    landmarks : list of Landmarks, optional
        One per mesh, in its coordinates: they fix each mesh's turn about the long axis
        in the alignment onto the start.
    start_landmarks : Landmarks, optional
        The start's, when it is a mesh given (a subject's are ``landmarks[index]``).
    weights : array, shape ``(n,)``, optional
        Non-negative weights of the meshes in the mean (e.g. the size of the stratum
        each stands for, :func:`~.atlas_subset.choose_atlas_subset`); equal by default.
        The objective reported is then ``n sum_i w_i C_i`` (weights summing to one).
    jobs : int, default 1
        The rigid alignments, and the registrations of an iteration, run in parallel (:func:`~ladders.study.batch.run_batch`:
        worker processes, ``-1`` one per core, or Dask under
        ``joblib.parallel_config(backend="dask")``); the same atlas, to round-off,
        whatever their number.

    Returns
    -------
    AtlasResult
    """
    settings = settings or CorrespondenceSettings()
    tol = check_float(tol, "estimate_atlas: tol", minimum=0.0)
    if len(meshes) == 0:
        raise ValueError("estimate_atlas: meshes: no mesh given")
    meshes = [check_mesh(v, f, f"estimate_atlas: mesh {i}") for i, (v, f) in enumerate(meshes)]
    start_v, start_f, corresponding, surface = _start_and_term(meshes, initial, surface_term)
    start_lm = _start_landmarks(landmarks, start_landmarks, initial, len(meshes))
    transforms, targets = _aligned_targets(
        meshes, start_v, start_f, corresponding, surface, align, settings, landmarks, start_lm,
        jobs,
    )  # fmt: skip
    space = LDDMMLandmarks(len(start_v), 3, alpha=settings.alpha, settings=settings.registration,
                           cache_size=0)  # fmt: skip
    logs = AtlasLogs(settings.alpha, space.settings, jobs=jobs)
    w = _weights(weights, len(meshes))
    objectives, previous, moves = [], [start_v], []

    def report(it, x, gnorm):
        objectives.append(logs.objective(w))  # of the registrations just run
        moved = float(np.sqrt(((x - previous[-1]) ** 2).sum(1).mean()))
        previous.append(x)
        if it > 0:
            moves.append(moved)
        if checkpoint is not None:
            checkpoint(it, np.array(x))
        if progress is not None:
            progress(it, objectives[-1], gnorm)
        return it > 0 and moved <= tol

    res = frechet_mean(space, targets, w, initial=start_v, tol=0.0, max_iter=max_iter,
                       callback=report, map_logs=logs)  # fmt: skip
    atlas_lm = None
    if landmarks is not None:
        atlas_lm = _atlas_landmarks(landmarks, transforms, np.array(res.mean), start_f)
    return AtlasResult(
        np.array(res.mean), start_f, res.converged, res.n_iter, objectives, res.gradient_norms,
        transforms, not surface, res.message, atlas_lm, logs.n_registrations,
        logs.cpu_seconds, moves,
    )  # fmt: skip


def _weights(weights, n: int):
    """The weights normalised to sum to one, or None (equal)."""
    if weights is None:
        return None
    w = np.asarray(weights, dtype=float)
    if w.shape != (n,) or not np.isfinite(w).all() or (w < 0).any() or w.sum() <= 0:
        raise ValueError(
            f"estimate_atlas: weights: expected {n} finite non-negative weights (one per mesh) "
            f"with a positive sum, got shape {w.shape}"
        )
    return w / w.sum()


def _start_landmarks(landmarks, start_landmarks, initial, n) -> Landmarks | None:
    if landmarks is None:
        return None
    if len(landmarks) != n or not all(isinstance(lm, Landmarks) for lm in landmarks):
        raise ValueError(f"estimate_atlas: landmarks: expected {n} Landmarks, one per mesh")
    if isinstance(initial, tuple) or initial == "mean":
        if start_landmarks is None and initial != "mean":
            raise ValueError("estimate_atlas: start_landmarks: needed for a start mesh given")
        return start_landmarks
    return landmarks[0 if initial == "first" else int(initial)]


def _atlas_landmarks(landmarks, transforms, vertices, faces) -> Landmarks:
    """The mean of the aligned landmarks, apex and septal point on the atlas's surface."""
    from ..surface_queries import closest_points

    mean = np.mean([lm.transformed(t).as_array() for lm, t in zip(landmarks, transforms)], 0)
    on_surface = closest_points(mean[[0, 2]], vertices, faces)[0]
    return Landmarks(on_surface[0], mean[1], on_surface[1])
