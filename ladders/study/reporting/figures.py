"""Figures of the study: the paper's Fig. 4 (symmetry errors), Fig. 5a (ASE) and Fig. 5b (maps)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..running.results import ERROR_NAMES, VARIANTS
from .selection import (
    LABELS,
    VARIANT_METHOD,
    alpha_values,
    collect,
    representative_subject,
    row_label,
    transport_rows,
)

__all__ = ["plot_errors", "plot_ase", "plot_maps", "map_pair"]

_COLORS = {"residual": "tab:blue", "no_residual": "tab:orange"}
_OTHER_COLOR = "tab:green"


def _centres(keys) -> np.ndarray:
    """Positions of the alpha^2 groups on a log-spaced axis (log10 alpha^2)."""
    return np.log10(np.asarray([float(k) for k in keys]))


def _boxes(ax, results, keys, rows: list, measure: str, log: bool) -> None:
    """Grouped box plots on a log-spaced alpha^2 axis: one group per alpha^2, one box per row."""
    centres = _centres(keys)
    gaps = np.diff(centres)
    group = 0.8 * (gaps.min() if gaps.size else 1.0)
    box = group / len(rows)
    for j, row in enumerate(rows):
        data = [collect(results, k, row, measure) for k in keys]
        if log:
            data = [np.maximum(v, 1e-16) for v in data]
        positions = centres + (j - (len(rows) - 1) / 2) * box
        bp = ax.boxplot(
            data, positions=positions, widths=0.85 * box, patch_artist=True,
            showfliers=True, medianprops={"color": "black"}, flierprops={"markersize": 3},
        )  # fmt: skip
        for patch in bp["boxes"]:
            patch.set_facecolor(_COLORS.get(row, _OTHER_COLOR))
            patch.set_alpha(0.7)
    ax.set_xticks(centres)
    ax.set_xticklabels([f"{float(k):g}" for k in keys])
    ax.set_xlim(centres.min() - group, centres.max() + group)
    ax.set_xlabel("α² (log scale)")
    if log:
        ax.set_yscale("log")
    ax.grid(True, axis="y", which="both", alpha=0.3)


def plot_errors(results: list[dict], path: Path, unit: str) -> None:
    """Fig. 4: the four errors per alpha^2, with and without residuals (box plots).

    The median registration error and inverse consistency over the subjects are
    drawn on every panel as reference levels.
    """
    import matplotlib.pyplot as plt

    keys = alpha_values(results)
    n = len(results)
    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    centres = _centres(keys)
    refs = {
        "registration_error": ("median registration error T→S", "k--", "s"),
        "inverse_consistency": ("median inverse consistency", "k:", "^"),
    }
    for ax, name in zip(axes.ravel(), ERROR_NAMES, strict=True):
        _boxes(ax, results, keys, list(VARIANTS), name, log=True)
        for ref, (label, style, marker) in refs.items():
            levels = [np.median(collect(results, k, VARIANTS[0], ref)) for k in keys]
            ax.plot(centres, np.maximum(levels, 1e-16), style, marker=marker, ms=5, label=label)
        ax.set_title(LABELS[name], fontsize=12)
        ax.set_ylabel(f"error, {unit}")
    handles = [plt.Rectangle((0, 0), 1, 1, color=_COLORS[v], alpha=0.7) for v in VARIANTS]
    handles += axes[0, 0].get_lines()[-2:]
    labels = ["with residuals", "without residuals", *(r[0] for r in refs.values())]
    fig.legend(handles, labels, loc="upper center", ncol=4, bbox_to_anchor=(0.5, 0.935))
    fig.suptitle(
        "Fig. 4: the symmetry errors against α², with and without residuals\n"
        f"{n} subjects; errors in {unit}",
        fontsize=13,
    )
    fig.tight_layout(rect=(0, 0, 1, 0.915))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_ase(results: list[dict], path: Path) -> None:
    """Fig. 5a: area strain error per alpha^2 and transport method (box plots)."""
    import matplotlib.pyplot as plt

    keys = alpha_values(results)
    fig, ax = plt.subplots(figsize=(9, 5))
    rows = transport_rows(results)
    _boxes(ax, results, keys, rows, "ase", log=True)
    ax.set_ylabel("ASE (dimensionless: relative area change)")
    colors = [_COLORS.get(row, _OTHER_COLOR) for row in rows]
    handles = [plt.Rectangle((0, 0), 1, 1, color=c, alpha=0.7) for c in colors]
    ax.legend(handles, [row_label(row) for row in rows], fontsize=9)
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
        verts[:, 0], verts[:, 1], verts[:, 2], triangles=faces, cmap=cmap, linewidth=0,
        antialiased=False, shade=False,
    )  # fmt: skip
    surf.set_array(face_vals)  # flat colour per face, no lighting: no banding
    surf.set_clim(*lim)
    ax.set_box_aspect(np.ptp(verts, axis=0), zoom=1.35)
    ax.view_init(elev=10, azim=azim)
    ax.set_axis_off()
    return surf


def map_pair(subfig, verts, faces, values, cmap, lim, title, views) -> object:
    """One map of per-vertex ``values`` on a mesh from two views (azimuths ``views``,
    degrees) side by side, in the matplotlib subfigure ``subfig`` titled ``title``;
    returns the last surface (for a colour bar)."""
    surf = None
    for j, azim in enumerate(views):
        ax = subfig.add_subplot(1, 2, j + 1, projection="3d")
        surf = _surface(ax, verts, faces, values, cmap, lim, azim)
        ax.text2D(0.5, 0.02, f"view {j + 1}: azimuth {azim:g}°", transform=ax.transAxes,
                  ha="center", fontsize=8)  # fmt: skip
    subfig.subplots_adjust(left=0.0, right=1.0, bottom=0.0, top=0.86, wspace=-0.15)
    subfig.suptitle(title, fontsize=10, y=0.99)
    return surf


def plot_maps(results: list, atlas, subjects_ed, faces, path: Path) -> str:
    """Fig. 5b: local area strain maps of a representative subject and their error.

    The subject is the one with the median ASE of the pole ladder with residuals
    (:func:`representative_subject`) at the ``alpha^2`` nearest 1; the title says
    which. Top row: the subject's strain ``LAS_S`` on ``S`` and the transported
    strain ``LAS_T'`` on ``T`` for the three methods; bottom row: the error map
    ``LAS_T' - LAS_S`` of each method, the ASE in each title. Every map is shown
    from two opposite sides (azimuths -60 and 120 degrees).

    Parameters
    ----------
    results : list of SubjectResults
    atlas : array (k, 3)
    subjects_ed : mapping
        End-diastole vertices ``(k, 3)`` by subject name.
    faces : int array (f, 3)
    path : Path

    Returns
    -------
    str
        The name of the subject shown.
    """
    import matplotlib.pyplot as plt

    key = min(alpha_values(results), key=lambda a: abs(np.log(a)))  # nearest to 1
    shown, n_subjects = representative_subject(results, key)
    pair = shown.at(key)
    rows = transport_rows(results)
    las = {row: np.asarray(pair.transport(VARIANT_METHOD.get(row, row)).las) for row in rows}
    subject_las = np.asarray(pair.las_subject)
    strain_lim = np.percentile(np.concatenate([subject_las, *las.values()]), [2, 98])
    err = {row: las[row] - subject_las for row in rows}
    e = float(np.percentile(np.abs(np.concatenate(list(err.values()))), 98)) or 1.0
    views = (-60.0, 120.0)
    fig = plt.figure(figsize=(15, 7.2))
    head, top, bottom = fig.subfigures(3, 1, height_ratios=(0.1, 1, 1))
    sub = np.array([top.subfigures(1, 4), bottom.subfigures(1, 4)])
    s1 = map_pair(sub[0, 0], np.asarray(subjects_ed[shown.subject]), faces, subject_las,
                   "viridis", strain_lim, "LAS_S on S (subject)", views)  # fmt: skip
    for col, row in enumerate(rows, start=1):
        ase = f"ASE = {pair.measure(row, 'ase'):.3g}"
        map_pair(sub[0, col], atlas, faces, las[row], "viridis", strain_lim,
                  f"LAS_T′ on T: {row_label(row)}\n{ase}", views)  # fmt: skip
        s2 = map_pair(sub[1, col], atlas, faces, err[row], "RdBu_r", (-e, e),
                       f"error LAS_T′ − LAS_S: {row_label(row)}\n{ase}", views)  # fmt: skip
    for x, surf, label in (
        (0.3, s1, "local area strain (a − a′)/a\n(top row)"),
        (0.7, s2, "error LAS_T′ − LAS_S\n(bottom row)"),
    ):
        cax = sub[1, 0].add_axes((x - 0.08, 0.1, 0.07, 0.75))
        sub[1, 0].colorbar(surf, cax=cax, label=label)
    head.suptitle(
        f"Local area strain (dimensionless), subject {shown.subject}: the median ASE of the "
        f"pole ladder with residuals among {n_subjects} subjects, α² = {key:g}",
        fontsize=13,
        y=0.85,
    )
    fig.savefig(path, dpi=90, bbox_inches="tight", pad_inches=0.05)
    plt.close(fig)
    return shown.subject
