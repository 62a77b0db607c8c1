"""Figures of the study: the paper's Fig. 4 (symmetry errors), Fig. 5a (ASE) and Fig. 5b (maps)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..running.pipeline import ERROR_NAMES, VARIANTS

__all__ = ["plot_errors", "plot_ase", "plot_maps", "alpha_keys", "collect"]

LABELS = {
    "midpoint_distance": "Midpoint distance",
    "centrality": "Centrality",
    "involutivity": "Involutivity",
    "transvectivity": "Transvectivity",
    "ase": "Area strain error (pole ladder)",
}
_COLORS = {"residual": "tab:blue", "no_residual": "tab:orange", "fanning": "tab:green"}
_METHOD_LABELS = {
    "residual": "pole ladder, with residuals",
    "no_residual": "pole ladder, without residuals",
    "fanning": "fanning scheme",
}


def alpha_keys(results: list[dict]) -> list[str]:
    """The ``alpha^2`` keys present in any subject's results, in increasing order."""
    return sorted({k for r in results for k in r["alpha2"]}, key=float)


def collect(results: list[dict], key: str, path: tuple) -> np.ndarray:
    """Values at ``alpha2[key][path...]`` over the subjects that have a result there."""
    values = []
    for r in results:
        if key not in r["alpha2"]:
            continue  # failed at this alpha^2
        node = r["alpha2"][key]
        for p in path:
            node = node[p]
        values.append(float(node))
    return np.asarray(values)


def _boxes(ax, results, keys, series: dict, log: bool) -> None:
    """Grouped box plots: one group per alpha^2, one box per series."""
    width = len(series) + 1
    for j, (variant, path) in enumerate(series.items()):
        data = [collect(results, k, path) for k in keys]
        if log:
            data = [np.maximum(v, 1e-16) for v in data]
        bp = ax.boxplot(
            data, positions=np.arange(len(keys)) * width + j, widths=0.8, patch_artist=True,
            showfliers=True, medianprops={"color": "black"}, flierprops={"markersize": 3},
        )  # fmt: skip
        for patch in bp["boxes"]:
            patch.set_facecolor(_COLORS[variant])
            patch.set_alpha(0.7)
    ax.set_xticks(np.arange(len(keys)) * width + (len(series) - 1) / 2)
    ax.set_xticklabels([f"{float(k):g}" for k in keys])
    ax.set_xlabel("α²")
    if log:
        ax.set_yscale("log")
    ax.grid(True, axis="y", which="both", alpha=0.3)


def plot_errors(results: list[dict], path: Path, unit: str) -> None:
    """Fig. 4: the four errors per alpha^2, with and without residuals (box plots).

    The median registration error and inverse consistency over the subjects are
    drawn on every panel as reference levels.
    """
    import matplotlib.pyplot as plt

    keys = alpha_keys(results)
    n = len(results)
    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    centres = np.arange(len(keys)) * 3 + 0.5
    refs = {
        "registration_error": ("median registration error T→S", "k--", "s"),
        "inverse_consistency": ("median inverse consistency", "k:", "^"),
    }
    for ax, name in zip(axes.ravel(), ERROR_NAMES, strict=True):
        _boxes(ax, results, keys, {v: (v, name) for v in VARIANTS}, log=True)
        for ref, (label, style, marker) in refs.items():
            levels = [np.median(collect(results, k, (ref,))) for k in keys]
            ax.plot(centres, np.maximum(levels, 1e-16), style, marker=marker, ms=5, label=label)
        ax.set_title(LABELS[name], fontsize=12)
        ax.set_ylabel(f"error, {unit}")
    handles = [plt.Rectangle((0, 0), 1, 1, color=_COLORS[v], alpha=0.7) for v in VARIANTS]
    handles += axes[0, 0].get_lines()[-2:]
    labels = ["with residuals", "without residuals", *(r[0] for r in refs.values())]
    fig.legend(handles, labels, loc="upper center", ncol=4, bbox_to_anchor=(0.5, 0.955))
    fig.suptitle(f"Symmetry errors of the pole ladder, {n} subjects, in {unit}", fontsize=14)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_ase(results: list[dict], path: Path) -> None:
    """Fig. 5a: area strain error per alpha^2 and transport method (box plots)."""
    import matplotlib.pyplot as plt

    keys = alpha_keys(results)
    fig, ax = plt.subplots(figsize=(9, 5))
    series = {v: (v, "ase") for v in (*VARIANTS, "fanning")}
    _boxes(ax, results, keys, series, log=True)
    ax.set_ylabel("ASE (dimensionless: relative area change)")
    handles = [plt.Rectangle((0, 0), 1, 1, color=_COLORS[v], alpha=0.7) for v in series]
    ax.legend(handles, [_METHOD_LABELS[v] for v in series], fontsize=9)
    ax.set_title(
        f"Area strain error of the transported deformation, {len(results)} subjects\n"
        "boxes: quartiles, whiskers: 1.5 IQR, line: median"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _surface(ax, verts, faces, values, cmap, lim, azim) -> object:
    face_vals = np.asarray(values)[np.asarray(faces)].mean(axis=1)
    surf = ax.plot_trisurf(
        verts[:, 0], verts[:, 1], verts[:, 2], triangles=faces, cmap=cmap, linewidth=0
    )
    surf.set_array(face_vals)
    surf.set_clim(*lim)
    ax.set_box_aspect(np.ptp(verts, axis=0), zoom=1.25)
    ax.view_init(elev=10, azim=azim)
    ax.set_axis_off()
    return surf


def _map_pair(subfig, verts, faces, values, cmap, lim, title, views) -> object:
    """One map from two views side by side, in a subfigure titled ``title``."""
    surf = None
    for j, azim in enumerate(views):
        ax = subfig.add_subplot(1, 2, j + 1, projection="3d")
        surf = _surface(ax, verts, faces, values, cmap, lim, azim)
        ax.text2D(0.5, 0.1, f"view {j + 1}: azimuth {azim:g}°", transform=ax.transAxes,
                  ha="center", fontsize=8)  # fmt: skip
    subfig.subplots_adjust(left=0.0, right=1.0, bottom=0.0, top=0.84, wspace=0.0)
    subfig.suptitle(title, fontsize=10, y=0.99)
    return surf


def plot_maps(result: dict, atlas, subject_ed, faces, path: Path, n_subjects: int) -> None:
    """Fig. 5b: local area strain maps and their error, two views, ASE in the titles.

    Top row: the subject's strain ``LAS_S`` on ``S`` and the transported strain
    ``LAS_T'`` on ``T`` for the three methods; bottom row: the error map
    ``LAS_T' - LAS_S`` of each method. Every map is shown from two opposite
    sides (azimuths -60 and 120 degrees).
    """
    import matplotlib.pyplot as plt

    key = min(alpha_keys([result]), key=lambda k: abs(np.log(float(k))))  # nearest to 1
    pair = result["alpha2"][key]
    las = {k: np.asarray(v, dtype=float) for k, v in pair["las"].items()}
    methods = (*VARIANTS, "fanning")
    strain_lim = np.percentile(np.concatenate(list(las.values())), [2, 98])
    err = {m: las[m] - las["subject"] for m in methods}
    e = float(np.percentile(np.abs(np.concatenate(list(err.values()))), 98)) or 1.0
    views = (-60.0, 120.0)
    fig = plt.figure(figsize=(15, 7.5))
    head, top, bottom = fig.subfigures(3, 1, height_ratios=(0.08, 1, 1))
    sub = np.array([top.subfigures(1, 4), bottom.subfigures(1, 4)])
    s1 = _map_pair(sub[0, 0], subject_ed, faces, las["subject"], "viridis", strain_lim,
                   "LAS_S on S (subject)", views)  # fmt: skip
    for col, m in enumerate(methods, start=1):
        ase = f"ASE = {pair[m]['ase']:.3g}"
        _map_pair(sub[0, col], atlas, faces, las[m], "viridis", strain_lim,
                  f"LAS_T′ on T: {_METHOD_LABELS[m]}\n{ase}", views)  # fmt: skip
        s2 = _map_pair(sub[1, col], atlas, faces, err[m], "RdBu_r", (-e, e),
                       f"error LAS_T′ − LAS_S: {_METHOD_LABELS[m]}\n{ase}", views)  # fmt: skip
    for x, surf, label in (
        (0.3, s1, "local area strain (a − a′)/a\n(top row)"),
        (0.7, s2, "error LAS_T′ − LAS_S\n(bottom row)"),
    ):
        cax = sub[1, 0].add_axes((x - 0.08, 0.1, 0.07, 0.75))
        sub[1, 0].colorbar(surf, cax=cax, label=label)
    head.suptitle(
        f"Local area strain (dimensionless), subject {result['subject']} "
        f"(1 of {n_subjects} subjects), α² = {float(key):g}",
        fontsize=13,
        y=0.9,
    )
    fig.savefig(path, dpi=90)
    plt.close(fig)
