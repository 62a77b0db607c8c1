"""The AHA bull's-eye plot: 17 per-segment values on four concentric rings.

The standard polar map of the left ventricle (Cerqueira et al., Circulation
2002): the apex (segment 17) in the centre, then the apical (13-16), mid
(7-12) and basal (1-6) rings outwards. The anterior wall is at the top, the
septum on the left, the inferior wall at the bottom and the lateral wall on the
right, so that segments 1 to 6 (and 7 to 12) follow each other
counter-clockwise from the top: 1 anterior, 2 anteroseptal (upper left),
3 inferoseptal (lower left), 4 inferior, 5 inferolateral (lower right) and
6 anterolateral (upper right); 13 anterior, 14 septal, 15 inferior and
16 lateral. The sector angles are those of
:data:`ladders.study.cohort.aha_segments.AHA_SEGMENTS` (degrees counter-clockwise
from the right), which is also the view from the base of
:func:`ladders.study.population.aha_segments`.

The figures are built on :class:`matplotlib.figure.Figure` without pyplot, so
that they draw with any backend (Agg included) and never open a window.
"""

from __future__ import annotations

import numpy as np

from ..cohort.aha_segments import AHA_SEGMENTS

__all__ = ["RING_RADII", "bullseye_plot", "bullseye_figure"]

#: Inner and outer radius of each ring of the plot.
RING_RADII = {"apex": (0.0, 0.25), "apical": (0.25, 0.5), "mid": (0.5, 0.75), "basal": (0.75, 1.0)}


def _limits(values: np.ndarray, vmin, vmax) -> tuple[float, float]:
    finite = values[np.isfinite(values)]
    if vmin is not None and vmax is not None:
        return float(vmin), float(vmax)
    if finite.size == 0:
        low, high = 0.0, 1.0
    elif finite.min() < 0 < finite.max():
        high = float(np.abs(finite).max())
        low = -high
    else:
        low, high = float(finite.min()), float(finite.max())
    if low == high:
        low, high = low - 0.5, high + 0.5
    return (low if vmin is None else float(vmin)), (high if vmax is None else float(vmax))


def _new_axes(figsize):
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    return fig, fig.add_subplot(1, 1, 1)


def bullseye_plot(
    values,
    ax=None,
    title: str | None = None,
    cmap="RdBu_r",
    p_values=None,
    alpha: float = 0.05,
    label: str | None = None,
    vmin: float | None = None,
    vmax: float | None = None,
):
    """Draw 17 per-segment values as an AHA bull's-eye (see the module).

    Parameters
    ----------
    values : array, shape (17,)
        Value of segment ``j + 1`` at index ``j``; a NaN segment is drawn grey.
    ax : matplotlib Axes, optional
        Where to draw (a new figure of its own by default).
    title : str, optional
    cmap : str or Colormap, default "RdBu_r"
    p_values : array, shape (17,), optional
        The segments with ``p < alpha`` are outlined in black and hatched.
    alpha : float, default 0.05
    label : str, optional
        The colour bar's label.
    vmin, vmax : float, optional
        Colour limits; by default symmetric about 0 when the values have both
        signs, otherwise their range.

    Returns
    -------
    matplotlib.figure.Figure
        The figure holding the plot; its axes carry one
        :class:`matplotlib.patches.Wedge` per segment, in segment order.
    """
    import matplotlib as mpl
    from matplotlib.patches import Wedge

    v = np.asarray(values, dtype=float)
    if v.shape != (17,):
        raise ValueError(f"values: expected 17 per-segment values, got shape {v.shape}")
    marked = np.zeros(17, dtype=bool)
    if p_values is not None:
        p = np.asarray(p_values, dtype=float)
        if p.shape != (17,):
            raise ValueError(f"p_values: expected 17 per-segment p-values, got shape {p.shape}")
        marked = p < alpha
    if ax is None:
        fig, ax = _new_axes((5.2, 4.4))
    else:
        fig = ax.figure
    low, high = _limits(v, vmin, vmax)
    norm = mpl.colors.Normalize(low, high)
    colormap = mpl.colormaps[cmap] if isinstance(cmap, str) else cmap
    for number in range(1, 18):
        ring, _, centre, width = AHA_SEGMENTS[number]
        inner, outer = RING_RADII[ring]
        value = v[number - 1]
        face = colormap(norm(value)) if np.isfinite(value) else (0.8, 0.8, 0.8, 1.0)
        edge = {"edgecolor": "black", "linewidth": 2.5, "hatch": "//"} if marked[number - 1] else {
            "edgecolor": "white", "linewidth": 1.0}  # fmt: skip
        wedge = Wedge(
            (0.0, 0.0), outer, centre - 0.5 * width, centre + 0.5 * width,
            width=outer - inner, facecolor=face, zorder=2 if marked[number - 1] else 1, **edge,
        )  # fmt: skip
        wedge.set_gid(f"segment {number}")
        ax.add_patch(wedge)
        radius = 0.0 if ring == "apex" else 0.5 * (inner + outer)
        angle = np.radians(centre)
        dark = float(np.dot(mpl.colors.to_rgb(face), (0.299, 0.587, 0.114))) < 0.5
        ink = "white" if dark else "black"
        ax.text(radius * np.cos(angle), radius * np.sin(angle), str(number), ha="center",
                va="center", fontsize=9, fontweight="bold", color=ink, zorder=3,
                bbox={"boxstyle": "round,pad=0.15", "facecolor": face, "edgecolor": "none"})  # fmt: skip
    for text, (x, y, ha) in {
        "anterior": (0.0, 1.06, "center"), "septal": (-1.06, 0.0, "right"),
        "inferior": (0.0, -1.12, "center"), "lateral": (1.06, 0.0, "left"),
    }.items():  # fmt: skip
        ax.text(x, y, text, ha=ha, va="center", fontsize=8, color="0.3")
    ax.set_xlim(-1.35, 1.35)
    ax.set_ylim(-1.2, 1.2)
    ax.set_aspect("equal")
    ax.set_axis_off()
    mappable = mpl.cm.ScalarMappable(norm=norm, cmap=colormap)
    fig.colorbar(mappable, ax=ax, label=label, shrink=0.8)
    if title:
        ax.set_title(title, fontsize=10)
    return fig


def bullseye_figure(table, quantity: str = "", alpha: float = 0.05):
    """Two bull's-eyes of a segment table: the group difference and ``-log10 p_fwer``.

    Parameters
    ----------
    table : SegmentTable
        From :func:`ladders.study.population.segment_table`.
    quantity : str
        What was compared (e.g. ``"area strain"``), for the titles.
    alpha : float, default 0.05
        Segments with ``p_fwer < alpha`` are outlined in both panels.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    g0, g1 = table.groups
    fig = Figure(figsize=(10.5, 4.6))
    left, right = fig.subplots(1, 2)
    what = f"{quantity}: " if quantity else ""
    bullseye_plot(
        table.difference, ax=left, p_values=table.p_fwer, alpha=alpha,
        title=f"{what}{g0} − {g1}", label="difference of the segment means",
    )  # fmt: skip
    logp = -np.log10(np.asarray(table.p_fwer, dtype=float))
    bullseye_plot(
        logp, ax=right, cmap="viridis", p_values=table.p_fwer, alpha=alpha, vmin=0.0,
        vmax=max(float(logp.max()), -np.log10(alpha)), label="−log10 p_fwer",
        title=f"{what}−log10 p, FWER over 17 segments\noutlined: p < {alpha:g}",
    )  # fmt: skip
    return fig
