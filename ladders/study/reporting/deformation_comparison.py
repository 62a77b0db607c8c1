"""Deformation models against each other on the same cohort: means and paired statistics.

The paper's conclusion conjectures that the stationary-velocity-field (SVF)
space, whose group structure is symmetric, would show smaller symmetry errors
than LDDMM. With several models run on the same subjects and settings
(``symladders study --deformation lddmm,svf``, or ``both``; any registered model,
e.g. ``lddmm,svf,pdm``), each model after the first is compared with the first,
measure by measure and subject by subject: ``model - reference`` per subject, the
fraction of subjects where the model is lower, the median difference with a 95 %
bootstrap interval and the Wilcoxon signed-rank p-value
(:func:`ladders.study.reporting.statistics.paired_comparison`).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ..deformations import DeformationModelError, deformation_model
from ..files import atomic_write_text
from ..running.results import ERROR_NAMES, REGISTRATION_MEASURES, VARIANTS
from .rows import DeformationComparisonRow
from .statistics import paired_comparison

__all__ = [
    "MEASURES",
    "model_label",
    "compare_deformations",
    "comparison_markdown",
    "comparison_csv",
    "write_model_comparison",
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


def model_label(name: str) -> str:
    """What tables call the model ``name`` (its ``label`` when registered)."""
    try:
        return deformation_model(name).label or name.upper()
    except DeformationModelError:
        return name.upper()


def compare_deformations(
    lddmm: list, svf: list, seed: int = 0, n_boot: int = 2000, names=("lddmm", "svf")
) -> list[DeformationComparisonRow]:
    """One row per ``(alpha^2, variant, measure)``: means and the paired ``svf - lddmm``.

    Parameters
    ----------
    lddmm, svf : lists of SubjectResults
        :attr:`ladders.study.running.runner.StudyOutcome.results` of the reference
        study and of the one compared with it (any two models: see ``names``);
        subjects are matched by name, and a subject missing from either (a failed
        pair) is left out of that ``alpha^2``.
    seed : int
        Seed of the bootstrap (``numpy.random.default_rng``).
    n_boot : int
        Bootstrap resamples.
    names : (str, str)
        The two models' names, the reference first.

    Returns
    -------
    list of DeformationComparisonRow
        ``alpha2, variant, measure, n, reference, model, mean_reference, mean_model,
        fraction_model_lower, median_difference, ci_low, ci_high, wilcoxon_p``.
    """
    reference, other = names
    rng = np.random.default_rng(seed)
    keys = sorted({a for r in lddmm for a in r.alpha2} & {a for r in svf for a in r.alpha2})
    rows = []
    for key in keys:
        for variant, measure in MEASURES:
            a = _values(lddmm, key, variant, measure)
            b = _values(svf, key, variant, measure)
            names_ = sorted(set(a) & set(b))
            x = np.array([b[n] for n in names_])
            y = np.array([a[n] for n in names_])
            stats = paired_comparison(x, y, rng, n_boot=n_boot)
            rows.append(
                DeformationComparisonRow(
                    key, variant or "registration", measure, stats.n, reference, other,
                    float(y.mean()) if names_ else None, float(x.mean()) if names_ else None,
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
    """The comparison as Markdown: one table per compared model (distances in ``unit``;
    the ASE is dimensionless)."""
    pairs = list(dict.fromkeys((r.reference, r.model) for r in rows))
    return "\n".join(_pair_markdown([r for r in rows if (r.reference, r.model) == p], unit)
                     for p in pairs)  # fmt: skip


def _pair_markdown(rows: list[DeformationComparisonRow], unit: str) -> str:
    n = max((r.n for r in rows), default=0)
    ref, model = (model_label(rows[0].reference), model_label(rows[0].model)) if rows else ("", "")
    lines = [
        f"{ref} against {model}, {n} subjects; distances in {unit}, the ASE and the deformation "
        f"norm without unit. Difference = {model} - {ref} per subject (median, 95 % bootstrap "
        "interval); p: Wilcoxon signed-rank.",
        "",
        f"| alpha^2 | variant | measure | {ref} mean | {model} mean | {model} lower | median diff "
        "[95 % CI] | p |",
        "| ---: | --- | --- | ---: | ---: | ---: | --- | ---: |",
    ]
    for r in rows:
        ci = f"{_fmt(r.median_difference)} [{_fmt(r.ci_low)}, {_fmt(r.ci_high)}]"
        lower = "" if r.fraction_model_lower is None else f"{r.fraction_model_lower:.0%}"
        lines.append(
            f"| {r.alpha2:g} | {r.variant} | {r.measure} | {_fmt(r.mean_reference)} | "
            f"{_fmt(r.mean_model)} | {lower} | {ci} | {_fmt(r.wilcoxon_p, '.2g')} |"
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


def write_model_comparison(results: dict, output) -> tuple[Path, str]:
    """Compare every model of ``results`` with the first; write ``comparison.md`` and ``.csv``.

    What ``symladders study --deformation A,B,...`` writes next to the studies.

    Parameters
    ----------
    results : dict
        ``{model name: list of SubjectResults}`` on the same subjects, the reference first.
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
    names = list(results)
    if len(names) < 2:
        raise ValueError(f"results: expected two models or more, got {names}")
    reference = names[0]
    rows = [row for other in names[1:]
            for row in compare_deformations(results[reference], results[other],
                                            names=(reference, other))]  # fmt: skip
    units = [p.unit for r in results[reference] for p in r.pairs]
    text = comparison_markdown(rows, units[0] if units else "mm")
    atomic_write_text(output / "comparison.csv", comparison_csv(rows))
    atomic_write_text(output / "comparison.md", text)
    return output / "comparison.md", text


def write_deformation_comparison(
    lddmm: list, svf: list, output, names=("lddmm", "svf")
) -> tuple[Path, str]:
    """Compare two studies' results and write ``comparison.md`` and ``comparison.csv``
    (:func:`write_model_comparison` of the two, ``names`` the reference first).

    Parameters
    ----------
    lddmm, svf : list of SubjectResults
        The two studies' results on the same subjects.
    output : path
        The folder (created if needed).
    names : (str, str)

    Returns
    -------
    path : Path
        ``comparison.md``.
    text : str
        Its Markdown.
    """
    return write_model_comparison(dict(zip(names, (lddmm, svf), strict=True)), output)
