"""The maps of a linear-model contrast on the atlas, as a figure.

:func:`plot_model_map` draws, for one comparison (a contrast on one transported
motion), the contrast's effect on the normal wall motion and the corrected p-values of
the wall-motion test, of its TFCE map when there is one, and of the normal component of
the displacement, each from two views; ``symladders analyze --design`` writes it for the
main comparison of every contrast (``fig_model_map_<contrast>.png``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot_model_map"]

_VIEWS = (-60.0, 120.0)


def plot_model_map(c, path, alpha: float = 0.05) -> Path:
    """Effect and corrected p-values of ``c`` (a :class:`~.model_comparison.ModelComparison`)
    on the atlas, written to ``path``."""
    from matplotlib.figure import Figure

    from ..reporting.figures import map_pair

    m = c.motion
    wall = c.tests["wall_motion"]
    panels = []
    effect = c.effects.get("wall_motion")
    if effect is not None:
        top = float(np.abs(effect).max()) or 1.0
        panels.append(("effect on the normal wall motion (mm)", effect, "RdBu_r", (-top, top),
                       "mm"))  # fmt: skip
    top = max(float(-np.log10(1.0 / (wall.n_permutations + 1))), 2.0)
    panels.append(("normal wall motion: −log10 p (FWER)", -np.log10(wall.p_fwer), "inferno",
                   (0.0, top), "−log10 p"))  # fmt: skip
    if wall.p_fwer_enhanced is not None:
        panels.append(("normal wall motion, TFCE: −log10 p (FWER)",
                       -np.log10(wall.p_fwer_enhanced), "inferno", (0.0, top), "−log10 p"))  # fmt: skip
    normal = c.tests["normal"]
    panels.append(("normal displacement: −log10 p (FWER)", -np.log10(normal.p_fwer), "inferno",
                   (0.0, top), "−log10 p"))  # fmt: skip
    fig = Figure(figsize=(5.2 * len(panels), 3.2))
    subs = fig.subfigures(1, len(panels))
    for sub, (title, values, cmap, lim, label) in zip(np.atleast_1d(subs), panels):
        surf = map_pair(sub, m.atlas, m.faces, values, cmap, lim, title, _VIEWS)
        sub.colorbar(surf, ax=sub.axes, shrink=0.6, label=label)
    fig.suptitle(f"{c.contrast}, {m.label} ({m.name}); significant where −log10 p > "
                 f"{-np.log10(alpha):.2f}", y=1.1)  # fmt: skip
    path = Path(path)
    fig.savefig(path, dpi=90, bbox_inches="tight", pad_inches=0.05)
    return path
