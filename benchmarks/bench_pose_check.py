"""The pose check on the project's own cohorts: false refusals, and the margins to what it must stop.

    python benchmarks/bench_pose_check.py             # seeds 31-40, 45 subjects each
    python benchmarks/bench_pose_check.py --publish   # docs/generated/pose_check.md

Ten two-group cohorts of 45 subjects (``make_two_group_cohort``, default hypokinesia,
seeds 31 to 40) are written and read back as ``symladders cohort`` and ``symladders
study --meshes`` do (``write_two_group_cohort``, ``read_cohort``), and checked as the
study checks them (``check_cohort_units``): every refusal is a false one, since none of
them is posed. Then every one of their 450 subjects is checked (``check_units_and_pose``,
its ED and ES meshes together, as the study does: the ED mesh against the atlas, the ES
mesh against its ED) as it is, in metres, turned by 90 degrees about each of the
atlas's two minor axes (through the ED centroid), and moved by one atlas size along each
of the atlas's principal axes (both ways): across the long axis, and along it; and the
same moves of its ES mesh alone. The
measures are the rotation of the rigid fit of the corresponding vertices (the mesh with
the atlas's faces, as in the study) and the second moments (the same faces listed from
another corner, which the check reads as another triangulation). The former rule (the
angle between the principal axes, beyond 45 degrees, or the centroids more than one
atlas size apart) is evaluated on the same meshes.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import publishing_main  # noqa: E402

from ladders.study import read_cohort  # noqa: E402
from ladders.study.population import make_two_group_cohort, write_two_group_cohort  # noqa: E402
from ladders.study.preparation import (  # noqa: E402
    UnitsError,
    check_cohort_units,
    check_units_and_pose,
    principal_frame,
    second_moments,
)

SEEDS = range(31, 41)
SUBJECTS = 45


def _cohort(seed: int):
    data = make_two_group_cohort(SUBJECTS, seed=seed)
    with tempfile.TemporaryDirectory() as folder:
        return read_cohort(write_two_group_cohort(data, Path(folder) / "cohort"))


def _former(v, f, atlas, faces) -> tuple[float, float]:
    """The former rule's angle between principal axes and centroid offset (atlas sizes)."""
    centre, axes = principal_frame(v, f)
    atlas_centre, atlas_axes = principal_frame(atlas, faces)
    size = np.sqrt(np.trace(second_moments(atlas, faces)[1]))
    angle = np.degrees(np.arccos(min(1.0, abs(axes[:, 0] @ atlas_axes[:, 0]))))
    return float(angle), float(np.linalg.norm(centre - atlas_centre) / size)


def _check(atlas, faces, ed, es, f):
    """``(stopped, {phase: MeshSize})`` of one subject (ED and ES) checked as the study does."""
    pair = {"s": {"ed": (ed, f), "es": (es, f)}}
    try:
        report = check_units_and_pose(atlas, faces, pair)
    except UnitsError:
        report = check_units_and_pose(atlas, faces, pair, allow_pose=True, allow_scale=True)
        return True, {m.name.split(":")[1]: m for m in report.meshes}
    return False, {m.name.split(":")[1]: m for m in report.meshes}


def _variants(atlas, faces, v, centre):
    """The must-stop versions of ``v`` (about ``centre``): (kind, vertices)."""
    _, axes = principal_frame(atlas, faces)
    size = np.sqrt(np.trace(second_moments(atlas, faces)[1]))
    yield "metres", v / 1000.0
    for k in (1, 2):
        turn = Rotation.from_rotvec(np.pi / 2 * axes[:, k]).as_matrix()
        yield "turned", (v - centre) @ turn.T + centre
    for k in (0, 1, 2):
        for sign in (1.0, -1.0):
            yield ("along" if k == 0 else "across"), v + sign * size * axes[:, k]


def _measure_seed(seed: int) -> dict:
    cohort = _cohort(seed)
    atlas, faces = cohort.atlas, cohort.faces
    other = faces[:, [1, 2, 0]]  # the same triangles listed from another corner
    out = {"cohort_refused": 0, "rows": []}
    try:
        check_cohort_units(cohort)
    except UnitsError:
        out["cohort_refused"] = 1
    for s in cohort.subjects:
        row = {"former": [_former(v, faces, atlas, faces) for v in (s.ed, s.es)]}
        centre = second_moments(s.ed, faces)[0]
        for measure, f in (("correspondence", faces), ("moments", other)):
            stopped, sizes = _check(atlas, faces, s.ed, s.es, f)
            row[measure] = (stopped, max(m.angle for m in sizes.values()), sizes["ed"].offset,
                            sizes["es"].offset)  # fmt: skip
            moved = zip(
                _variants(atlas, faces, s.ed, centre), _variants(atlas, faces, s.es, centre)
            )
            for (kind, ed), (_, es) in moved:  # the whole subject moved
                hit, sizes = _check(atlas, faces, ed, es, f)
                row.setdefault((measure, kind), []).append(hit)
                row.setdefault((measure, kind + " value"), []).append(
                    max(m.angle for m in sizes.values()) if kind == "turned" else sizes["ed"].offset
                )
            es_centre = second_moments(s.es, faces)[0]
            for kind, es in _variants(atlas, faces, s.es, es_centre):  # ES alone moved
                hit, sizes = _check(atlas, faces, s.ed, es, f)
                row.setdefault((measure, "es " + kind), []).append(hit)
        out["rows"].append(row)
    print(f"seed {seed}: cohort refused {out['cohort_refused']}", flush=True)
    return out


def run() -> dict:
    """Every seed's measurements."""
    return {seed: _measure_seed(seed) for seed in SEEDS}


def _fraction(values) -> str:
    values = list(values)
    return f"{sum(values)} / {len(values)}"


def _table(results: dict) -> str:
    rows = [r for seed in results.values() for r in seed["rows"]]
    cohorts = sum(seed["cohort_refused"] for seed in results.values())
    n = len(rows)
    lines = [
        f"{len(results)} cohorts of {SUBJECTS} subjects (seeds {min(SEEDS)}-{max(SEEDS)}), "
        f"{n} subjects (ED and ES checked together, as the study checks them); the study's "
        f"check refused {cohorts} of the {len(results)} cohorts. A subject moved or turned "
        "as a whole, and its ES mesh alone: stopped / tried.",
        "",
        "| rule | unposed subjects refused | unposed: largest angle (deg) / ED offset / ES "
        "offset from ED (atlas sizes) | turned 90 deg: stopped (subject; ES alone) | moved one "
        "atlas size across the long axis | moved along it | in metres |",
        "|---|---|---|---|---|---|---|",
    ]
    former = np.array([f for r in rows for f in r["former"]])
    refused = (former[:, 0] > 45.0) | (former[:, 1] > 1.0)
    lines.append(
        f"| former: principal axes > 45 deg, offset > 1.0 (each mesh) | {refused.sum()} / "
        f"{len(former)} meshes | {former[:, 0].max():.1f} / {former[:, 1].max():.2f} | - | - "
        "| - | - |"
    )
    for measure, name in (("correspondence", "rigid fit of the corresponding vertices (study)"),
                          ("moments", "second moments (another triangulation)")):  # fmt: skip
        unposed = np.array([r[measure][1:] for r in rows])
        stopped = [r[measure][0] for r in rows]

        def cells(kind, rows=rows, measure=measure):
            whole = [x for r in rows for x in r[(measure, kind)]]
            alone = [x for r in rows for x in r[(measure, "es " + kind)]]
            return f"{_fraction(whole)}; {_fraction(alone)}"

        lines.append(
            f"| {name}: > 45 deg, offset > 0.6 | {_fraction(stopped)} | "
            f"{unposed[:, 0].max():.1f} / {unposed[:, 1].max():.2f} / {unposed[:, 2].max():.2f} "
            f"| {cells('turned')} | {cells('across')} | {cells('along')} | {cells('metres')} |"
        )
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    publishing_main("pose_check", __doc__, lambda: _table(run()), argv)


if __name__ == "__main__":
    main()
