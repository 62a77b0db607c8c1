"""Reporting the study: tables, paired statistics, figures and the comparison of models.

- :mod:`.report`: the Table-1-style summary and :func:`write_report`;
- :mod:`.statistics`: the tidy table and the paired comparison;
- :mod:`.figures`: Fig. 4, Fig. 5a and Fig. 5b;
- :mod:`.bullseye`: the AHA 17-segment bull's-eye plot;
- :mod:`.deformation_comparison`: deformation models against the first (e.g. SVF
  against LDDMM) on the same subjects;
- :mod:`.rows`: the typed rows of those tables.
"""

from .bullseye import bullseye_figure, bullseye_plot
from .deformation_comparison import (
    compare_deformations,
    comparison_csv,
    comparison_markdown,
    write_deformation_comparison,
    write_model_comparison,
)
from .report import summarize, summary_markdown, terminal_summary, write_report
from .rows import DeformationComparisonRow, PairedComparison, PairedRow, SummaryRow
from .statistics import paired_comparison, paired_statistics, tidy_rows

__all__ = [
    "bullseye_plot",
    "bullseye_figure",
    "summarize",
    "summary_markdown",
    "terminal_summary",
    "write_report",
    "paired_comparison",
    "paired_statistics",
    "tidy_rows",
    "compare_deformations",
    "write_deformation_comparison",
    "write_model_comparison",
    "comparison_csv",
    "comparison_markdown",
    "SummaryRow",
    "PairedComparison",
    "PairedRow",
    "DeformationComparisonRow",
]
