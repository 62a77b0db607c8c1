"""Running the study: the computation of a pair, its typed result, the runner and its store.

- :mod:`.pipeline`: :class:`StudyConfig` and :func:`compute_pair`, the one
  computation of a (subject, ``alpha^2``) pair;
- :mod:`.results`: the typed results (:class:`PairResult`, :class:`FailedPair`,
  :class:`SubjectResults`, ...);
- :mod:`.runner`: :func:`run_study` over a cohort (parallel, resumable);
- :mod:`.store`: one JSON file per pair, written atomically and read back whole
  (:mod:`.result_codec`), and the claims of concurrent runs (:mod:`.claims`);
- :mod:`.provenance`: the run's manifest.
"""

from .pipeline import (
    DEFAULT_REGISTRATION,
    StudyConfig,
    compute_pair,
    make_space,
    run_subject,
)
from .result_codec import ResultSchemaError
from .results import (
    ERROR_NAMES,
    FANNING,
    POLE_LADDER,
    REGISTRATION_MEASURES,
    SCHEMA_VERSION,
    SVF_CONJUGATION,
    TRANSPORT_LABELS,
    VARIANTS,
    FailedPair,
    PairResult,
    RegistrationCounts,
    RegistrationSummary,
    SubjectResults,
    TransportResult,
    VariantErrors,
)
from .runner import StudyOutcome, configuration_id, run_study
from .store import PairStore

__all__ = [
    "DEFAULT_REGISTRATION",
    "StudyConfig",
    "compute_pair",
    "make_space",
    "run_subject",
    "ERROR_NAMES",
    "VARIANTS",
    "REGISTRATION_MEASURES",
    "POLE_LADDER",
    "FANNING",
    "SVF_CONJUGATION",
    "TRANSPORT_LABELS",
    "SCHEMA_VERSION",
    "PairResult",
    "FailedPair",
    "SubjectResults",
    "VariantErrors",
    "RegistrationSummary",
    "RegistrationCounts",
    "TransportResult",
    "ResultSchemaError",
    "StudyOutcome",
    "configuration_id",
    "run_study",
    "PairStore",
]
