"""The correspondence's quality table: one row per mesh, the ones to inspect first.

A row holds the data term's distance before and after the registration, the
Hausdorff and mean surface distances of the corresponded mesh to its input (in
the atlas's unit), the optimiser's convergence and iterations. A mesh is flagged
when its subject failed (the reason is given), its registration did not
converge, a distance exceeds the settings' thresholds, or its mean surface
distance is more than three times the cohort's median (at least five meshes).
Flagged rows come first, then the others by decreasing mean surface distance.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ..files import atomic_write_text

__all__ = ["COLUMNS", "quality_rows", "write_quality_table"]

COLUMNS = (
    "subject", "phase", "status", "flagged", "reasons", "n_input_vertices", "distance_before",
    "distance_after", "hausdorff", "mean_surface_distance", "converged", "n_iter", "unit",
)  # fmt: skip


def _flags(row: dict, settings, median: float | None) -> list[str]:
    if row["status"] != "ok":
        return [row["reasons"]]
    out = []
    if not row["converged"]:
        out.append(f"registration stopped after {row['n_iter']} iterations before converging")
    if row["mean_surface_distance"] > settings.flag_mean_distance:
        out.append(f"mean surface distance > {settings.flag_mean_distance:g}")
    if row["hausdorff"] > settings.flag_hausdorff:
        out.append(f"Hausdorff distance > {settings.flag_hausdorff:g}")
    if median is not None and row["mean_surface_distance"] > 3 * median:
        out.append(f"mean surface distance > 3 x the cohort's median ({median:.3g})")
    return out


def quality_rows(records: list[dict], settings, units: dict | None = None) -> list[dict]:
    """The table's rows from the subjects' records, flagged first (see the module)."""
    units = units or {}
    rows = []
    for rec in records:
        for phase in ("ed", "es"):
            row = dict.fromkeys(COLUMNS, "")
            row.update(subject=rec["subject"], phase=phase, status=rec["status"],
                       unit=units.get(rec["subject"], ""))  # fmt: skip
            if rec["status"] == "ok":
                row.update({k: rec[phase][k] for k in COLUMNS if k in rec[phase]})
            else:
                row["reasons"] = rec.get("reason", "failed")
            rows.append(row)
    ok = [r["mean_surface_distance"] for r in rows if r["status"] == "ok"]
    median = float(np.median(ok)) if len(ok) >= 5 else None
    for row in rows:
        reasons = _flags(row, settings, median)
        row["flagged"] = bool(reasons)
        row["reasons"] = "; ".join(reasons)
    ok_key = lambda r: -r["mean_surface_distance"] if r["status"] == "ok" else 0.0  # noqa: E731
    return sorted(rows, key=lambda r: (not r["flagged"], ok_key(r)))


def _fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def write_quality_table(records, output, settings, units=None) -> list[dict]:
    """Write ``quality.csv`` and ``quality.md`` into ``output``; return the rows."""
    rows = quality_rows(records, settings, units)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    output = Path(output)
    atomic_write_text(output / "quality.csv", buf.getvalue())
    n_flag = sum(r["flagged"] for r in rows)
    lines = [
        "# Correspondence quality",
        "",
        f"{len(rows)} meshes, {n_flag} flagged for inspection (listed first). Distances in the "
        "atlas's unit; `distance_*` is the data term's RKHS distance (unit^2).",
        "",
        "| " + " | ".join(COLUMNS) + " |",
        "|" + "---|" * len(COLUMNS),
    ]
    lines += ["| " + " | ".join(_fmt(r[c]) for c in COLUMNS) + " |" for r in rows]
    atomic_write_text(output / "quality.md", "\n".join(lines) + "\n")
    return rows
