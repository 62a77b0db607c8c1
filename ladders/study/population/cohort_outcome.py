"""A survival outcome of the synthetic cohort, simulated from each subject's true regional motion.

:func:`regional_motion` is each subject's normal motion from end-diastole to
end-systole (mm, negative inward, on the outward normals of its own ED surface)
averaged over a region of the atlas (the planted one, or every vertex);
:func:`cohort_outcome` turns it into a follow-up time and an event per subject with
:func:`ladders.statistics.simulate_survival`: the log hazard ratio is ``beta`` per
standard deviation of that motion over the cohort, a smaller inward motion (a weaker
contraction) a higher hazard, and 30 % of the subjects censored on average. This is
how ``benchmarks/bench_outcome.py`` simulates its outcomes; ``symladders cohort
--outcome-effect BETA`` writes them into ``design.csv`` (columns ``time`` and
``event``) for ``symladders analyze --outcome time,event`` and ``symladders
cycle-analyze --outcome time,event``.
"""

from __future__ import annotations

import numpy as np

from ladders.statistics import simulate_survival

from ..errors import CohortError
from ..wall_motion import outward_vertex_normals

__all__ = ["OUTCOME_CENSORING", "cohort_outcome", "regional_motion"]

#: The expected fraction of censored subjects of :func:`cohort_outcome`.
OUTCOME_CENSORING = 0.3


def regional_motion(cohort, region=None) -> np.ndarray:
    """Each subject's mean normal motion ED -> ES over ``region`` (mm, inward negative).

    Parameters
    ----------
    cohort : Cohort
        Subjects with ``ed`` and ``es`` in vertex correspondence (shared ``faces``).
    region : array of bool, shape (k,), optional
        The vertices averaged over (default every vertex).

    Returns
    -------
    ndarray, shape (n_subjects,)
    """
    out = []
    for s in cohort.subjects:
        normals = outward_vertex_normals(s.ed, cohort.faces)
        motion = np.einsum("kd,kd->k", s.es - s.ed, normals)
        out.append(motion.mean() if region is None else motion[np.asarray(region)].mean())
    return np.array(out)


def cohort_outcome(
    cohort, beta: float, rng: np.random.Generator, region=None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Follow-up times and events simulated from the regional motion (see the module).

    Parameters
    ----------
    cohort : Cohort
    beta : float
        Log hazard ratio per standard deviation of the regional motion (a weaker
        inward motion, a higher hazard), ``>= 0``.
    rng : numpy.random.Generator
    region : array of bool, shape (k,), optional

    Returns
    -------
    time : ndarray, shape (n,)
    event : ndarray of bool, shape (n,)
    risk : ndarray, shape (n,)
        The log hazard ratio of each subject.
    """
    if isinstance(beta, bool) or not (np.isfinite(float(beta)) and float(beta) >= 0):
        raise CohortError(f"outcome_effect: expected a number >= 0, got {beta!r}")
    motion = regional_motion(cohort, region)
    spread = motion.std()
    z = (motion - motion.mean()) / spread if spread > 0 else np.zeros_like(motion)
    risk = float(beta) * z
    time, event = simulate_survival(risk, rng, censoring=OUTCOME_CENSORING)
    return time, event, risk
