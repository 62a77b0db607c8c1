"""Files of a cycle analysis: per-vertex and per-frame tables, maps on the atlas, the curves.

Written by :func:`write_cycle_tests` into one folder:

* ``cycle_vertices.csv``: per vertex, each group's mean peak inward motion (mm;
  ``peak_group1_mm``) or, with the rotation measure, signed peak rotation about the
  long axis (degrees; ``peak_group1_deg``), or a wall measure's peak (mm or percent),
  and time to peak (fraction of the cycle),
  their ``t`` and FWER-corrected p, the
  smallest per-frame p, and with the peak's TFCE test its enhanced map and FWER p
  (``peak_tfce``, ``peak_tfce_p_fwer``); when only some vertices were tested, a
  ``tested`` column (1 or 0) and ``nan`` statistics elsewhere;
* ``cycle_frames.csv``: per frame, its fraction of the cycle, the vertices found at
  FWER 5 % (vertices and frames together) and the largest ``|t|``;
* ``cycle_tests.vtu``: the atlas with those per-vertex columns as point data;
* ``cycle_curves.png``: each group's mean curve (the measure's) through
  the cycle, over the vertices whose peak differs (all vertices tested when none does).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..files import atomic_path, atomic_write_text, csv_text
from ..meshes.mesh_outputs import write_point_mesh
from .cycle_analysis import CycleMotion, CycleTests

__all__ = ["write_cycle_tests"]


def _vertex_columns(tests: CycleTests) -> dict[str, np.ndarray]:
    a, b = tests.labels, ~tests.labels
    columns = {
        f"peak_group1_{tests.unit}": tests.peaks[a].mean(axis=0),
        f"peak_group2_{tests.unit}": tests.peaks[b].mean(axis=0),
        "peak_t": tests.peak.statistic,
        "peak_p_fwer": tests.peak.p_fwer,
        "time_group1": tests.times[a].mean(axis=0),
        "time_group2": tests.times[b].mean(axis=0),
        "time_t": tests.time_to_peak.statistic,
        "time_p_fwer": tests.time_to_peak.p_fwer,
        "frames_min_p_fwer": tests.per_frame.p_fwer.min(axis=0),
    }
    if tests.peak_tfce is not None:
        columns["peak_tfce"] = tests.peak_tfce.enhanced
        columns["peak_tfce_p_fwer"] = tests.peak_tfce.p_fwer_enhanced
    if tests.tested is not None and not tests.tested.all():
        columns["tested"] = tests.tested.astype(float)
    return columns


def write_cycle_tests(folder, motion: CycleMotion, tests: CycleTests, names=("group1", "group2"),
                      alpha: float = 0.05) -> list[Path]:  # fmt: skip
    """Write the analysis's files (see the module); return their paths.

    Parameters
    ----------
    folder : path
    motion : CycleMotion
    tests : CycleTests
    names : (str, str)
        The groups' names (``tests.labels`` True first), used in the plot.
    alpha : float, default 0.05
        The FWER level of the counts and of the plot's vertices.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    columns = _vertex_columns(tests)
    vertices = folder / "cycle_vertices.csv"
    rows = [[v, *(f"{columns[c][v]:.6g}" for c in columns)] for v in range(len(motion.atlas))]
    atomic_write_text(vertices, csv_text(["vertex", *columns], rows))
    frames = folder / "cycle_frames.csv"
    pf = tests.per_frame
    rows = [[t, f"{motion.fractions[t]:.4f}", int((pf.p_fwer[t] < alpha).sum()),
             f"{np.nanmax(np.abs(pf.statistic[t])):.4g}"] for t in range(pf.statistic.shape[0])]  # fmt: skip
    atomic_write_text(frames, csv_text(["frame", "fraction", f"vertices_p_fwer_below_{alpha:g}",
                                    "max_abs_t"], rows))  # fmt: skip
    vtu = write_point_mesh(folder / "cycle_tests.vtu", motion.atlas, motion.faces, columns)
    png = folder / "cycle_curves.png"
    _plot_curves(png, motion, tests, names, alpha)
    return [vertices, frames, vtu, png]


_AXIS_LABELS = {
    "normal": "normal motion (mm, inward < 0)",
    "rotation": "rotation (deg, counter-clockwise from the apex > 0)",
    "thickness": "wall thickness (mm)",
    "thickening": "wall thickening from ED (mm)",
    "radial": "radial strain (%)",
    "circumferential": "circumferential strain (%)",
    "longitudinal": "longitudinal strain (%)",
}


def _plot_curves(path: Path, motion: CycleMotion, tests: CycleTests, names, alpha: float) -> None:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    found = tests.peak.p_fwer < alpha
    tested = np.ones_like(found) if tests.tested is None else tests.tested
    where = found if found.any() else tested
    curves = tests.curves(motion)[:, :, where].mean(axis=2)  # (n_subjects, n_frames)
    x = np.append(motion.fractions, 1.0)
    fig, ax = plt.subplots(figsize=(5.5, 3.4))
    for label, name, colour in ((True, names[0], "tab:red"), (False, names[1], "tab:blue")):
        c = curves[tests.labels == label]
        mean = np.append(c.mean(axis=0), c.mean(axis=0)[0])
        sd = np.append(c.std(axis=0), c.std(axis=0)[0])
        ax.plot(x, mean, color=colour, label=f"{name} ({len(c)})")
        ax.fill_between(x, mean - sd, mean + sd, color=colour, alpha=0.2, lw=0)
    what = (f"{int(found.sum())} vertices whose peak differs" if found.any()
            else "all vertices tested")  # fmt: skip
    ylabel = _AXIS_LABELS.get(tests.measure, f"{tests.measure} ({tests.unit})")
    ax.set(xlabel="fraction of the cycle", ylabel=ylabel, title=f"mean over {what}")
    ax.legend(frameon=False)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=90, format="png")
    plt.close(fig)
