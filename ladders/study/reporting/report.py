"""Tables and figures of the study (the paper's Table 1, Fig. 4, Fig. 5a and Fig. 5b)."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ..running.pipeline import ERROR_NAMES, VARIANTS
from ..running.store import atomic_write_text
from .figures import LABELS as _LABELS
from .figures import alpha_keys as _alpha_keys
from .figures import collect as _collect
from .figures import plot_ase, plot_errors, plot_maps
from .statistics import DEFAULT_UNIT, paired_csv, paired_statistics, tidy_csv, tidy_rows

__all__ = ["summarize", "summary_markdown", "paired_markdown", "failures_markdown", "write_report"]


def summarize(results: list[dict]) -> list[dict]:
    """Mean (and standard deviation) of every measure per ``alpha^2`` and variant.

    Returns
    -------
    list of dict
        One row per ``(alpha2, measure, variant)`` with ``mean``, ``std``, ``n``.
    """
    rows = []
    for key in _alpha_keys(results):
        measures = [(name, (v, name), v) for v in VARIANTS for name in (*ERROR_NAMES, "ase")]
        measures += [("ase", ("fanning", "ase"), "fanning")]
        measures += [
            (name, (name,), "both")
            for name in ("registration_error", "rkhs_norm", "inverse_consistency")
        ]
        for name, path, variant in measures:
            vals = _collect(results, key, path)
            if vals.size == 0:
                continue  # every subject failed at this alpha^2
            rows.append(
                {
                    "alpha2": float(key),
                    "measure": name,
                    "variant": variant,
                    "mean": float(vals.mean()),
                    "std": float(vals.std(ddof=1)) if vals.size > 1 else 0.0,
                    "n": int(vals.size),
                }
            )
    return rows


def summary_csv(rows: list[dict]) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=["alpha2", "measure", "variant", "mean", "std", "n"])
    writer.writeheader()
    writer.writerows(rows)
    return buf.getvalue()


def _cell(get: dict, key: tuple) -> str:
    return f"{get[key]:.3g}" if key in get else "n/a"


def convergence_markdown(results: list[dict]) -> str:
    """One paragraph: registrations, the fraction that met the optimiser's tolerance,
    mean iterations and the largest final gradient (in the optimiser's variables)."""
    pairs = [p for r in results for p in r["alpha2"].values()]
    n = sum(p["n_registrations"] for p in pairs)
    bad = sum(p["non_converged_registrations"] for p in pairs)
    iters = sum(p.get("n_iterations", 0) for p in pairs)
    grads = [p["max_gradient_norm"] for p in pairs if "max_gradient_norm" in p]
    grad = max(grads, default=float("nan"))
    if n == 0:
        return "No registration.\n"
    return (
        f"Registrations: {n}; {n - bad} ({(n - bad) / n:.2%}) met the optimiser's tolerance, "
        f"{bad} stopped at the iteration limit; {iters / n:.0f} iterations on average; "
        f"largest final gradient {grad:.3g} (optimiser's normalised variables).\n"
    )


def summary_markdown(rows: list[dict], unit: str = DEFAULT_UNIT) -> str:
    """A Table-1-style Markdown table: mean errors per ``alpha^2``, residual vs no residual."""
    alphas = sorted({r["alpha2"] for r in rows})
    get = {(r["alpha2"], r["measure"], r["variant"]): r["mean"] for r in rows}
    head = "| Error type | " + " | ".join(
        f"a²={a:g} Residual | a²={a:g} No residual" for a in alphas
    )
    lines = [f"Mean over subjects, in {unit}.", "", head + " |"]
    lines.append("|---" * (1 + 2 * len(alphas)) + "|")
    for name in (*ERROR_NAMES, "ase"):
        cells = []
        for a in alphas:
            cells += [_cell(get, (a, name, v)) for v in VARIANTS]
        lines.append(f"| {_LABELS[name]} | " + " | ".join(cells) + " |")
    single = [("ase", "fanning", "Area strain error (fanning)")]
    single += [
        (name, "both", label)
        for name, label in (
            ("registration_error", "Reg. error"),
            ("rkhs_norm", "Reg. norm"),
            ("inverse_consistency", "Inverse cons."),
        )
    ]
    for name, variant, label in single:
        cells = []
        for a in alphas:  # one value per alpha^2, shared by both variants
            cells += [_cell(get, (a, name, variant)), ""]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _fmt(v, spec: str) -> str:
    return "n/a" if v is None else format(v, spec)


def paired_markdown(rows: list[dict], unit: str = DEFAULT_UNIT) -> str:
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
        frac = (
            "n/a"
            if r["fraction_residual_lower"] is None
            else (f"{r['fraction_residual_lower']:.0%}")
        )
        ci = f"[{_fmt(r['ci_low'], '.3g')}, {_fmt(r['ci_high'], '.3g')}]"
        lines.append(
            f"| {r['alpha2']:g} | {_LABELS[r['measure']]} | {r['n']} | {frac} | "
            f"{_fmt(r['median_difference'], '.3g')} | {ci} | {_fmt(r['wilcoxon_p'], '.3g')} "
            f"| {r['note']} |"
        )
    return "\n".join(lines) + "\n"


def failures_markdown(results: list[dict]) -> str:
    """The failed (subject, alpha^2) pairs with their error, or an empty string."""
    failed = [(r["subject"], a, e) for r in results for a, e in r.get("failed", {}).items()]
    if not failed:
        return ""
    subjects = len({f[0] for f in failed})
    lines = [f"{len(failed)} pair(s) of {subjects} subject(s) failed (left out above):", ""]
    lines += [f"- {name}, α² = {float(a):g}: {err}" for name, a, err in failed]
    return "\n".join(lines) + "\n"


def write_report(
    results: list[dict], output, atlas, faces, map_subject_ed=None, unit: str | None = None
) -> dict:
    """Write the tables and figures of the study; return their paths.

    Files: ``summary.csv`` (mean, std per ``alpha^2``, measure, variant),
    ``results.csv`` (tidy, one row per subject, ``alpha^2``, variant and
    measure), ``paired_statistics.csv``, ``summary.md`` (Table 1, the paired
    comparison, the failures) and the figures ``fig4_symmetry_errors.png``,
    ``fig5a_area_strain_error.png``, ``fig5b_area_strain_maps.png``.

    Parameters
    ----------
    results : list of per-subject result dicts (:attr:`ladders.study.running.runner.StudyOutcome.results`)
    output : path of the results folder
    atlas : array (k, 3); faces : int array (f, 3)
    map_subject_ed : array (k, 3), optional
        End-diastole mesh of the first subject, for the area strain maps.
    unit : str, optional
        Unit of the distances; default: the results' ``unit`` field, else ``"mm"``.
    """
    import matplotlib

    matplotlib.use("Agg")
    output = Path(output)
    ok = [r for r in results if r["alpha2"]]
    paths = {k: output / v for k, v in _FILES.items()}
    if not ok:  # every pair failed: only the list of failures
        atomic_write_text(paths["summary_md"], failures_markdown(results))
        return {"summary_md": paths["summary_md"]}
    tidy = tidy_rows(results, unit)
    unit = unit or next(row["unit"] for row in tidy if row["measure"] == "centrality")
    rows, paired = summarize(results), paired_statistics(results, seed=0)
    text = summary_markdown(rows, unit) + "\n" + convergence_markdown(results) + "\n"
    text += paired_markdown(paired, unit)
    if failures_markdown(results):
        text += "\n" + failures_markdown(results)
    atomic_write_text(paths["summary_csv"], summary_csv(rows))
    atomic_write_text(paths["results_csv"], tidy_csv(tidy))
    atomic_write_text(paths["paired_csv"], paired_csv(paired))
    atomic_write_text(paths["summary_md"], text)
    plot_errors(ok, paths["errors_png"], unit)
    plot_ase(ok, paths["ase_png"])
    if map_subject_ed is not None and results[0]["alpha2"]:
        paths["maps_png"] = output / "fig5b_area_strain_maps.png"
        plot_maps(
            results[0], np.asarray(atlas), np.asarray(map_subject_ed), faces,
            paths["maps_png"], len(ok),
        )  # fmt: skip
    return paths


_FILES = {
    "summary_csv": "summary.csv",
    "results_csv": "results.csv",
    "paired_csv": "paired_statistics.csv",
    "summary_md": "summary.md",
    "errors_png": "fig4_symmetry_errors.png",
    "ase_png": "fig5a_area_strain_error.png",
}
