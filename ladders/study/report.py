"""Tables and figures of the study (the paper's Table 1, Fig. 4, Fig. 5a and Fig. 5b)."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from .pipeline import ERROR_NAMES, VARIANTS
from .store import atomic_write_text

__all__ = ["summarize", "summary_markdown", "write_report"]

_LABELS = {
    "midpoint_distance": "Midpoint distance",
    "centrality": "Centrality",
    "involutivity": "Involutivity",
    "transvectivity": "Transvectivity",
    "ase": "Area strain error (pole ladder)",
}


def _alpha_keys(results: list[dict]) -> list[str]:
    keys = list(results[0]["alpha2"].keys())
    return sorted(keys, key=float)


def _collect(results: list[dict], key: str, path: tuple) -> np.ndarray:
    values = []
    for r in results:
        node = r["alpha2"][key]
        for p in path:
            node = node[p]
        values.append(float(node))
    return np.asarray(values)


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


def summary_markdown(rows: list[dict], unit: str = "mm") -> str:
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
            cells += [f"{get[(a, name, v)]:.3g}" for v in VARIANTS]
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
            cells += [f"{get[(a, name, variant)]:.3g}", ""]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _plot_errors(results, path: Path) -> None:
    import matplotlib.pyplot as plt

    keys = _alpha_keys(results)
    fig, axes = plt.subplots(2, 2, figsize=(11, 8))
    colors = {"residual": "tab:blue", "no_residual": "tab:orange"}
    for ax, name in zip(axes.ravel(), ERROR_NAMES, strict=True):
        for j, variant in enumerate(VARIANTS):
            data = [np.maximum(_collect(results, k, (variant, name)), 1e-16) for k in keys]
            pos = np.arange(len(keys)) * 3 + j
            bp = ax.boxplot(data, positions=pos, widths=0.8, patch_artist=True, showfliers=True)
            for patch in bp["boxes"]:
                patch.set_facecolor(colors[variant])
                patch.set_alpha(0.6)
        ax.set_xticks(np.arange(len(keys)) * 3 + 0.5)
        ax.set_xticklabels([f"{float(k):g}" for k in keys])
        ax.set_yscale("log")
        ax.set_title(_LABELS[name])
        ax.set_xlabel("alpha²")
        ax.set_ylabel("error (mm)")
        ax.grid(True, axis="y", alpha=0.3)
    handles = [plt.Rectangle((0, 0), 1, 1, color=c, alpha=0.6) for c in colors.values()]
    fig.legend(handles, ["with residuals", "without residuals"], loc="upper center", ncol=2)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_ase(results, path: Path) -> None:
    import matplotlib.pyplot as plt

    keys = _alpha_keys(results)
    x = np.array([float(k) for k in keys])
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    series = {
        "pole ladder, residuals": ("residual", "ase"),
        "pole ladder, no residuals": ("no_residual", "ase"),
        "fanning scheme": ("fanning", "ase"),
    }
    for label, p in series.items():
        vals = np.array([_collect(results, k, p) for k in keys])
        mean, std = vals.mean(axis=1), vals.std(axis=1)
        ax.errorbar(x, mean, yerr=std, marker="o", capsize=3, label=label)
    ax.set_xscale("log")
    ax.set_xlabel("alpha²")
    ax.set_ylabel("ASE (area strain error)")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_maps(result: dict, atlas, subject_ed, faces, path: Path) -> None:
    import matplotlib.pyplot as plt

    keys = _alpha_keys([result])
    key = min(keys, key=lambda k: abs(np.log(float(k))))  # closest to alpha^2 = 1
    las = result["alpha2"][key]["las"]
    panels = [
        ("S - S' on S (subject)", subject_ed, las["subject"]),
        ("T - T' on T, pole ladder, residuals", atlas, las["residual"]),
        ("T - T' on T, pole ladder, no residuals", atlas, las["no_residual"]),
        ("T - T' on T, fanning scheme", atlas, las["fanning"]),
    ]
    values = np.concatenate([np.asarray(p[2]) for p in panels])
    lo, hi = np.percentile(values, [2, 98])
    fig = plt.figure(figsize=(10, 9))
    surf = None
    for i, (title, verts, vals) in enumerate(panels):
        ax = fig.add_subplot(2, 2, i + 1, projection="3d")
        face_vals = np.asarray(vals)[np.asarray(faces)].mean(axis=1)
        surf = ax.plot_trisurf(
            verts[:, 0], verts[:, 1], verts[:, 2], triangles=faces, cmap="viridis", linewidth=0
        )
        surf.set_array(face_vals)
        surf.set_clim(lo, hi)
        ax.set_box_aspect(np.ptp(verts, axis=0))
        ax.view_init(elev=15, azim=-60)
        ax.set_title(title, fontsize=10)
        ax.set_axis_off()
    fig.colorbar(surf, ax=fig.axes, shrink=0.5, label="local area strain (a - a') / a")
    fig.suptitle(f"Area strain maps, subject {result['subject']}, alpha² = {float(key):g}")
    fig.savefig(path, dpi=100)
    plt.close(fig)


def write_report(results: list[dict], output, atlas, faces, map_subject_ed=None) -> dict:
    """Write ``summary.csv``, ``summary.md`` and the figures; return their paths.

    Parameters
    ----------
    results : list of per-subject result dicts (from :func:`ladders.study.run_subject`)
    output : path of the results folder
    atlas : array (k, 3); faces : int array (f, 3)
    map_subject_ed : array (k, 3), optional
        End-diastole mesh of the first subject, for the area strain maps.
    """
    import matplotlib

    matplotlib.use("Agg")
    output = Path(output)
    rows = summarize(results)
    paths = {
        "summary_csv": output / "summary.csv",
        "summary_md": output / "summary.md",
        "errors_png": output / "fig4_symmetry_errors.png",
        "ase_png": output / "fig5a_area_strain_error.png",
    }
    atomic_write_text(paths["summary_csv"], summary_csv(rows))
    atomic_write_text(paths["summary_md"], summary_markdown(rows))
    _plot_errors(results, paths["errors_png"])
    _plot_ase(results, paths["ase_png"])
    if map_subject_ed is not None:
        paths["maps_png"] = output / "fig5b_area_strain_maps.png"
        _plot_maps(
            results[0], np.asarray(atlas), np.asarray(map_subject_ed), faces, paths["maps_png"]
        )
    return paths
