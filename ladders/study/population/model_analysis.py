"""The linear-model analysis of a study's transported motion, as ``symladders analyze --design`` runs it.

:func:`analyze_model` reads a study's output folder and a design table (a
``subject`` column and any covariates), checks them against each other before any
computation, fits the model formula's design (:func:`ladders.statistics.design_matrix`)
and tests each contrast on every motion of the study (:func:`~.model_comparison.compare_model`:
per atlas vertex, optionally with TFCE, and per AHA segment when the atlas's
landmarks are given). It writes, into the analysis folder::

    model_vertices.csv   one row per motion, contrast, test and atlas vertex
    model_segments.csv   one row per motion, contrast, test and AHA segment
    model_summary.md     the counts of detections and the segment tables in words
    maps/model_<motion>_<contrast>.vtu   statistic, p-values, TFCE and segments (ParaView)
    fig_bullseye_<contrast>.png          the main motion's segment effects and p-values
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from manifolds.validation import check_int

from ..errors import CohortError
from ..files import atomic_write_text
from ..meshes.mesh_outputs import write_point_mesh
from ..recommendations import main_motion
from .aha_model import AHA_NAMES, aha_segments
from .analysis import select_motions
from .group_comparison import normalize_motion
from .model_comparison import MODEL_TESTS, ModelComparison, compare_model
from .model_design import model_design
from .model_figures import plot_model_map
from .transported_motion import load_transported_motion

__all__ = ["ModelOutcome", "analyze_model", "main_comparison"]

_KINDS = {"t": "t", "F": "F", "pillai": "Pillai's V"}


@dataclass
class ModelOutcome:
    """What :func:`analyze_model` returns: the comparisons (per motion and contrast), the files."""

    comparisons: list[ModelComparison]
    main: list[ModelComparison]
    paths: dict = field(default_factory=dict)
    left_out: list = field(default_factory=list)


def main_comparison(comparisons: list[ModelComparison]) -> list[ModelComparison]:
    """Per contrast, the main motion (:func:`~ladders.study.recommendations.main_motion`: the
    pole ladder with residuals at the alpha^2 nearest the recommended one, else the first)."""
    return [
        main_motion([c for c in comparisons if c.contrast == name])
        for name in dict.fromkeys(c.contrast for c in comparisons)
    ]


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", text).strip("_") or "contrast"


def _file_stem(c: ModelComparison) -> str:
    return f"model_{c.motion.name.replace('/', '_')}_{_slug(c.contrast)}"


def _effect(c: ModelComparison, test: str, segments: bool = False) -> np.ndarray | None:
    effects = c.segment_effects if segments else c.effects
    value = (effects or {}).get(test)
    if value is None:
        return None
    return np.linalg.norm(value, axis=-1) if value.ndim == 2 else value


def _motion_cells(c: ModelComparison) -> list:
    m = c.motion
    return [m.name, m.deformation, m.method, "" if m.alpha2 is None else f"{m.alpha2:g}"]


def vertices_csv(comparisons: list[ModelComparison], alpha: float = 0.05) -> str:
    """Tidy CSV: one row per motion, contrast, test and vertex (``effect``: the contrast's
    estimate; its length for the displacement)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["motion", "deformation", "method", "alpha2", "contrast", "test", "kind",
                     "vertex", "segment", "effect", "statistic", "p_uncorrected", "p_fwer",
                     "significant", "tfce", "p_fwer_tfce"])  # fmt: skip
    for c in comparisons:
        for test in MODEL_TESTS:
            r = c.tests[test]
            effect = _effect(c, test)
            for v in range(r.statistic.size):
                writer.writerow(_motion_cells(c) + [
                    c.contrast, test, r.kind, v,
                    "" if c.segments is None else int(c.segments[v]),
                    "" if effect is None else f"{effect[v]:.6g}",
                    f"{r.statistic[v]:.6g}", f"{r.p_uncorrected[v]:.6g}", f"{r.p_fwer[v]:.6g}",
                    int(r.p_fwer[v] < alpha),
                    "" if r.enhanced is None else f"{r.enhanced[v]:.6g}",
                    "" if r.p_fwer_enhanced is None else f"{r.p_fwer_enhanced[v]:.6g}",
                ])  # fmt: skip
    return out.getvalue()


def segments_csv(comparisons: list[ModelComparison]) -> str:
    """Tidy CSV: one row per motion, contrast, test and AHA segment."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["motion", "deformation", "method", "alpha2", "contrast", "test", "kind",
                     "segment", "name", "n_vertices", "effect", "statistic", "p_uncorrected",
                     "p_fwer"])  # fmt: skip
    for c in comparisons:
        if c.segment_tests is None:
            continue
        counts = np.bincount(c.segments, minlength=18)[1:]
        for test in MODEL_TESTS:
            r = c.segment_tests[test]
            effect = _effect(c, test, segments=True)
            for s in range(17):
                writer.writerow(_motion_cells(c) + [
                    c.contrast, test, r.kind, s + 1, AHA_NAMES[s + 1], int(counts[s]),
                    "" if effect is None else f"{effect[s]:.6g}",
                    f"{r.statistic[s]:.6g}", f"{r.p_uncorrected[s]:.6g}", f"{r.p_fwer[s]:.6g}",
                ])  # fmt: skip
    return out.getvalue()


def segment_markdown(c: ModelComparison, test: str, alpha: float = 0.05) -> str:
    """The 17-segment table of one test of one comparison, in Markdown."""
    r = c.segment_tests[test]
    effect = _effect(c, test, segments=True)
    lines = [f"| segment | effect | {_KINDS.get(r.kind, r.kind)} | p | p (FWER, 17 segments) |",
             "|---|---|---|---|---|"]  # fmt: skip
    for s in range(17):
        star = " **" if r.p_fwer[s] < alpha else ""
        lines.append(
            f"| {s + 1} {AHA_NAMES[s + 1]} | {'-' if effect is None else f'{effect[s]:.3g}'} | "
            f"{r.statistic[s]:.3g} | {r.p_uncorrected[s]:.2g} | {r.p_fwer[s]:.2g}{star} |"
        )
    return "\n".join(lines) + "\n"


def summary_markdown(comparisons, main, alpha, header, formula) -> str:
    """The analysis in words: per motion and contrast the detections of every test."""
    tfce = comparisons[0].tests["normal"].enhanced is not None
    lines = ["# Linear-model analysis of the transported motion", "", header, "",
             f"Model `{formula}`; family-wise error {alpha:g} over the atlas vertices "
             "(maximum statistic over Freedman-Lane permutations)"
             + ("; TFCE (H = 2, E = 1) on the atlas's triangle adjacency." if tfce else "."),
             "", "| motion | contrast | test | statistic | vertices detected"
             + (" | with TFCE |" if tfce else " |"),
             "|---|---|---|---|---|" + ("---|" if tfce else "")]  # fmt: skip
    k = comparisons[0].motion.atlas.shape[0]
    for c in comparisons:
        for test in MODEL_TESTS:
            r = c.tests[test]
            row = (f"| {c.motion.label} | `{c.contrast}` | {test} | {_KINDS.get(r.kind, r.kind)} "
                   f"| {int(r.significant(alpha).sum())} of {k} |")  # fmt: skip
            if tfce:
                row += f" {int(r.significant(alpha, enhanced=True).sum())} |"
            lines.append(row)
    for c in main:
        if c.segment_tests is None:
            continue
        for test in ("wall_motion", "normal", "strain"):
            lines += ["", f"## AHA segments: {test.replace('_', ' ')}, `{c.contrast}`, "
                      f"{c.motion.label}", "", segment_markdown(c, test, alpha)]  # fmt: skip
    return "\n".join(lines) + "\n"


def write_model_maps(comparisons, folder: Path, alpha: float = 0.05) -> list:
    """One ``.vtu`` of the atlas per motion and contrast with every test's maps."""
    paths = []
    for c in comparisons:
        data = {}
        if c.segments is not None:
            data["aha_segment"] = c.segments.astype(float)
        for test in MODEL_TESTS:
            r = c.tests[test]
            data[f"{test}_statistic"] = r.statistic
            data[f"{test}_p_fwer"] = r.p_fwer
            data[f"{test}_significant"] = (r.p_fwer < alpha).astype(float)
            if r.enhanced is not None:
                data[f"{test}_tfce"] = r.enhanced
                data[f"{test}_tfce_p_fwer"] = r.p_fwer_enhanced
            if test in c.effects:
                data[f"{test}_effect"] = c.effects[test]
        m = c.motion
        paths.append(write_point_mesh(folder / f"{_file_stem(c)}.vtu", m.atlas, m.faces, data))
    return paths


def _bullseyes(c: ModelComparison, path: Path, alpha: float) -> Path:
    from matplotlib.figure import Figure

    from ..reporting.bullseye import bullseye_plot

    fig = Figure(figsize=(14.0, 4.6))
    for ax, test in zip(fig.subplots(1, 3), ("wall_motion", "normal", "strain")):
        effect = _effect(c, test, segments=True)
        r = c.segment_tests[test]
        values = r.statistic if effect is None else effect
        bullseye_plot(values, ax=ax, p_values=r.p_fwer, alpha=alpha,
                      title=f"{test.replace('_', ' ')}: {c.contrast}",
                      label="effect" if effect is not None else r.kind)  # fmt: skip
    fig.savefig(path, dpi=110, bbox_inches="tight")
    return path


def analyze_model(
    study_output,
    table: dict,
    formula: str,
    contrasts: list,
    output=None,
    *,
    alpha2=None,
    methods=None,
    n_permutations: int = 10000,
    tfce: bool = False,
    aha_landmarks=None,
    blocks: str | None = None,
    normalize: str | None = None,
    alpha: float = 0.05,
    seed: int = 0,
    progress: bool = True,
    figures: bool = True,
    fwhm: float | None = None,
    source=None,
) -> ModelOutcome:
    """Test the contrasts of a linear model on a study's transported motion; write the analysis.

    Parameters
    ----------
    study_output : path
        A folder written by ``symladders study``.
    table : dict of str to list
        The design table (:func:`ladders.statistics.read_design`): a ``subject`` column
        and the covariates. Subjects of the study not in it are left out (listed);
        subjects in it but not in the study raise.
    formula : str
        The model, e.g. ``"group + age + sex"``.
    contrasts : list of str
        E.g. ``["group[patients] - group[controls]", "age"]``.
    output : path, optional
        Default ``study_output/analysis``.
    alpha2, methods : optional
        Restrict the motions (:func:`~.analysis.select_motions`).
    n_permutations : int
    tfce : bool
        Also TFCE maps with their family-wise p-values.
    aha_landmarks : Landmarks, optional
        The atlas's apex, base-plane centre and septal point: the AHA segment tables.
    blocks : str, optional
        A column of the table: exchangeability blocks (e.g. ``"site"``).
    normalize : {None, "volume"}
    alpha : float
    seed : int
    progress, figures : bool
    fwhm : float, optional
        Smooth every subject's maps on the atlas before the tests (mm, full width at
        half maximum; :func:`~.model_comparison.compare_model`).
    source : path, optional
        The design table's file, named in the errors.

    Returns
    -------
    ModelOutcome
    """
    n_permutations = check_int(n_permutations, "n_permutations", minimum=1)
    motions = select_motions(load_transported_motion(study_output), alpha2, methods)
    model = model_design(table, formula, contrasts, motions[0].subjects, blocks, source)
    design, block_labels, kept, left_out = model.design, model.blocks, model.kept, model.left_out
    motions = [m.subset(kept) for m in motions]
    if normalize == "volume":
        motions = [normalize_motion(m)[0] for m in motions]
    elif normalize is not None:
        raise CohortError(f"normalize: expected None or 'volume', got {normalize!r}")
    segments = None
    if aha_landmarks is not None:
        lm = aha_landmarks
        segments = aha_segments(motions[0].atlas, lm.apex, lm.base, lm.septum)
    rng = np.random.default_rng(seed)
    comparisons = [
        compare_model(
            m,
            design,
            spec,
            n_permutations,
            rng,
            tfce=tfce,
            segments=segments,
            blocks=block_labels,
            progress=progress,
            fwhm=fwhm,
        )  # fmt: skip
        for spec in contrasts
        for m in motions
    ]
    main = main_comparison(comparisons)
    folder = Path(output) if output is not None else Path(study_output) / "analysis"
    folder.mkdir(parents=True, exist_ok=True)
    header = f"Study: {Path(study_output).resolve()}; {len(kept)} subjects; seed {seed}."
    if fwhm is not None:
        header += f" Maps smoothed on the atlas, {fwhm:g} mm FWHM."
    if left_out:
        header += f" Left out (not in the design table): {', '.join(left_out)}."
    paths = {}
    texts = [
        ("model_vertices.csv", vertices_csv(comparisons, alpha)),
        ("model_summary.md", summary_markdown(comparisons, main, alpha, header, formula)),
    ]
    if segments is not None:
        texts.append(("model_segments.csv", segments_csv(comparisons)))
    for name, text in texts:
        atomic_write_text(folder / name, text)
        paths[name] = folder / name
    write_model_maps(comparisons, folder / "maps", alpha)
    paths["maps"] = folder / "maps"
    if figures:
        for c in main:
            name = f"fig_model_map_{_slug(c.contrast)}.png"
            paths[name] = plot_model_map(c, folder / name, alpha)
            if segments is not None:
                name = f"fig_bullseye_{_slug(c.contrast)}.png"
                paths[name] = _bullseyes(c, folder / name, alpha)
    return ModelOutcome(comparisons, main, paths, left_out)
