"""Selecting numbers from the typed results for the tables and figures of the report."""

from __future__ import annotations

import numpy as np

from ..running.results import POLE_LADDER, VARIANTS, method_label

__all__ = [
    "LABELS",
    "VARIANT_METHOD",
    "alpha_values",
    "collect",
    "transport_rows",
    "other_rows",
    "skipped_transports",
    "row_label",
    "representative_subject",
]

#: Row labels of the four errors and the pole ladder's ASE.
LABELS = {
    "midpoint_distance": "Midpoint distance",
    "centrality": "Centrality",
    "involutivity": "Involutivity",
    "transvectivity": "Transvectivity",
    "ase": "Area strain error (pole ladder)",
}
#: The pole ladder's transport method of each variant row.
VARIANT_METHOD = POLE_LADDER


def alpha_values(results: list) -> list[float]:
    """The ``alpha^2`` with a result for any subject, in increasing order."""
    return sorted({a for r in results for a in r.alpha2})


def collect(results: list, alpha2: float, row: str, measure: str) -> np.ndarray:
    """``pair.measure(row, measure)`` over the subjects with a result at ``alpha2``."""
    pairs = [r.at(alpha2) for r in results]
    return np.asarray([p.measure(row, measure) for p in pairs if p is not None], dtype=float)


def transport_rows(results: list) -> list[str]:
    """The rows of the transports: the two variants (their pole ladders), then the model's
    own transport where it has one (``"fanning"``, ``"svf_conjugation"``, ...)."""
    first = next(p for r in results for p in r.pairs)
    others = [t.method for t in first.transports if t.method not in POLE_LADDER.values()]
    return [*VARIANTS, *others]


def other_rows(results: list) -> list[str]:
    """The transport rows that are not a pole ladder (none, or the model's own)."""
    return transport_rows(results)[len(VARIANTS) :]


def skipped_transports(results: list) -> dict[str, str]:
    """``method -> reason`` of the transports the model does not have (from any pair)."""
    return {s.method: s.reason for r in results for p in r.pairs for s in p.skipped_transports}


def row_label(row: str) -> str:
    """What the transport of a row is, e.g. ``"pole ladder, with residuals"``."""
    return method_label(VARIANT_METHOD.get(row, row))


def representative_subject(results: list, alpha2: float):
    """The subject whose ASE of the pole ladder with residuals is the median at ``alpha2``
    (the lower of the two middle ones for an even count), and the number of subjects."""
    ranked = sorted(
        (r for r in results if r.at(alpha2) is not None),
        key=lambda r: (r.at(alpha2).measure("residual", "ase"), r.subject),
    )
    return ranked[(len(ranked) - 1) // 2], len(ranked)
