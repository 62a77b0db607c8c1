"""LDDMM against SVF on the same cohort: means and paired statistics per alpha^2.

The paper's conclusion conjectures that the stationary-velocity-field (SVF)
space, whose group structure is symmetric, would show smaller symmetry errors
than LDDMM. With both studies run on the same subjects and settings
(``symladders study --deformation both``), each measure is compared subject by
subject: ``SVF - LDDMM`` per subject, the fraction of subjects where SVF is
lower, the median difference with a 95 % bootstrap interval and the Wilcoxon
signed-rank p-value (:func:`ladders.study.reporting.statistics.paired_comparison`).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ..files import atomic_write_text
from ..running.results import ERROR_NAMES, REGISTRATION_MEASURES, VARIANTS
from .rows import DeformationComparisonRow
from .statistics import paired_comparison

__all__ = [
    "MEASURES",
    "compare_deformations",
    "comparison_markdown",
    "comparison_csv",
    "write_deformation_comparison",
]

#: ``(variant, measure)`` compared; ``None`` for the registration measures shared by the variants.
MEASURES = (
    *((v, e) for v in VARIANTS for e in (*ERROR_NAMES, "ase")),
    *((None, m) for m in REGISTRATION_MEASURES),
)


def _values(results: list, alpha2: float, variant, measure) -> dict[str, float]:
    """``{subject: value}`` over the subjects with a result at ``alpha2``."""
    out = {}
    for r in results:
        pair = r.at(alpha2)
        if pair is not None:
            out[r.subject] = pair.measure(variant or VARIANTS[0], measure)
    return out


def compare_deformations(lddmm: list, svf: list, seed: int = 0, n_boot: int = 2000) -> list[dict]:
    """One row per ``(alpha^2, variant, measure)``: means and the paired ``SVF - LDDMM``.

    Parameters
    ----------
    lddmm, svf : lists of SubjectResults
        :attr:`ladders.study.running.runner.StudyOutcome.results` of the two studies;
        subjects are matched by name, and a subject missing from either (a
        failed pair) is left out of that ``alpha^2``.
    seed : int
        Seed of the bootstrap (``numpy.random.default_rng``).
    n_boot : int
        Bootstrap resamples.

    Returns
    -------
    list of DeformationComparisonRow
        ``alpha2, variant, measure, n, mean_lddmm, mean_svf, fraction_svf_lower,
        median_difference, ci_low, ci_high, wilcoxon_p``.
    """
    rng = np.random.default_rng(seed)
    keys = sorted({a for r in lddmm for a in r.alpha2} & {a for r in svf for a in r.alpha2})
    rows = []
    for key in keys:
        for variant, measure in MEASURES:
            a = _values(lddmm, key, variant, measure)
            b = _values(svf, key, variant, measure)
            names = sorted(set(a) & set(b))
            x = np.array([b[n] for n in names])
            y = np.array([a[n] for n in names])
            stats = paired_comparison(x, y, rng, n_boot=n_boot)
            rows.append(
                DeformationComparisonRow(
                    key, variant or "registration", measure, stats.n,
                    float(y.mean()) if names else None, float(x.mean()) if names else None,
                    stats.fraction_residual_lower, stats.median_difference, stats.ci_low,
                    stats.ci_high, stats.wilcoxon_p,
                )
            )  # fmt: skip
    return rows


def _fmt(value, spec: str = ".3g") -> str:
    return "" if value is None else format(value, spec)


def comparison_markdown(
    rows: list[DeformationComparisonRow], unit: str = "mm (per-vertex RMS)"
) -> str:
    """The comparison as a Markdown table (distances in ``unit``; the ASE is dimensionless)."""
    n = max((r.n for r in rows), default=0)
    lines = [
        f"LDDMM against SVF, {n} subjects; distances in {unit}, the ASE and the deformation "
        "norm without unit. Difference = SVF - LDDMM per subject (median, 95 % bootstrap "
        "interval); p: Wilcoxon signed-rank.",
        "",
        "| alpha^2 | variant | measure | LDDMM mean | SVF mean | SVF lower | median diff "
        "[95 % CI] | p |",
        "| ---: | --- | --- | ---: | ---: | ---: | --- | ---: |",
    ]
    for r in rows:
        ci = f"{_fmt(r.median_difference)} [{_fmt(r.ci_low)}, {_fmt(r.ci_high)}]"
        lower = "" if r.fraction_svf_lower is None else f"{r.fraction_svf_lower:.0%}"
        lines.append(
            f"| {r.alpha2:g} | {r.variant} | {r.measure} | {_fmt(r.mean_lddmm)} | "
            f"{_fmt(r.mean_svf)} | {lower} | {ci} | {_fmt(r.wilcoxon_p, '.2g')} |"
        )
    return "\n".join(lines) + "\n"


def comparison_csv(rows: list[DeformationComparisonRow]) -> str:
    """The comparison as CSV text (``None`` as an empty cell)."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=DeformationComparisonRow.fields(), lineterminator="\n")
    writer.writeheader()
    for r in rows:
        writer.writerow({k: "" if v is None else v for k, v in r.as_dict().items()})
    return buf.getvalue()


def write_deformation_comparison(lddmm: list, svf: list, output) -> tuple[Path, str]:
    """Compare the two studies' results and write ``comparison.md`` and ``comparison.csv``.

    What ``symladders study --deformation both`` writes next to the two studies.

    Parameters
    ----------
    lddmm, svf : list of SubjectResults
        The two studies' results on the same subjects.
    output : path
        The folder (created if needed).

    Returns
    -------
    path : Path
        ``comparison.md``.
    text : str
        Its Markdown.
    """
    output = Path(output)
    output.mkdir(parents=True, exist_ok=True)
    rows = compare_deformations(lddmm, svf)
    units = [p.unit for r in lddmm for p in r.pairs]
    text = comparison_markdown(rows, units[0] if units else "mm")
    atomic_write_text(output / "comparison.csv", comparison_csv(rows))
    atomic_write_text(output / "comparison.md", text)
    return output / "comparison.md", text
