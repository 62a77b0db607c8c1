"""``report.md``: the entry point to a route's results.

Written by the last step of ``symladders run`` from what the steps wrote (nothing is
computed again): what was run and on whom; the maps of the model's contrasts (figures,
bull's-eyes, the vertices and AHA segments found), with the score against a planted
truth when the settings give one; the cycle's analysis; every subject left out or
flagged, with the step and the reason; every setting and the versions of the packages.
"""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

__all__ = ["write_report", "subjects_with_results", "flagged_subjects"]


def subjects_with_results(folder: Path) -> list[str]:
    """The subjects with results in a study folder (or a cycle study's)."""
    folder = Path(folder)
    if (folder / "cycle_study.csv").is_file() or any(folder.glob("*.npz")):
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


def flagged_subjects(root: Path, subjects: list[str]) -> list[tuple[str, str, str]]:
    """``(subject, step, reason)`` of every subject a step could not use or flagged."""
    root = Path(root)
    out = []
    for row in _rows(root / "meshes" / "meshing.csv"):
        if row.get("status") == "failed":
            name = Path(row.get("mesh") or row.get("source") or "").name
            subject = _subject_of(name, subjects)
            out.append((subject, "mesh", row.get("error", "")))
    for row in _rows(root / "corresponded" / "quality.csv"):
        reason = row.get("flag") or row.get("flags") or row.get("reason") or ""
        if reason.strip():
            out.append((row.get("subject", ""), "correspond", reason))
    for row in _rows(root / "tracked" / "tracking.csv"):
        if row.get("status") not in (None, "", "ok", "skipped", "reused"):
            out.append((row.get("subject", ""), "track", row.get("error") or row["status"]))
    for row in _rows(root / "cycle_study" / "cycle_study.csv"):
        if row.get("status") not in (None, "", "ok", "skipped", "reused"):
            out.append((row.get("subject", ""), "cycle-study", row.get("error") or row["status"]))
    return out


def _subject_of(name: str, subjects: list[str]) -> str:
    for s in sorted(subjects, key=len, reverse=True):
        if name.startswith(s):
            return s
    return name


def _versions() -> dict:
    from ..running.provenance import package_versions

    return package_versions()


def _link(root: Path, path: Path) -> str:
    return os.path.relpath(path, root).replace(os.sep, "/")


def write_report(outcome, root: Path) -> Path:
    """Write ``root/report.md`` from the route's outputs; its path."""
    root = Path(root)
    settings, table, model = outcome.settings, outcome.table, outcome.model
    lines = [f"# Results of `symladders run {settings.path.name}`", ""]
    lines += [f"{len(table)} subjects from `{settings.subjects}`; model `{model.formula}`.", ""]
    lines += ["## Steps", "", "| step | status | time | command |", "|---|---|---:|---|"]
    for step, done in zip(outcome.steps, outcome.outcomes):
        lines.append(f"| {step.name} | {done.status} | {done.seconds:.0f} s | "
                     f"`{step.command(root)}` |")  # fmt: skip
    lines.append("| report | ran | | |")
    analysis = root / "analysis"
    summary = analysis / "model_summary.md"
    if summary.is_file():
        lines += ["", "## The model", "", summary.read_text(encoding="utf-8")]
        for fig in sorted(analysis.glob("fig_*.png")):
            lines += [f"![{fig.stem}]({_link(root, fig)})", ""]
    flagged = flagged_subjects(root, table.subjects)
    lines += ["", "## Subjects left out or flagged", ""]
    if flagged:
        lines += ["| subject | step | reason |", "|---|---|---|"]
        lines += [f"| {s} | {step} | {reason} |" for s, step, reason in flagged]
    else:
        lines.append("None.")
    lines += ["", "## Settings", "", "```json",
              json.dumps(settings.values, indent=1, default=str), "```"]  # fmt: skip
    lines += ["", "## Versions", ""]
    lines += [f"- {k}: {v}" for k, v in _versions().items()]
    path = root / "report.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
