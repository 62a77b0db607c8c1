"""The effect of a cycle test drawn as curves: each group's mean curve over the found vertices.

:func:`contrast_curves` gives, for the vertices a test found, the mean curve through
the cycle of each level of the variable a contrast is about, adjusted for the model's
other covariates: the model is fitted to every subject's curve (averaged over those
vertices) and each level's curve is the model's prediction for every subject with its
variable set to that level, averaged over the subjects (the other covariates as they
are). For the model ``group`` these are the groups' own mean curves. A continuous
variable is drawn at its mean minus and plus one standard deviation. The band around
each curve is plus and minus one residual standard deviation of the fit.

:func:`plot_curves` draws them (``cycle_curves.png`` for the peak's vertices,
``cycle_trajectory.png`` for the trajectory's).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd

from ...statistics import Design
from ..files import atomic_path

__all__ = ["contrast_curves", "contrast_variable", "plot_curves"]


def contrast_variable(design: Design, contrast: str) -> str | None:
    """The design's variable a contrast is about: the first factor it names, else the
    first continuous column it names, else None."""
    text = str(contrast)
    for factor in design.factors:
        if re.search(rf"(^|[^\w]){re.escape(factor)}($|[^\w])", text):
            return factor
    for column in design.columns:
        if column != "Intercept" and "[" not in column and ":" not in column and (
            re.search(rf"(^|[^\w]){re.escape(column)}($|[^\w])", text)
        ):  # fmt: skip
            return column
    return None


def _frame(table: dict, design: Design) -> pd.DataFrame:
    """The design's variables on its subjects, coded as the design coded them."""
    rows = {str(s).strip(): i for i, s in enumerate(table["subject"])}
    index = [rows[s] for s in design.subjects]
    names = design.model_spec.required_variables if design.model_spec is not None else ()
    data = {}
    for name in names:
        values = [table[name][i] for i in index]
        if name in design.factors:
            labels = [str(v).strip() for v in values]
            data[name] = pd.Categorical(labels, categories=design.factors[name])
        else:
            data[name] = np.array([float(v) for v in values])
    return pd.DataFrame(data)


def contrast_curves(curves, design: Design, contrast: str, table: dict | None = None,
                    labels=None, names=("group1", "group2")) -> list[tuple]:  # fmt: skip
    """Each level's mean curve, adjusted for the other covariates (see the module).

    Parameters
    ----------
    curves : array, shape (n, n_frames)
        Every subject's curve (e.g. averaged over the found vertices), the design's rows.
    design : Design
    contrast : str
    table : dict, optional
        The design table (its variables re-coded at each level); without it, or without
        a variable in the contrast, the groups of ``labels`` or all subjects together.
    labels : array of bool, optional
        Two groups (True first), drawn with ``names`` when ``table`` is not given.
    names : (str, str)

    Returns
    -------
    list of (label, mean curve (n_frames,), band (n_frames,), subjects)
    """
    y = np.asarray(curves, dtype=np.float64)
    variable = contrast_variable(design, contrast) if table is not None else None
    if variable is None:
        if labels is None:
            return [("all subjects", y.mean(axis=0), y.std(axis=0), len(y))]
        labels = np.asarray(labels, dtype=bool)
        return [(name, y[g].mean(axis=0), y[g].std(axis=0), int(g.sum()))
                for name, g in ((names[0], labels), (names[1], ~labels))]  # fmt: skip
    x = design.matrix
    beta, *_ = np.linalg.lstsq(x, y, rcond=None)
    dof = max(x.shape[0] - x.shape[1], 1)
    band = np.sqrt(((y - x @ beta) ** 2).sum(axis=0) / dof)
    frame = _frame(table, design)
    out = []
    if variable in design.factors:
        levels = design.factors[variable]
        counts = frame[variable].value_counts()
        settings = [(level, pd.Categorical([level] * len(frame), categories=levels),
                     int(counts.get(level, 0))) for level in levels]  # fmt: skip
    else:
        mean, sd = frame[variable].mean(), frame[variable].std()
        settings = [(f"{variable} {v:.3g}", np.full(len(frame), v), len(frame))
                    for v in (mean - sd, mean + sd)]  # fmt: skip
    for label, value, count in settings:
        moved = frame.copy()
        moved[variable] = value
        rows = np.asarray(design.model_spec.get_model_matrix(moved), dtype=np.float64)
        out.append((str(label), (rows @ beta).mean(axis=0), band, count))
    return out


def plot_curves(path, fractions, groups: list, title: str, ylabel: str) -> Path:
    """Each group's mean curve through the cycle (closed at ``1``) with its band."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    path = Path(path)
    x = np.append(np.asarray(fractions, dtype=np.float64), 1.0)
    fig, ax = plt.subplots(figsize=(5.5, 3.4))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (label, mean, band, count) in enumerate(groups):
        mean, band = np.append(mean, mean[0]), np.append(band, band[0])
        colour = colours[i % len(colours)]
        ax.plot(x, mean, color=colour, label=f"{label} ({count})")
        ax.fill_between(x, mean - band, mean + band, color=colour, alpha=0.2, lw=0)
    ax.set(xlabel="fraction of the cycle", ylabel=ylabel, title=title)
    ax.legend(frameon=False, fontsize="small")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=90, format="png")
    plt.close(fig)
    return path
