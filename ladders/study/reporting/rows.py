"""The typed rows of the study's tables: summaries, paired comparisons, one model against another.

Frozen dataclasses of numbers and strings (``None`` where a value cannot be
computed, never NaN), each with ``as_dict()`` for CSV writers and ``fields()`` for
their header.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields

__all__ = ["SummaryRow", "PairedComparison", "PairedRow", "DeformationComparisonRow"]


class _Row:
    def as_dict(self) -> dict:
        """The fields as a plain dict, in their order."""
        return asdict(self)

    @classmethod
    def fields(cls) -> list[str]:
        """The names of the fields, in order (a CSV header)."""
        return [f.name for f in fields(cls)]


@dataclass(frozen=True)
class SummaryRow(_Row):
    """Mean and standard deviation of one measure at one ``alpha^2`` for one variant.

    ``variant`` is ``"residual"``, ``"no_residual"``, the third transport method (its
    ASE) or ``"both"`` (the registration measures, shared by the variants).
    """

    alpha2: float
    measure: str
    variant: str
    mean: float
    std: float
    n: int


@dataclass(frozen=True)
class PairedComparison(_Row):
    """Paired comparison of two samples of one error (first minus second, per subject).

    Attributes
    ----------
    n : int
    fraction_residual_lower : float or None
        Share of subjects with a strictly lower value in the first sample.
    median_difference, ci_low, ci_high : float or None
        Median difference and its 95 % bootstrap interval.
    wilcoxon_p : float or None
        Two-sided signed-rank test.
    note : str
        Why a value is missing, or which fallback was used.
    """

    n: int
    fraction_residual_lower: float | None = None
    median_difference: float | None = None
    ci_low: float | None = None
    ci_high: float | None = None
    wilcoxon_p: float | None = None
    note: str = ""


@dataclass(frozen=True)
class PairedRow(_Row):
    """:class:`PairedComparison` of residual against no residual for one error at one ``alpha^2``."""

    alpha2: float
    measure: str
    n: int
    fraction_residual_lower: float | None
    median_difference: float | None
    ci_low: float | None
    ci_high: float | None
    wilcoxon_p: float | None
    note: str

    @classmethod
    def of(cls, alpha2: float, measure: str, comparison: PairedComparison) -> PairedRow:
        """The row of ``comparison`` at ``alpha2`` for ``measure``."""
        return cls(alpha2, measure, **comparison.as_dict())


@dataclass(frozen=True)
class DeformationComparisonRow(_Row):
    """One measure at one ``alpha^2`` for one variant, a deformation model against a
    reference model on the same subjects (e.g. SVF against LDDMM).

    ``median_difference`` and its interval are ``model`` minus ``reference`` per subject.
    The means and the fraction are also read by the models' names:
    ``row.mean_lddmm``, ``row.mean_svf``, ``row.fraction_svf_lower``.
    """

    alpha2: float
    variant: str
    measure: str
    n: int
    reference: str
    model: str
    mean_reference: float | None
    mean_model: float | None
    fraction_model_lower: float | None
    median_difference: float | None
    ci_low: float | None
    ci_high: float | None
    wilcoxon_p: float | None

    def __getattr__(self, name: str):
        fields_ = self.__dict__
        if name.startswith("mean_") and fields_.get("reference") == name[5:]:
            return fields_["mean_reference"]
        if name.startswith("mean_") and fields_.get("model") == name[5:]:
            return fields_["mean_model"]
        if name == f"fraction_{fields_.get('model')}_lower":
            return fields_["fraction_model_lower"]
        raise AttributeError(f"{type(self).__name__} has no attribute {name!r}")
