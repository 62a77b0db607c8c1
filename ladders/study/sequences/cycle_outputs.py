"""Files of a cycle analysis: per-vertex, per-frame and per-segment tables, maps, curves, summary.

Written by :func:`write_cycle_tests` into one folder, for every contrast tested:

* ``cycle_vertices.csv``: one row per contrast and vertex: for the peak (``peak_``) and
  the time to peak (``time_``) the contrast's estimate (``effect``, a one-row contrast;
  for two groups also each group's mean, ``peak_group1_mm`` or, with the rotation,
  ``peak_group1_deg``, or a wall measure's, in mm or percent), the statistic (``t`` or ``F``) and its FWER p; for the frames
  the largest ``|t|`` or ``F`` and the smallest FWER p over the frames; for the
  trajectory Pillai's trace and its FWER p; with TFCE, each summary's enhanced map
  (``peak_tfce``, ...) and its FWER p (``peak_tfce_p_fwer``, ...); when only some vertices
  were tested, a ``tested`` column (1 or 0) and ``nan`` elsewhere;
* ``cycle_frames.csv``: per contrast and frame, its fraction of the cycle, the
  vertices found at that frame (FWER over vertices and frames together) and the
  largest statistic;
* ``cycle_segments.csv`` (with AHA segments): per contrast, summary and segment, the
  statistic and FWER p over the segments (for the frames, the frame of the smallest p);
* ``cycle_tests.vtu`` (``cycle_tests_<contrast>.vtu`` with several contrasts): the
  atlas with the per-vertex columns as point data;
* ``cycle_curves.png`` and ``cycle_trajectory.png`` (suffixed likewise): the mean curve
  through the cycle of each level of the contrast's variable
  (:func:`~.cycle_figures.contrast_curves`) over the vertices whose peak, or
  trajectory, differs (every vertex tested when none does);
* ``cycle_summary.md``: the counts of every test in words, and the segment tables.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..files import atomic_write_text, csv_text
from ..meshes.mesh_outputs import write_point_mesh
from ..population.aha_model import AHA_NAMES
from .cycle_analysis import CycleMotion
from .cycle_figures import contrast_curves, plot_curves
from .cycle_model import CycleTests

__all__ = ["write_cycle_tests", "vertex_columns"]

_KINDS = {"t": "t", "F": "F", "pillai": "Pillai's V"}
_PREFIX = {"per_frame": "frames", "peak": "peak", "time_to_peak": "time",
           "trajectory": "trajectory"}  # fmt: skip
#: The figures' axis label of every measure.
_AXIS_LABELS = {
    "normal": "normal motion (mm, inward < 0)",
    "rotation": "rotation (deg, counter-clockwise from the apex > 0)",
    "thickness": "wall thickness (mm)",
    "thickening": "wall thickening from ED (mm)",
    "radial": "radial strain (%)",
    "circumferential": "circumferential strain (%)",
    "longitudinal": "longitudinal strain (%)",
}
_NAMES = {"per_frame": "per frame", "peak": "peak", "time_to_peak": "time to peak",
          "trajectory": "trajectory"}  # fmt: skip


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", text).strip("_") or "contrast"


def vertex_columns(tests: CycleTests) -> dict[str, np.ndarray]:
    """The per-vertex columns of one contrast (see the module), ``{name: (k,)}``."""
    columns = {}
    if tests.labels is not None:
        a, b = tests.labels, ~tests.labels
        columns[f"peak_group1_{tests.unit}"] = tests.peaks[a].mean(axis=0)
        columns[f"peak_group2_{tests.unit}"] = tests.peaks[b].mean(axis=0)
        columns["time_group1"] = tests.times[a].mean(axis=0)
        columns["time_group2"] = tests.times[b].mean(axis=0)
    for summary, r in tests.tests().items():
        p = _PREFIX[summary]
        if summary == "per_frame":
            columns["frames_max_abs_statistic"] = np.max(np.abs(r.statistic), axis=0)
            columns["frames_min_p_fwer"] = r.p_fwer.min(axis=0)
            if r.p_fwer_enhanced is not None:
                columns["frames_min_tfce_p_fwer"] = r.p_fwer_enhanced.min(axis=0)
            continue
        if summary != "trajectory" and r.effect is not None and r.effect.shape[0] == 1:
            unit = f"_{tests.unit}" if summary == "peak" else ""
            columns[f"{p}_effect{unit}"] = r.effect[0]
        columns[f"{p}_statistic"] = r.statistic
        columns[f"{p}_p_fwer"] = r.p_fwer
        if r.enhanced is not None:
            columns[f"{p}_tfce"] = r.enhanced
            columns[f"{p}_tfce_p_fwer"] = r.p_fwer_enhanced
    if tests.tested is not None and not tests.tested.all():
        columns["tested"] = tests.tested.astype(float)
    if tests.segments is not None:
        columns["aha_segment"] = tests.segments.astype(float)
    return columns


def _vertices_csv(all_tests: list, k: int) -> str:
    """Every contrast's columns; a column one contrast lacks (an F test's effect) is empty."""
    per_contrast = [vertex_columns(tests) for tests in all_tests]
    names = list(dict.fromkeys(c for columns in per_contrast for c in columns))
    rows = []
    for tests, columns in zip(all_tests, per_contrast):
        cells = [[f"{columns[c][v]:.6g}" if c in columns else "" for c in names] for v in range(k)]
        rows += [[tests.contrast, v, *cells[v]] for v in range(k)]
    return csv_text(["contrast", "vertex", *names], rows)


def _frames_csv(all_tests: list, fractions, alpha: float) -> str:
    header = ["contrast", "frame", "fraction", f"vertices_p_fwer_below_{alpha:g}",
              f"vertices_tfce_p_fwer_below_{alpha:g}", "max_abs_statistic"]  # fmt: skip
    rows = []
    for tests in all_tests:
        pf = tests.per_frame
        if pf is None:
            continue
        for t in range(pf.statistic.shape[0]):
            enhanced = (
                "" if pf.p_fwer_enhanced is None else int((pf.p_fwer_enhanced[t] < alpha).sum())
            )
            rows.append([tests.contrast, t, f"{fractions[t]:.4f}", int((pf.p_fwer[t] < alpha).sum()),
                         enhanced, f"{np.nanmax(np.abs(pf.statistic[t])):.4g}"])  # fmt: skip
    return csv_text(header, rows)


def _segments_csv(all_tests: list) -> str:
    header = ["contrast", "summary", "kind", "segment", "name", "statistic", "p_fwer", "frame"]
    rows = []
    for tests in all_tests:
        for summary, r in (tests.segment_tests or {}).items():
            for s in range(17):
                if summary == "per_frame":
                    p = r.p_fwer[:, s]
                    t = int(np.nanargmin(p)) if np.isfinite(p).any() else 0
                    stat, p_fwer, frame = r.statistic[t, s], p[t], t
                else:
                    stat, p_fwer, frame = r.statistic[s], r.p_fwer[s], ""
                rows.append([tests.contrast, summary, r.kind, s + 1, AHA_NAMES[s + 1],
                             f"{stat:.6g}", f"{p_fwer:.6g}", frame])  # fmt: skip
    return csv_text(header, rows)


def _summary(all_tests: list, header: str, alpha: float) -> str:
    tfce = all_tests[0].tfce
    first = all_tests[0]
    lines = ["# Linear-model analysis of the whole cycle", "", header, "",
             f"Curve per vertex: {_AXIS_LABELS.get(first.measure, first.measure)}"
             f"; {int(first.tested.sum())} of {first.tested.size} atlas vertices tested; the "
             f"trajectory on {first.components} principal component(s) per vertex "
             f"({100 * first.explained:.0f} % of the curves' variance). Family-wise error "
             f"{alpha:g} by the maximum statistic over Freedman-Lane permutations (per frame: "
             "over vertices and frames)"
             + ("; TFCE (H = 2, E = 1) on the atlas's triangles (per frame: and the "
                "neighbouring frames)." if tfce else "."),
             "", "| contrast | summary | statistic | vertices found" + (" | with TFCE |" if tfce
                                                                       else " |"),
             "|---|---|---|---|" + ("---|" if tfce else "")]  # fmt: skip
    for tests in all_tests:
        for summary, r in tests.tests().items():
            row = (f"| `{tests.contrast}` | {_NAMES[summary]} | {_KINDS.get(r.kind, r.kind)} | "
                   f"{int(tests.detected(summary, alpha).sum())} |")  # fmt: skip
            if tfce:
                row += f" {int(tests.detected(summary, alpha, tfce=True).sum())} |"
            lines.append(row)
    for tests in all_tests:
        if not tests.segment_tests:
            continue
        lines += ["", f"## AHA segments, `{tests.contrast}`", "",
                  "| segment | peak | p (FWER) | time to peak | p (FWER) | trajectory | p (FWER) |",
                  "|---|---|---|---|---|---|---|"]  # fmt: skip
        st = tests.segment_tests
        for s in range(17):
            cells = []
            for summary in ("peak", "time_to_peak", "trajectory"):
                r = st.get(summary)
                if r is None:
                    cells += ["-", "-"]
                    continue
                star = " **" if r.p_fwer[s] < alpha else ""
                cells += [f"{r.statistic[s]:.3g}", f"{r.p_fwer[s]:.2g}{star}"]
            lines.append(f"| {s + 1} {AHA_NAMES[s + 1]} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _where(tests: CycleTests, summary: str, alpha: float) -> tuple[np.ndarray, str]:
    found = tests.detected(summary, alpha, tfce=tests.tfce)
    tested = tests.tested if tests.tested is not None else np.ones_like(found)
    if found.any():
        return found, f"{int(found.sum())} vertices whose {_NAMES[summary]} differs"
    return tested, "all vertices tested"


def write_cycle_tests(
    folder,
    motion: CycleMotion,
    tests,
    names=("group1", "group2"),
    alpha: float = 0.05,
    table: dict | None = None,
    header: str = "",
    figures: bool = True,
) -> list[Path]:
    """Write the analysis's files (see the module); return their paths.

    Parameters
    ----------
    folder : path
    motion : CycleMotion
        The subjects of the tests, in their order.
    tests : CycleTests or list of CycleTests
        One per contrast, on the same subjects and vertices.
    names : (str, str)
        Two groups' names (``tests.labels`` True first), in the figures.
    alpha : float, default 0.05
        The FWER level of the counts and of the figures' vertices.
    table : dict, optional
        The design table: the figures' curves adjusted for the other covariates.
    header : str
        A line at the top of ``cycle_summary.md`` (the study, the model).
    figures : bool, default True
        Also the figures.
    """
    all_tests = [tests] if isinstance(tests, CycleTests) else list(tests)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    k = len(motion.atlas)
    paths = []
    texts = [("cycle_vertices.csv", _vertices_csv(all_tests, k)),
             ("cycle_frames.csv", _frames_csv(all_tests, motion.fractions, alpha))]  # fmt: skip
    if all_tests[0].segment_tests:
        texts.append(("cycle_segments.csv", _segments_csv(all_tests)))
    texts.append(("cycle_summary.md", _summary(all_tests, header, alpha)))
    for name, text in texts:
        atomic_write_text(folder / name, text)
        paths.append(folder / name)
    curves = all_tests[0].curves(motion)
    first = all_tests[0]
    ylabel = _AXIS_LABELS.get(first.measure, f"{first.measure} ({first.unit})")
    for tests in all_tests:
        suffix = "" if len(all_tests) == 1 else f"_{_slug(tests.contrast)}"
        columns = vertex_columns(tests)
        paths.append(write_point_mesh(folder / f"cycle_tests{suffix}.vtu", motion.atlas,
                                      motion.faces, columns))  # fmt: skip
        for summary, stem in (("peak", "cycle_curves"), ("trajectory", "cycle_trajectory")):
            if not figures or summary not in tests.tests():
                continue
            where, what = _where(tests, summary, alpha)
            groups = contrast_curves(curves[:, :, where].mean(axis=2), tests.design,
                                     tests.contrast, table, tests.labels, names)  # fmt: skip
            paths.append(plot_curves(folder / f"{stem}{suffix}.png", motion.fractions, groups,
                                     f"mean over {what}", ylabel))  # fmt: skip
    return paths
