"""The correspondence's quality table: one row per mesh, the ones to inspect first.

A row holds the data term's distance before and after the registration, the
Hausdorff and mean surface distances of the corresponded mesh to its input (in
the atlas's unit; the input's vertices beyond the atlas's rim, such as the lid a
label image gives a ventricle at its valve plane, are left out, and
``beyond_rim_fraction`` says what fraction they are), the optimiser's convergence
and iterations. A mesh is flagged
when its subject failed (the reason is given), its registration did not
converge, a distance exceeds the settings' thresholds, its mean surface
distance is more than three times the cohort's median (at least five meshes),
its landmarks and its surface fit disagree by more than ``flag_landmark_disagreement`` degrees, or fewer than
60 % of its vertices found the end-systolic surface along their normal.
Flagged rows come first, then the others by decreasing mean surface distance.
The end-diastolic rows also say how the mesh was aligned (``alignment``: ``icp``
or ``landmarks``) and over how many degrees about the long axis the surface fit
stays within its tolerance of the best (``axial_spread_deg``, 360 for a surface
of revolution): above ``flag_axial_spread`` without landmarks, the turn kept is
the input's own (:mod:`.rigid_fit`), which ``quality.md`` says in its header.
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
    "alignment", "axial_spread_deg", "landmark_disagreement_deg", "normal_hit_fraction",
    "beyond_rim_fraction",
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
    disagreement = row.get("landmark_disagreement_deg")
    if disagreement not in ("", None) and disagreement > settings.flag_landmark_disagreement:
        out.append(
            f"landmarks and surface fit differ by {disagreement:.0f} degrees "
            f"(> {settings.flag_landmark_disagreement:g}): check the landmarks"
        )
    hits = row.get("normal_hit_fraction")
    if hits not in ("", None) and hits < 0.6:
        out.append(f"only {hits:.0%} of the vertices met the surface along their normal")
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
    if value is None:
        return ""
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
    ]
    open_turn = [r for r in rows if r["alignment"] == "icp"
                 and isinstance(r["axial_spread_deg"], float)
                 and r["axial_spread_deg"] > settings.flag_axial_spread]  # fmt: skip
    if open_turn:
        spreads = [r["axial_spread_deg"] for r in open_turn]
        lines += [
            f"{len(open_turn)} subject(s): the surface leaves the turn about the long axis open "
            f"(fits within {settings.rotation_tolerance:.0%} of the best over {min(spreads):.0f} "
            f"to {max(spreads):.0f} degrees); their input's own orientation was kept. Anatomical "
            "landmarks (a landmark table, or a right-ventricle label) fix it.",
            "",
        ]
    lines += [
        "| " + " | ".join(COLUMNS) + " |",
        "|" + "---|" * len(COLUMNS),
    ]
    lines += ["| " + " | ".join(_fmt(r[c]) for c in COLUMNS) + " |" for r in rows]
    atomic_write_text(output / "quality.md", "\n".join(lines) + "\n")
    return rows
