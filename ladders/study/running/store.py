"""Crash-safe storage of a study's results: one JSON file per (subject, alpha^2).

Layout of an output folder::

    results/<config>/config.json                  settings shared by the files below
    results/<config>/atlas.vtu                    their atlas and faces
    results/<config>/<subject>/alpha2=<a>.json    one result per subject and alpha^2

``<config>`` is a hash of every setting the results depend on except the
alpha^2 sweep (kernel width, control points, integrator, atlas, faces, ...),
so extending the sweep reuses the finished pairs while a run with other
settings writes into its own folder and never touches earlier results.

The store alone writes the typed results
(:class:`~ladders.study.running.results.PairResult`,
:class:`~ladders.study.running.results.FailedPair`) to JSON and reads them back
(:mod:`ladders.study.running.result_codec`). Each file is written atomically
(:func:`ladders.study.files.atomic_write_text`). A file is
reused only if it parses, is of the current
:data:`~ladders.study.running.results.SCHEMA_VERSION`, carries the expected
parameter hash and holds the whole result; otherwise the pair is recomputed and
:attr:`PairStore.unusable` says why. Two runs into one folder share the work
through claims (:mod:`ladders.study.running.claims`).
"""

from __future__ import annotations

import json
from pathlib import Path

from ..errors import CohortError
from ..files import array_digest, atomic_write_text, config_hash
from .claims import Claim
from .result_codec import ResultSchemaError, decode, encode
from .results import FailedPair, PairResult

# atomic_write_text, array_digest and config_hash live in ladders.study.files; they are
# re-exported here, where the study's code and tests have imported them from.
__all__ = [
    "atomic_write_text",
    "array_digest",
    "config_hash",
    "validate_subject_name",
    "PairStore",
]


def validate_subject_name(name) -> str:
    """Return ``name`` if it is usable as a file name inside the output folder.

    Raises
    ------
    CohortError
        (a ``ValueError``) If ``name`` is not a non-empty string, is ``.`` or ``..``, starts with a
        dot, or holds a path separator or a NUL character.
    """
    bad = (
        not isinstance(name, str)
        or not name.strip()
        or name.startswith(".")
        or any(c in name for c in ("/", "\\", "\0"))
    )
    if bad:
        raise CohortError(
            "subjects: a subject name must be a non-empty file name without path "
            f"separators, NUL or a leading dot ('.', '..'), got {name!r}"
        )
    return name


class PairStore:
    """Results of one configuration: a JSON file per (subject, alpha^2).

    Parameters
    ----------
    folder : path
        The study's output folder.
    config_id : str
        Hash of the settings shared by all pairs (see :func:`config_hash`); the
        files live in ``folder/results/<config_id>/``.

    Attributes
    ----------
    unusable : dict
        ``(subject, alpha2) -> reason`` for the stored files :meth:`load` found
        and did not use (another schema version, a missing field, other inputs).
    """

    def __init__(self, folder: str | Path, config_id: str):
        self.root = Path(folder) / "results" / config_id
        self.config_id = config_id
        self.root.mkdir(parents=True, exist_ok=True)
        self.unusable: dict[tuple[str, float], str] = {}

    def path(self, name: str, alpha2: float) -> Path:
        """The result file of subject ``name`` at ``alpha2``."""
        return self.root / validate_subject_name(name) / f"alpha2={float(alpha2)!r}.json"

    def load(self, name: str, alpha2: float, params_hash: str) -> PairResult | FailedPair | None:
        """The stored result of a pair if it can be read whole and has ``params_hash``."""
        path = self.path(name, alpha2)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError:
            return None  # not computed yet
        key = (name, float(alpha2))
        try:
            data = json.loads(text)
            result = decode(data)
        except ValueError as exc:  # JSONDecodeError or ResultSchemaError
            reason = str(exc) if isinstance(exc, ResultSchemaError) else "not valid JSON"
            self.unusable[key] = reason
            return None
        if data.get("params_hash") != params_hash:
            self.unusable[key] = "computed from other meshes or settings"
            return None
        self.unusable.pop(key, None)
        return result

    def save(self, result: PairResult | FailedPair, params_hash: str) -> None:
        """Write ``result`` atomically to the file of its subject and ``alpha^2``."""
        data = {**encode(result), "params_hash": params_hash}
        atomic_write_text(self.path(result.subject, result.alpha2), json.dumps(data, indent=1))

    # Claims (see ladders.study.running.claims) -----------------------------------
    def claim(self, name: str, alpha2: float) -> bool:
        """Claim a pair for this process; ``False`` if a live process holds it."""
        return Claim(self.path(name, alpha2)).acquire()

    def claim_is_stale(self, name: str, alpha2: float) -> bool:
        """Whether the pair's claim (if any) belongs to a dead process on this host."""
        return Claim(self.path(name, alpha2)).is_stale()

    def release(self, name: str, alpha2: float) -> None:
        """Release this process's claim on a pair."""
        Claim(self.path(name, alpha2)).release()
