"""What ``symladders analyze`` writes: tidy tables, a summary, maps on the atlas and figures.

Layout of an analysis folder::

    vertices.csv        one row per motion, test and atlas vertex (statistic, p-values)
    tests.csv           one row per motion: group sizes, detections, global test, AUC
                        (the wall-motion detections in the last column)
    scores.csv          with a planted truth: power, Dice, AUC, FWER under the null
    summary.md          the above in words and tables
    maps/<motion>.vtu   the atlas with the group means and the test maps (ParaView)
    fig_group_means.png, fig_pvalue_map.png, fig_pca_modes.png, fig_transport_scores.png
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ladders.statistics import mode_shapes
from manifolds.euclidean import Euclidean

from ..files import atomic_write_text
from ..meshes.mesh_outputs import write_point_mesh
from ..reporting.figures import map_pair
from .against_truth import TransportScore, scores_csv, scores_markdown
from .group_comparison import GroupComparison

__all__ = [
    "vertices_csv",
    "tests_csv",
    "summary_markdown",
    "write_maps",
    "plot_group_means",
    "plot_pvalue_map",
    "plot_pca_modes",
    "plot_transport_scores",
    "write_analysis",
]

_TESTS = {
    "displacement": "hotelling_t2",
    "normal": "normal_t",
    "strain": "strain_t",
    "wall_motion": "wall_motion_t",
}


def _file_name(comparison: GroupComparison) -> str:
    return comparison.motion.name.replace("/", "_")


def vertices_csv(comparisons: list[GroupComparison], weight=None, alpha: float = 0.05) -> str:
    """Tidy CSV: one row per motion, test (``hotelling_t2``, ``t``) and vertex."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    header = ["motion", "deformation", "method", "alpha2", "test", "vertex", "statistic",
              "p_uncorrected", "p_fwer", "significant"]  # fmt: skip
    if weight is not None:
        header.append("planted_weight")
    writer.writerow(header)
    for c in comparisons:
        m = c.motion
        alpha2 = "" if m.alpha2 is None else repr(m.alpha2)
        for quantity, name in _TESTS.items():
            test = getattr(c, quantity)
            significant = test.p_fwer < alpha
            for v in range(test.statistic.size):
                row = [m.name, m.deformation, m.method, alpha2, name, v,
                       f"{test.statistic[v]:.10g}", f"{test.p_uncorrected[v]:.6g}",
                       f"{test.p_fwer[v]:.6g}", int(significant[v])]  # fmt: skip
                if weight is not None:
                    row.append(f"{weight[v]:.6g}")
                writer.writerow(row)
    return out.getvalue()


def _test_rows(comparisons, alpha):
    for c in comparisons:
        m, g = c.motion, c.global_test
        yield {
            "motion": m.name,
            "deformation": m.deformation,
            "method": m.method,
            "alpha2": "" if m.alpha2 is None else m.alpha2,
            "n_" + c.groups[0]: int(c.labels.sum()),
            "n_" + c.groups[1]: int((~c.labels).sum()),
            "displacement_vertices_significant": int(c.detected(alpha).sum()),
            "normal_vertices_significant": int(c.detected(alpha, "normal").sum()),
            "strain_vertices_significant": int(c.detected(alpha, "strain").sum()),
            "global_t2": g.statistic,
            "global_p_permutation": g.p_permutation,
            "global_p_parametric": g.p_parametric,
            "pca_components": g.n_components,
            "explained_variance": float(c.pca.explained_variance_ratio[: g.n_components].sum()),
            "auc": c.classifier.auc,
            "auc_ci_low": c.classifier.ci_low,
            "auc_ci_high": c.classifier.ci_high,
            "normalization": c.normalization or "none",
            "wall_motion_vertices_significant": int(c.detected(alpha, "wall_motion").sum()),
        }


def tests_csv(comparisons: list[GroupComparison], alpha: float = 0.05) -> str:
    """CSV of one row per motion: group sizes, detections, the global test and the AUC."""
    rows = list(_test_rows(comparisons, alpha))
    out = io.StringIO()
    if rows:
        writer = csv.DictWriter(out, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    return out.getvalue()


def summary_markdown(
    comparisons: list[GroupComparison],
    alpha: float = 0.05,
    scores: list[TransportScore] | None = None,
    truth: str | None = None,
    header: str = "",
) -> str:
    """The analysis in words and tables (``summary.md``)."""
    c0 = comparisons[0]
    n = c0.displacement.n_permutations
    lines = [
        "# Group comparison of transported motion",
        "",
        header,
        f"Groups: {c0.groups[0]} ({int(c0.labels.sum())}) against {c0.groups[1]} "
        f"({int((~c0.labels).sum())}). Per atlas vertex: Hotelling T² of the displacement "
        f"T' − T, t of its component along the atlas's normal, t of the local area strain "
        f"and t of the normal wall motion (the signed distance along the atlas's normal to "
        f"the surface T'), family-wise error controlled at {alpha:g} by "
        f"{n:,} permutations of the group labels (maximum over the vertices). Global test: "
        f"Hotelling T² of the first PCA scores of the displacements, by permutation. "
        "Classifier: PCA and logistic regression, stratified cross-validation, AUC with a "
        "bootstrap interval over the subjects.",
        "",
        "| motion | vertices found (displacement) | (normal motion) | (wall motion) | (strain) | "
        "global p | AUC [95 % CI] |",
        "|---|---|---|---|---|---|---|",
    ]
    k = c0.displacement.statistic.size
    for row, c in zip(_test_rows(comparisons, alpha), comparisons):
        lines.append(
            f"| {c.motion.label}{'' if c.motion.alpha2 is None else f', α² = {c.motion.alpha2:g}'}"
            f" ({c.motion.deformation}) | {row['displacement_vertices_significant']} / {k} | "
            f"{row['normal_vertices_significant']} / {k} | "
            f"{row['wall_motion_vertices_significant']} / {k} | "
            f"{row['strain_vertices_significant']} / {k} | {row['global_p_permutation']:.2g} | "
            f"{row['auc']:.2f} [{row['auc_ci_low']:.2f}, {row['auc_ci_high']:.2f}] |"
        )
    if scores:
        lines += ["", "## Against the planted truth", "", truth or "", "", scores_markdown(scores)]
        lines.append(
            "Power: fraction of the planted vertices found (displacement test; the normal-"
            "motion, wall-motion and strain powers: by those tests); Dice of the "
            "found region with the planted one; FWER: fraction of random splits of a cohort "
            "without the effect in which any vertex was found, with its exact binomial interval."
        )
    return "\n".join(lines) + "\n"


def write_maps(comparisons: list[GroupComparison], folder: Path, weight=None, alpha=0.05) -> list:
    """One ``.vtu`` of the atlas per motion, with the group means and the test maps."""
    paths = []
    for c in comparisons:
        m = c.motion
        data = {
            f"mean_displacement_{c.groups[0]}": c.group_mean(0),
            f"mean_displacement_{c.groups[1]}": c.group_mean(1),
            "mean_displacement_difference": c.group_mean(0) - c.group_mean(1),
            f"mean_strain_{c.groups[0]}": c.group_mean(0, "strain"),
            f"mean_strain_{c.groups[1]}": c.group_mean(1, "strain"),
            f"mean_wall_motion_{c.groups[0]}": c.group_mean(0, "wall_motion"),
            f"mean_wall_motion_{c.groups[1]}": c.group_mean(1, "wall_motion"),
            "hotelling_t2": c.displacement.statistic,
            "hotelling_p_fwer": c.displacement.p_fwer,
            "hotelling_p_uncorrected": c.displacement.p_uncorrected,
            "hotelling_significant": (c.displacement.p_fwer < alpha).astype(float),
            "normal_t": c.normal.statistic,
            "normal_p_fwer": c.normal.p_fwer,
            "normal_significant": (c.normal.p_fwer < alpha).astype(float),
            "wall_motion_t": c.wall_motion.statistic,
            "wall_motion_p_fwer": c.wall_motion.p_fwer,
            "wall_motion_significant": (c.wall_motion.p_fwer < alpha).astype(float),
            "strain_t": c.strain.statistic,
            "strain_p_fwer": c.strain.p_fwer,
            "strain_significant": (c.strain.p_fwer < alpha).astype(float),
        }
        if weight is not None:
            data["planted_weight"] = weight
            data["planted_region"] = (np.asarray(weight) >= 0.5).astype(float)
        paths.append(write_point_mesh(folder / f"{_file_name(c)}.vtu", m.atlas, m.faces, data))
    return paths


def _save(fig, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=90, bbox_inches="tight", pad_inches=0.05)
    plt.close(fig)
    return path


_VIEWS = (-60.0, 120.0)


def plot_group_means(c: GroupComparison, path: Path) -> Path:
    """Magnitude of each group's mean displacement and of their difference on the atlas."""
    import matplotlib.pyplot as plt

    m = c.motion
    means = [np.linalg.norm(c.group_mean(i), axis=1) for i in (0, 1)]
    diff = np.linalg.norm(c.group_mean(0) - c.group_mean(1), axis=1)
    lim = (0.0, float(max(x.max() for x in means)) or 1.0)
    fig = plt.figure(figsize=(15.6, 3.2))
    subs = fig.subfigures(1, 3)
    for i in (0, 1):
        surf = map_pair(subs[i], m.atlas, m.faces, means[i], "viridis", lim,
                        f"|mean T′ − T|, {c.groups[i]}", _VIEWS)  # fmt: skip
    fig.colorbar(surf, ax=subs[1].axes, shrink=0.6, label="mm")
    surf = map_pair(subs[2], m.atlas, m.faces, diff, "magma", (0.0, float(diff.max()) or 1.0),
                    "|difference of the means|", _VIEWS)  # fmt: skip
    fig.colorbar(surf, ax=subs[2].axes, shrink=0.6, label="mm")
    fig.suptitle(f"Mean motion per group on the atlas: {m.label} ({m.name})", y=1.1)
    return _save(fig, path)


def plot_pvalue_map(c: GroupComparison, path: Path, weight=None, alpha: float = 0.05) -> Path:
    """``-log10`` of the corrected p-values of every vertex test on the atlas (and the truth)."""
    import matplotlib.pyplot as plt

    m = c.motion
    panels = [
        ("displacement (Hotelling T²)", -np.log10(c.displacement.p_fwer)),
        ("normal motion (t)", -np.log10(c.normal.p_fwer)),
        ("normal wall motion (t)", -np.log10(c.wall_motion.p_fwer)),
        ("area strain (t)", -np.log10(c.strain.p_fwer)),
    ]
    if weight is not None:
        panels.append(("planted region (weight)", np.asarray(weight)))
    top = max(float(-np.log10(1.0 / (c.displacement.n_permutations + 1))), 2.0)
    fig = plt.figure(figsize=(5.2 * len(panels), 3.2))
    subs = fig.subfigures(1, len(panels))
    for sub, (title, values) in zip(np.atleast_1d(subs), panels):
        lim = (0.0, 1.0) if title.startswith("planted") else (0.0, top)
        surf = map_pair(sub, m.atlas, m.faces, values, "inferno", lim, title, _VIEWS)
        sub.colorbar(surf, ax=sub.axes, shrink=0.6,
                     label="weight" if lim == (0.0, 1.0) else "−log10 p (FWER)")  # fmt: skip
    fig.suptitle(
        f"Corrected p-values, {m.label} ({m.name}); significant where −log10 p > "
        f"{-np.log10(alpha):.2f}",
        y=1.1,
    )
    return _save(fig, path)


def plot_pca_modes(c: GroupComparison, path: Path, ks=(-2.0, 0.0, 2.0)) -> Path:
    """The first PCA modes of the displacements as atlases deformed at ``k`` standard deviations."""
    import matplotlib.pyplot as plt

    m = c.motion
    space = Euclidean(m.atlas.shape)
    n_modes = min(2, c.pca.n_components)
    fig = plt.figure(figsize=(4.2 * len(ks), 3.8 * n_modes))
    rows = np.atleast_1d(fig.subfigures(n_modes, 1))
    for mode, row in enumerate(rows):
        shapes = mode_shapes(space, m.atlas, c.pca, mode, ks)
        cols = np.atleast_1d(row.subfigures(1, len(ks)))
        for k, shape, sub in zip(ks, shapes, cols):
            move = np.linalg.norm(shape - m.atlas, axis=1)
            map_pair(sub, shape, m.faces, move, "viridis", (0.0, float(move.max()) or 1.0),
                     f"mode {mode + 1} "
                     f"({100 * c.pca.explained_variance_ratio[mode]:.0f} %), {k:+g} sd", _VIEWS)  # fmt: skip
    fig.suptitle(f"PCA modes of the transported motion, {m.label} ({m.name}); colour: mm", y=1.02)
    return _save(fig, path)


def plot_transport_scores(scores: list[TransportScore], path: Path) -> Path:
    """Power, Dice, AUC and the null FWER of every transport against ``alpha^2``."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4, figsize=(17, 4))
    by_method: dict[str, list[TransportScore]] = {}
    for s in scores:
        by_method.setdefault(
            f"{s.deformation}: {s.label}" if s.method != "none" else s.label, []
        ).append(s)
    alphas = sorted({s.alpha2 for s in scores if s.alpha2 is not None}) or [1.0]
    for name, rows in by_method.items():
        if rows[0].alpha2 is None:  # no transport: a horizontal line
            xs, style = [alphas[0], alphas[-1]], "k--"
            rows = rows * 2
        else:
            rows = sorted(rows, key=lambda s: s.alpha2)
            xs, style = [s.alpha2 for s in rows], "o-"
        for ax, field in zip(axes, ("power", "dice", "auc", "fwer")):
            ys = [getattr(s, field) for s in rows]
            if any(y is None for y in ys):
                continue
            ax.plot(xs, ys, style, label=name)
    for ax, title in zip(axes, ("detection power", "Dice with the planted region", "AUC",
                                 "FWER under the null")):  # fmt: skip
        ax.set_xscale("log")
        ax.set_xlabel("α²")
        ax.set_title(title)
        ax.grid(True, alpha=0.3)
    axes[3].axhline(0.05, color="grey", lw=0.8)
    axes[0].legend(fontsize=7)
    fig.suptitle("Which transport finds the planted effect")
    return _save(fig, path)


def write_analysis(
    folder,
    comparisons: list[GroupComparison],
    main: GroupComparison,
    alpha: float = 0.05,
    weight=None,
    scores: list[TransportScore] | None = None,
    truth: str | None = None,
    header: str = "",
    figures: bool = True,
) -> dict:
    """Write every output of the analysis into ``folder``; returns ``{name: path}``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = {}
    for name, text in (
        ("vertices.csv", vertices_csv(comparisons, weight, alpha)),
        ("tests.csv", tests_csv(comparisons, alpha)),
        ("summary.md", summary_markdown(comparisons, alpha, scores, truth, header)),
    ):
        atomic_write_text(folder / name, text)
        paths[name] = folder / name
    if scores:
        atomic_write_text(folder / "scores.csv", scores_csv(scores))
        paths["scores.csv"] = folder / "scores.csv"
    write_maps(comparisons, folder / "maps", weight, alpha)
    paths["maps"] = folder / "maps"
    if figures:
        paths["fig_group_means.png"] = plot_group_means(main, folder / "fig_group_means.png")
        paths["fig_pvalue_map.png"] = plot_pvalue_map(
            main, folder / "fig_pvalue_map.png", weight, alpha
        )
        paths["fig_pca_modes.png"] = plot_pca_modes(main, folder / "fig_pca_modes.png")
        if scores:
            paths["fig_transport_scores.png"] = plot_transport_scores(
                scores, folder / "fig_transport_scores.png"
            )
    return paths
