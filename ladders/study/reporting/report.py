"""Tables and figures of the study (the paper's Table 1, Fig. 4, Fig. 5a and Fig. 5b)."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ..files import atomic_write_text
from ..running.results import ERROR_NAMES, REGISTRATION_MEASURES, VARIANTS, RegistrationCounts
from .figures import plot_ase, plot_errors, plot_maps
from .rows import PairedRow, SummaryRow
from .selection import LABELS, alpha_values, collect, other_rows, row_label, skipped_transports
from .statistics import paired_csv, paired_statistics, tidy_csv, tidy_rows

__all__ = [
    "summarize",
    "summary_markdown",
    "terminal_summary",
    "paired_markdown",
    "failures_markdown",
    "convergence_markdown",
    "skipped_markdown",
    "write_report",
]

_REGISTRATION_LABELS = {
    "registration_error": "Reg. error",
    "registration_norm": "Reg. norm",
    "inverse_consistency": "Inverse cons.",
}


def summarize(results: list) -> list[SummaryRow]:
    """Mean (and standard deviation) of every measure per ``alpha^2`` and variant.

    Parameters
    ----------
    results : list of SubjectResults

    Returns
    -------
    list of SummaryRow
        One row per ``(alpha2, measure, variant)`` with ``mean``, ``std``, ``n``;
        ``variant`` is ``"residual"``, ``"no_residual"``, the model's own transport
        method (its ASE; none for a model without one) or ``"both"`` (the registration
        measures).
    """
    if not any(r.pairs for r in results):
        return []
    measures = [(name, v, v) for v in VARIANTS for name in (*ERROR_NAMES, "ase")]
    measures += [("ase", other, other) for other in other_rows(results)]
    measures += [(name, VARIANTS[0], "both") for name in REGISTRATION_MEASURES]
    rows = []
    for a2 in alpha_values(results):
        for name, row, variant in measures:
            vals = collect(results, a2, row, name)
            std = float(vals.std(ddof=1)) if vals.size > 1 else 0.0
            rows.append(SummaryRow(a2, name, variant, float(vals.mean()), std, int(vals.size)))
    return rows


def summary_csv(rows: list[SummaryRow]) -> str:
    """The rows of :func:`summarize` as CSV text."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=SummaryRow.fields())
    writer.writeheader()
    writer.writerows(r.as_dict() for r in rows)
    return buf.getvalue()


def _cell(get: dict, key: tuple) -> str:
    return f"{get[key]:.3g}" if key in get else "n/a"


def convergence_markdown(results: list, stopping: str | None = None) -> str:
    """One paragraph: registrations, the fraction that converged (met the stopping rule,
    stated when ``stopping`` describes it), mean iterations and flow passes, and the
    largest final gradient (in the optimiser's variables)."""
    c = RegistrationCounts.total(p.counts for r in results for p in r.pairs)
    n, bad = c.n_registrations, c.non_converged
    if n == 0:
        return "No registration.\n"
    rule = f" (the stopping rule: {stopping})" if stopping else ""
    return (
        f"Registrations: {n}; {n - bad} ({(n - bad) / n:.2%}) converged{rule}, "
        f"{bad} stopped before; {c.n_iterations / n:.0f} iterations on average "
        f"({c.n_flow_evaluations / n:.0f} flow passes); largest final gradient "
        f"{c.max_gradient_norm:.3g} (optimiser's normalised variables).\n"
    )


def _means(rows: list[SummaryRow]) -> dict:
    return {(r.alpha2, r.measure, r.variant): r.mean for r in rows}


def _others(rows: list[SummaryRow]) -> list[str]:
    """The rows' transport methods that are not a variant's pole ladder, in order."""
    return list(dict.fromkeys(r.variant for r in rows if r.variant not in (*VARIANTS, "both")))


def skipped_markdown(results: list) -> str:
    """One line per transport the deformation model does not have, with the reason
    (an empty string when it has them all)."""
    skipped = skipped_transports(results)
    return "".join(f"Not run: {row_label(m)} ({why}).\n" for m, why in skipped.items())


def summary_markdown(rows: list[SummaryRow], unit: str) -> str:
    """A Table-1-style Markdown table: mean errors per ``alpha^2``, residual vs no residual."""
    alphas = sorted({r.alpha2 for r in rows})
    get = _means(rows)
    head = "| Error type | " + " | ".join(
        f"a²={a:g} Residual | a²={a:g} No residual" for a in alphas
    )
    lines = [f"Mean over subjects, distances in {unit}.", "", head + " |"]
    lines.append("|---" * (1 + 2 * len(alphas)) + "|")
    for name in (*ERROR_NAMES, "ase"):
        cells = []
        for a in alphas:
            cells += [_cell(get, (a, name, v)) for v in VARIANTS]
        lines.append(f"| {LABELS[name]} | " + " | ".join(cells) + " |")
    single = [("ase", o, f"Area strain error ({row_label(o)})") for o in _others(rows)]
    single += [(name, "both", label) for name, label in _REGISTRATION_LABELS.items()]
    for name, variant, label in single:
        cells = []
        for a in alphas:  # one value per alpha^2, shared by both variants
            cells += [_cell(get, (a, name, variant)), ""]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def terminal_summary(rows: list[SummaryRow], unit: str, n_subjects: int) -> str:
    """The summary in at most 100 columns: one line per ``alpha^2``, two tables.

    Each cell of the first table holds the mean with and without residuals;
    the second holds the model's own transport's ASE (when it has one) and the
    registration measures.
    """
    alphas = sorted({r.alpha2 for r in rows})
    get = _means(rows)
    others = _others(rows)
    names = {"midpoint_distance": "midpoint", "centrality": "centrality",
             "involutivity": "involutivity", "transvectivity": "transvect.",
             "ase": "ASE pole ladder"}  # fmt: skip
    lines = [
        f"Means over {n_subjects} subjects, distances in {unit}; cell: with / without residuals.",
        "α²      | " + " | ".join(f"{v:<15}" for v in names.values()),
    ]
    for a in alphas:
        cells = [f"{_cell(get, (a, n, 'residual'))} / {_cell(get, (a, n, 'no_residual'))}"
                 for n in names]  # fmt: skip
        lines.append(f"{a:<7g} | " + " | ".join(f"{c:<15}" for c in cells))
    heads = [*(f"ASE {o}" for o in others), *_REGISTRATION_LABELS.values()]
    lines += ["", "α²      | " + " | ".join(f"{h:<15}" for h in heads)]
    for a in alphas:
        cells = [_cell(get, (a, "ase", o)) for o in others]
        cells += [_cell(get, (a, n, "both")) for n in _REGISTRATION_LABELS]
        lines.append(f"{a:<7g} | " + " | ".join(f"{c:<15}" for c in cells))
    return "\n".join(line.rstrip() for line in lines) + "\n"


def _fmt(v, spec: str) -> str:
    return "n/a" if v is None else format(v, spec)


def paired_markdown(rows: list[PairedRow], unit: str) -> str:
    """The paired comparison residual vs no residual as a Markdown table."""
    lines = [
        "Paired comparison, with residuals minus without, per subject "
        f"(differences in {unit}; the ASE is dimensionless).",
        "",
        "| α² | Error | n | Residual lower | Median difference | 95 % bootstrap CI "
        "| Wilcoxon p | Note |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        frac = "n/a" if r.fraction_residual_lower is None else f"{r.fraction_residual_lower:.0%}"
        ci = f"[{_fmt(r.ci_low, '.3g')}, {_fmt(r.ci_high, '.3g')}]"
        lines.append(
            f"| {r.alpha2:g} | {LABELS[r.measure]} | {r.n} | {frac} | "
            f"{_fmt(r.median_difference, '.3g')} | {ci} | {_fmt(r.wilcoxon_p, '.3g')} "
            f"| {r.note} |"
        )
    return "\n".join(lines) + "\n"


def failures_markdown(results: list) -> str:
    """The failed (subject, alpha^2) pairs with their error, or an empty string."""
    failed = [f for r in results for f in r.failures]
    if not failed:
        return ""
    subjects = len({f.subject for f in failed})
    lines = [f"{len(failed)} pair(s) of {subjects} subject(s) failed (left out above):", ""]
    lines += [f"- {f.subject}, α² = {f.alpha2:g}: {f.error}" for f in failed]
    return "\n".join(lines) + "\n"


def write_report(
    results: list,
    output,
    atlas,
    faces,
    subjects_ed=None,
    unit: str | None = None,
    stopping: str | None = None,
    units: str | None = None,
) -> dict:
    """Write the tables and figures of the study; return their paths.

    Files: ``summary.csv`` (mean, std per ``alpha^2``, measure, variant),
    ``results.csv`` (tidy, one row per subject, ``alpha^2``, variant and
    measure), ``paired_statistics.csv``, ``summary.md`` (Table 1, the paired
    comparison, the failures) and the figures ``fig4_symmetry_errors.png``,
    ``fig5a_area_strain_error.png``, ``fig5b_area_strain_maps.png``.

    Parameters
    ----------
    results : list of SubjectResults
        :attr:`ladders.study.running.runner.StudyOutcome.results`.
    output : path of the results folder
    atlas : array (k, 3); faces : int array (f, 3)
    subjects_ed : mapping, optional
        End-diastole vertices ``(k, 3)`` by subject name, for the area strain maps
        of the representative subject (Fig. 5b; not drawn without them).
    unit : str, optional
        Unit of the distances; default: the results' ``unit``.
    stopping : str, optional
        The registrations' stopping rule in words
        (:meth:`manifolds.numerics.solvers.StoppingRule.describe`), stated in
        ``summary.md`` as what "converged" means.
    units : str, optional
        How the meshes' units were obtained (checked, given, detected;
        :meth:`~ladders.study.preparation.UnitsReport.describe`), stated in ``summary.md``
        under Table 1.

    Returns
    -------
    dict
        Paths by key; ``"maps_subject"`` names the subject of Fig. 5b.
    """
    import matplotlib

    matplotlib.use("Agg")
    output = Path(output)
    ok = [r for r in results if r.pairs]
    paths = {k: output / v for k, v in _FILES.items()}
    if not ok:  # every pair failed: only the list of failures
        atomic_write_text(paths["summary_md"], failures_markdown(results))
        return {"summary_md": paths["summary_md"]}
    unit = unit or ok[0].pairs[0].unit
    rows, paired = summarize(results), paired_statistics(results, seed=0)
    text = summary_markdown(rows, unit) + "\n" + (f"{units}\n\n" if units else "")
    if skipped_markdown(results):
        text += skipped_markdown(results) + "\n"
    text += convergence_markdown(results, stopping) + "\n"
    text += paired_markdown(paired, unit)
    if failures_markdown(results):
        text += "\n" + failures_markdown(results)
    atomic_write_text(paths["summary_csv"], summary_csv(rows))
    atomic_write_text(paths["results_csv"], tidy_csv(tidy_rows(results, unit)))
    atomic_write_text(paths["paired_csv"], paired_csv(paired))
    atomic_write_text(paths["summary_md"], text)
    plot_errors(ok, paths["errors_png"], unit)
    plot_ase(ok, paths["ase_png"])
    if subjects_ed is not None:
        paths["maps_png"] = output / "fig5b_area_strain_maps.png"
        paths["maps_subject"] = plot_maps(
            ok, np.asarray(atlas), subjects_ed, faces, paths["maps_png"]
        )
    return paths


_FILES = {
    "summary_csv": "summary.csv",
    "results_csv": "results.csv",
    "paired_csv": "paired_statistics.csv",
    "summary_md": "summary.md",
    "errors_png": "fig4_symmetry_errors.png",
    "ase_png": "fig5a_area_strain_error.png",
}
