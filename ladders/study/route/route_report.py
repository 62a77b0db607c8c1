"""``report.md``: the entry point to a route's results.

Written by the last step of ``symladders run`` from the files the steps wrote (nothing
is computed again, so a reused step reports as it did):

1. **What was found**: per contrast of the model, on the recommended motion (the pole
   ladder with residuals at the route's alpha^2) and on the motion without transport,
   the atlas vertices whose normal wall motion and normal displacement differ
   (family-wise error over the vertices, and with TFCE), the AHA segments whose
   wall-motion test is significant, the figures (maps and bull's-eyes); with a planted
   truth in the settings (a synthetic cohort), the detection power and Dice of every
   test against it.
2. **The whole cycle**, when subjects were tracked: the cycle analysis's summary (per
   frame, peak, time to peak, trajectory) and figures; with the myocardium's label, the
   wall's thickening likewise and where the wall maps are.
3. **The subjects**: how many reached each step, and every subject left out or flagged,
   with the step and the reason.
4. **The steps**: each command, whether it ran or was reused, its time and log.
5. **The settings** (every key, the given ones marked) and the versions.
"""

from __future__ import annotations

import csv
import json
import os
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

__all__ = ["write_report", "subjects_with_results", "left_out_subjects", "truth_scores"]

#: The tests the report reads first (the normal wall motion, then the normal displacement).
MAIN_TESTS = ("wall_motion", "normal")
_TEST_NAMES = {"wall_motion": "normal wall motion", "normal": "normal displacement",
               "strain": "area strain", "displacement": "displacement (3-D)"}  # fmt: skip
_MAIN_METHOD = "pole_ladder_residual"


def subjects_with_results(folder: Path) -> list[str]:
    """The subjects with results in a study folder (or a cycle study's, or wall maps')."""
    folder = Path(folder)
    if (folder / "cycle_study.csv").is_file() or (folder / "wall.csv").is_file():
        return sorted(p.stem for p in folder.glob("*.npz"))
    from ..population import load_transported_motion

    motions = load_transported_motion(folder)
    return list(motions[0].subjects) if motions else []


def _rows(path: Path) -> list[dict]:
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            return list(csv.DictReader(fh))
    except OSError:
        return []


def _link(root: Path, path: Path) -> str:
    return os.path.relpath(path, root).replace(os.sep, "/")


def _stage_subjects(root: Path, table) -> dict:
    """Per step, the subjects that came out of it."""
    names = table.subjects
    stages = {"table": list(names)}
    meshes = root / "meshes"
    if meshes.is_dir():
        stages["mesh"] = [s for s in names
                          if any(meshes.glob(f"{s}_ed.*")) and any(meshes.glob(f"{s}_es.*"))]  # fmt: skip
    corresponded = root / "corresponded"
    if corresponded.is_dir():
        stages["correspond"] = [s for s in names if any(corresponded.glob(f"{s}_es.*"))]
    study = root / "study"
    if (study / "results").is_dir():
        studied = set(subjects_with_results(study))  # read once, not once per subject
        stages["study"] = [s for s in names if s in studied]
    design = root / "analysis" / "design.csv"
    if design.is_file():
        stages["analysis"] = [r["subject"] for r in _rows(design)]
    tracked = root / "tracked"
    if tracked.is_dir():
        stages["track"] = [s for s in names if (tracked / s / "frame_00.vtk").is_file()
                           or any((tracked / s).glob("frame_00.*"))]  # fmt: skip
    cycle = root / "cycle_study"
    if cycle.is_dir():
        stages["cycle-study"] = [s for s in names if (cycle / f"{s}.npz").is_file()]
    wall = root / "wall"
    if wall.is_dir():
        stages["wall"] = [s for s in names if (wall / f"{s}.npz").is_file()]
    return stages


def _reasons(root: Path) -> dict:
    """``{(subject, step): reason}`` from the steps' own tables."""
    out = {}
    for row in _rows(root / "meshes" / "meshing.csv"):
        if row.get("status") == "failed":
            name = Path(row.get("mesh") or "").stem
            subject = name.rsplit("_", 1)[0] if name.endswith(("_ed", "_es")) else name
            out[(subject, "mesh")] = row.get("error", "")
    for row in _rows(root / "corresponded" / "quality.csv"):
        if row.get("status") == "failed":
            out[(row.get("subject", ""), "correspond")] = row.get("reasons", "")
    for row in _rows(root / "tracked" / "tracking.csv"):
        if row.get("status") == "failed":
            out[(row.get("subject", ""), "track")] = row.get("error", "")
    for row in _rows(root / "cycle_study" / "cycle_study.csv"):
        if row.get("status") == "failed":
            out[(row.get("subject", ""), "cycle-study")] = row.get("error", "")
    return out


def left_out_subjects(root: Path, table, stages: dict | None = None) -> list[tuple[str, str, str]]:
    """``(subject, step, reason)`` of every subject a step did not pass on, and every mesh the
    correspondence flagged for inspection (kept, with its reasons). ``stages``: the subjects
    out of each step, when already read."""
    root = Path(root)
    stages = _stage_subjects(root, table) if stages is None else stages
    reasons = _reasons(root)
    order = ["table", "mesh", "correspond", "study", "analysis"]
    out, gone = [], set()
    for before, after in zip(order, order[1:]):
        if after not in stages:
            continue
        kept = set(stages[after])
        for s in stages[before]:
            if s not in kept and s not in gone:
                gone.add(s)
                reason = reasons.get((s, after), "")
                if after == "analysis" and not reason:
                    reason = "not in the analysis's design (no results)"
                out.append((s, after, reason or "no output (see the step's log)"))
    if "track" in stages:
        tracked = set(stages["track"])
        for e in table.tracked:
            if e.subject not in tracked and e.subject not in gone:
                out.append((e.subject, "track", reasons.get((e.subject, "track"), "not tracked")))
    for row in _rows(root / "corresponded" / "quality.csv"):
        if row.get("status") == "ok" and row.get("flagged") == "True":
            out.append((row["subject"], f"correspond ({row.get('phase', '')}, flagged, kept)",
                        row.get("reasons", "")))  # fmt: skip
    return out


def truth_scores(vertices_csv: Path, truth: Path, alpha: float) -> list[dict]:
    """Power and Dice of every test against a planted truth's AHA segments.

    The planted region is given by its segments (``planted_region.json``); on the
    route's atlas it is the set of vertices of those segments (``model_vertices.csv``'s
    ``segment`` column, from the atlas's landmarks). Power: the fraction of the region's
    vertices found; Dice: ``2 |found and region| / (|found| + |region|)``.
    """
    record = json.loads(Path(truth).read_text(encoding="utf-8"))
    region = record.get("region") or {}
    segments = set((region.get("abnormality") or {}).get("segments", ()))
    if not segments:
        return []
    groups = defaultdict(lambda: {"truth": [], "found": [], "found_tfce": []})
    for row in _rows(vertices_csv):
        if not row.get("segment"):
            return []
        key = (row["contrast"], row["method"], row["alpha2"], row["test"])
        groups[key]["truth"].append(int(row["segment"]) in segments)
        groups[key]["found"].append(float(row["p_fwer"]) < alpha)
        if row.get("p_fwer_tfce"):
            groups[key]["found_tfce"].append(float(row["p_fwer_tfce"]) < alpha)
    out = []
    for (contrast, method, alpha2, test), g in groups.items():
        truth_mask = np.array(g["truth"])
        for label, found in (("", g["found"]), (" (TFCE)", g["found_tfce"])):
            if not found:
                continue
            found = np.array(found)
            hit = int((found & truth_mask).sum())
            power = hit / max(int(truth_mask.sum()), 1)
            dice = 2 * hit / max(int(found.sum() + truth_mask.sum()), 1)
            out.append({"contrast": contrast, "method": method, "alpha2": alpha2,
                        "test": test + label, "power": power, "dice": dice,
                        "n_region": int(truth_mask.sum()), "n_found": int(found.sum())})  # fmt: skip
    return out


def _method_label(method: str, alpha2: str) -> str:
    if method == "none":
        return "no transport"
    name = {"pole_ladder_residual": "pole ladder with residuals",
            "pole_ladder": "pole ladder", "fanning": "fanning"}.get(method, method)  # fmt: skip
    return f"{name}, alpha^2 = {alpha2}"


def _found(root: Path, settings) -> list[str]:
    analysis = root / "analysis"
    rows = _rows(analysis / "model_vertices.csv")
    if not rows:
        return ["No analysis: the table has no group or covariate to test."]
    alpha = settings["model"]["alpha"]
    counts = defaultdict(lambda: [0, 0, 0, False])
    for row in rows:
        key = (row["contrast"], row["method"], row["alpha2"], row["test"])
        c = counts[key]
        c[0] += 1
        c[1] += float(row["p_fwer"]) < alpha
        if row.get("p_fwer_tfce"):
            c[2] += float(row["p_fwer_tfce"]) < alpha
            c[3] = True
    lines = [f"Family-wise error {alpha:g} over the atlas vertices (maximum statistic over "
             "Freedman-Lane permutations; TFCE on the atlas's mesh where it says so). Read "
             "the normal wall motion first: it is what a pair of surfaces shows.", "",
             "| contrast | motion | test | vertices found | with TFCE |", "|---|---|---|---:|---:|"]  # fmt: skip
    order = sorted(counts, key=lambda k: (k[0], k[1] != _MAIN_METHOD, k[1],
                                          MAIN_TESTS.index(k[3]) if k[3] in MAIN_TESTS else 9))  # fmt: skip
    for key in order:
        contrast, method, alpha2, test = key
        if test not in MAIN_TESTS:
            continue
        n, found, tfce, has = counts[key]
        lines.append(f"| `{contrast}` | {_method_label(method, alpha2)} | {_TEST_NAMES[test]} | "
                     f"{found} of {n} | {tfce if has else '–'} |")  # fmt: skip
    segments = [r for r in _rows(analysis / "model_segments.csv")
                if r["method"] == _MAIN_METHOD and r["test"] == "wall_motion"]  # fmt: skip
    if segments:
        lines += ["", "AHA segments whose mean normal wall motion differs (pole ladder with "
                  "residuals; family-wise error over the 17 segments):", ""]  # fmt: skip
        by_contrast = defaultdict(list)
        for r in segments:
            if float(r["p_fwer"]) < alpha:
                by_contrast[r["contrast"]].append(
                    f"{r['segment']} {r['name']} (effect {float(r['effect']):+.2f} mm, "
                    f"p = {float(r['p_fwer']):.2g})" if r["effect"] else f"{r['segment']} {r['name']}"
                )  # fmt: skip
        for contrast in dict.fromkeys(r["contrast"] for r in segments):
            found = by_contrast.get(contrast)
            lines.append(f"- `{contrast}`: " + ("; ".join(found) if found else "none"))
    truth = settings["model"]["truth"]
    if truth is not None:
        scores = [s for s in truth_scores(analysis / "model_vertices.csv", truth, alpha)
                  if s["test"].split(" ")[0] in MAIN_TESTS]  # fmt: skip
        if scores:
            lines += ["", f"Against the planted truth (`{truth.name}`: the vertices of its AHA "
                      "segments on this atlas):", "",
                      "| contrast | motion | test | power | Dice | region / found |",
                      "|---|---|---|---:|---:|---:|"]  # fmt: skip
            for s in scores:
                lines.append(f"| `{s['contrast']}` | {_method_label(s['method'], s['alpha2'])} "
                             f"| {_TEST_NAMES[s['test'].split(' ')[0]]}"
                             f"{' (TFCE)' if 'TFCE' in s['test'] else ''} | {s['power']:.2f} | "
                             f"{s['dice']:.2f} | {s['n_region']} / {s['n_found']} |")  # fmt: skip
    for fig in sorted(analysis.glob("fig_*.png")):
        lines += ["", f"![{fig.stem}]({_link(root, fig)})"]
    lines += ["", f"Every vertex's statistic and p-values: `{_link(root, analysis / 'model_vertices.csv')}`; "
              f"the maps for ParaView: `{_link(root, analysis / 'maps')}/`; the analysis's own "
              f"summary: `{_link(root, analysis / 'model_summary.md')}`."]  # fmt: skip
    return lines


def _summary_section(root: Path, folder: Path, title: str) -> list[str]:
    """A cycle analysis's own summary (``cycle_summary.md``, its title dropped) and figures."""
    if not folder.is_dir():
        return []
    lines = ["", f"## {title}", ""]
    summary = folder / "cycle_summary.md"
    if summary.is_file():
        text = summary.read_text(encoding="utf-8").splitlines()
        body = text[1:] if text and text[0].startswith("# ") else text
        lines += [line.replace("## ", "### ", 1) if line.startswith("## ") else line
                  for line in body]  # fmt: skip
    for fig in sorted(folder.glob("*.png")):
        lines += ["", f"![{fig.stem}]({_link(root, fig)})"]
    lines += ["", f"Tables and maps: `{_link(root, folder)}/`."]
    return lines


def _cycle(root: Path) -> list[str]:
    lines = _summary_section(root, root / "cycle_analysis", "The whole cycle")
    wall = root / "wall"
    lines += _summary_section(root, root / "wall_analysis", "The wall's thickening")
    if (wall / "wall_segments.csv").is_file():
        lines += ["", f"Every tracked subject's wall thickness, thickening and strain per AHA "
                  f"segment: `{_link(root, wall / 'wall_segments.csv')}`; per vertex: "
                  f"`{_link(root, wall / 'maps')}/`."]  # fmt: skip
    return lines


def _subjects(root: Path, table) -> list[str]:
    stages = _stage_subjects(root, table)
    lines = ["", "## The subjects", "", "| " + " | ".join(stages) + " |",
             "|" + "---:|" * len(stages), "| " + " | ".join(str(len(v)) for v in stages.values())
             + " |", ""]  # fmt: skip
    left = left_out_subjects(root, table, stages)
    if left:
        lines += ["Left out or flagged:", "", "| subject | step | reason |", "|---|---|---|"]
        lines += [f"| {s} | {step} | {reason.replace('|', '/')} |" for s, step, reason in left]
    else:
        lines.append("No subject left out or flagged.")
    return lines


def _steps(outcome, root: Path) -> list[str]:
    lines = ["", "## The steps", "", "| step | status | time | command |", "|---|---|---:|---|"]
    for step, done in zip(outcome.steps, outcome.outcomes):
        lines.append(f"| {step.name} | {done.status} | {done.seconds:.0f} s | "
                     f"`{step.command(root)}` |")  # fmt: skip
    lines += ["", f"Each step's output: `{_link(root, root / 'logs')}/<step>.log`; the record "
              f"of the run: `run.json`. `symladders run {outcome.settings.path.name} --dry-run` "
              "prints the commands."]  # fmt: skip
    return lines


def _settings(settings) -> list[str]:
    from .route_settings import SETTINGS

    lines = ["", "## The settings", "", f"From `{settings.path}` (given keys in bold; the others "
             "at their recommended default):", "", "| key | value |", "|---|---|"]  # fmt: skip
    for section, keys in SETTINGS.items():
        for key in keys:
            value = settings.values[section][key]
            name = f"{section}.{key}" if section else key
            given = key in settings.given.get(section, {})
            lines.append(f"| {'**' + name + '**' if given else name} | `{value}` |")
    return lines


def _versions() -> list[str]:
    from ..running.provenance import package_versions

    lines = ["", "## Versions", ""]
    lines += [f"- {k}: {v}" for k, v in package_versions().items() if v is not None]
    return lines


def write_report(outcome, root: Path) -> Path:
    """Write ``root/report.md`` from the route's outputs (see the module); its path."""
    root = Path(root)
    settings, table, model = outcome.settings, outcome.table, outcome.model
    analysed = len(_rows(root / "analysis" / "design.csv"))
    lines = [f"# {settings.path.stem}: results", "",
             f"`symladders run {settings.path.name}`, {time.strftime('%Y-%m-%d %H:%M')}. "
             f"{len(table)} subjects in `{settings.subjects.name}`"
             + (f", {analysed} analysed" if analysed else "")
             + (f"; model `{model.formula}`" if model.formula else "") + ".", "",
             "## What was found", ""]  # fmt: skip
    lines += _found(root, settings)
    lines += _cycle(root)
    lines += _subjects(root, table)
    lines += _steps(outcome, root)
    lines += _settings(settings)
    lines += _versions()
    path = root / "report.md"
    from ..files import atomic_write_text

    atomic_write_text(path, "\n".join(lines) + "\n")
    return path
