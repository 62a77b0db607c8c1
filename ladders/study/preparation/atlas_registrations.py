"""The registrations of one iteration of the atlas, run through the batch runner.

One iteration of the atlas (:func:`~.atlas.estimate_atlas`) registers the current
atlas onto every subject; the registrations are independent of each other, so
:class:`AtlasLogs` runs them through :func:`~ladders.study.batch.run_batch`: in this
process (``jobs=1``), in ``jobs`` local processes, or on a Dask cluster when the caller
sets ``joblib.parallel_config(backend="dask")``. It is the ``map_logs`` of
:func:`ladders.frechet_mean`, and it keeps each registration's objective, so that the
atlas's report of the objective per iteration registers nothing again. A target may be
a :class:`CoarseToFine` pair of surface terms: the atlas is then registered onto the
wide one first and onto the narrow one from there (:func:`register_atlas_onto`). Every
registration runs with BLAS on one thread and the same settings whatever ``jobs`` is,
so the atlas is the same, to round-off, on any number of workers.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from manifolds.data_terms.base import DataTerm
from manifolds.lddmm import LDDMMLandmarks, RegistrationSettings

from ..batch import run_batch

__all__ = ["AtlasLogs", "AtlasRegistration", "CoarseToFine", "register_atlas_onto"]


@dataclass(frozen=True)
class AtlasRegistration:
    """One registration of the atlas onto a subject.

    Attributes
    ----------
    log : array, shape ``(n_cp, 3)``
        The momenta at the atlas's control points (``Log_atlas(subject)``).
    objective : float
        The registration objective ``C`` (data term plus ``alpha^2 ||v||^2``).
    converged : bool
        Whether the registration met its stopping rule.
    cpu_seconds : float
        Processor time of the registration (every thread of its process).
    """

    log: np.ndarray
    objective: float
    converged: bool
    cpu_seconds: float


@dataclass(frozen=True)
class CoarseToFine:
    """A registration target matched in two stages: ``coarse``, then ``fine`` from there.

    Attributes
    ----------
    coarse, fine : DataTerm
        Two data terms towards one subject's surface, of a wide and of the narrow kernel
        (:meth:`~.correspondence_settings.CorrespondenceSettings.data_term_for`). The
        log and the objective are those of the registration onto ``fine``.
    """

    coarse: DataTerm
    fine: DataTerm


def register_atlas_onto(
    atlas, target, alpha: float, settings: RegistrationSettings
) -> AtlasRegistration:
    """Register ``atlas`` (shape ``(k, 3)``) onto ``target`` (a shape in correspondence, a
    data term, or a :class:`CoarseToFine` pair) in the LDDMM landmark space of ``alpha``
    and ``settings`` (the batch's work function).

    A :class:`CoarseToFine` target is registered onto its ``coarse`` term, then onto its
    ``fine`` term from the momenta found (a warm start at the same control points): the
    wide kernel sees a subject's whole surface from afar, the narrow one its details.
    """
    start = time.process_time()
    space = LDDMMLandmarks(len(atlas), 3, alpha=alpha, settings=settings, cache_size=1)
    if isinstance(target, CoarseToFine):
        first = space.register(atlas, target.coarse).momenta
        log = space.log_near(atlas, target.fine, first)
        res = space.register(atlas, target.fine, initial_momenta=first)  # from the cache
    else:
        log = space.log(atlas, target)
        res = space.register(atlas, target)  # the same registration, from the cache
    return AtlasRegistration(np.asarray(log), float(res.objective), bool(res.converged),
                             time.process_time() - start)  # fmt: skip


class AtlasLogs:
    """``map_logs(atlas, targets)`` for :func:`ladders.frechet_mean`: the atlas registered
    onto every target by :func:`run_batch`.

    Parameters
    ----------
    alpha : float
    settings : RegistrationSettings
        Those of the atlas's landmark space.
    jobs : int, default 1
        Worker processes (``-1``: one per core; 1: this process).

    Attributes
    ----------
    last : list of AtlasRegistration
        The registrations of the last call, in the targets' order.
    n_registrations : int
        Registrations run over every call.
    cpu_seconds : list of float
        Per call, the processor time of its registrations, summed.
    """

    def __init__(self, alpha: float, settings: RegistrationSettings, jobs: int = 1):
        self.alpha = float(alpha)
        self.settings = settings
        self.jobs = jobs
        self.last: list[AtlasRegistration] = []
        self.n_registrations = 0
        self.cpu_seconds: list[float] = []

    def __call__(self, atlas, targets) -> list:
        """``[Log_atlas(target)]``, one per target in their order."""
        atlas = np.asarray(atlas, dtype=float)
        tasks = [(atlas, t, self.alpha, self.settings) for t in targets]
        self.last = list(run_batch(register_atlas_onto, tasks, jobs=self.jobs,
                                   desc="registrations", unit="subject"))  # fmt: skip
        self.n_registrations += len(self.last)
        self.cpu_seconds.append(float(sum(r.cpu_seconds for r in self.last)))
        return [r.log for r in self.last]

    def objective(self, weights=None) -> float:
        """``sum_i C_i`` over the last call's registrations; with ``weights`` (summing to
        one), ``n sum_i w_i C_i``, the same when they are equal."""
        values = np.array([r.objective for r in self.last])
        if weights is None:
            return float(values.sum())
        return float(len(values) * np.dot(weights, values))
