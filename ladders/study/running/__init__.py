"""Running the study: the computation of a pair, the runner, its store and provenance.

- :mod:`.pipeline`: :class:`StudyConfig` and the computation of one subject;
- :mod:`.runner`: :func:`run_study` over a cohort (parallel, resumable);
- :mod:`.store`: one JSON file per (subject, ``alpha^2``), written atomically;
- :mod:`.provenance`: the run's manifest.
"""

from .pipeline import DEFAULT_REGISTRATION, ERROR_NAMES, VARIANTS, StudyConfig, run_subject
from .runner import StudyOutcome, compute_pair, configuration_id, run_study
from .store import PairStore

__all__ = [
    "DEFAULT_REGISTRATION",
    "ERROR_NAMES",
    "VARIANTS",
    "StudyConfig",
    "run_subject",
    "StudyOutcome",
    "compute_pair",
    "configuration_id",
    "run_study",
    "PairStore",
]
