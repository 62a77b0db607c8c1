"""Closest points and normal-line hits on a frame's surface: libigl's tree against the previous code.

    python benchmarks/bench_surface_queries.py [--repeat 20] [--publish]

The queries of tracking a mesh through a cycle, on the surface of one meshed frame
(a short-axis label image of 1.5 x 1.5 x 8 mm of the synthetic cohort's first subject at
end-systole, meshed as ``symladders mesh`` does) and the subject's ED mesh (the default
atlas's vertices):

* closest points of the ED vertices on the frame's surface:
  :func:`ladders.study.surface_queries.closest_points` (libigl's AABB tree) against
  :func:`trimesh.proximity.closest_point` (its R-tree, built for every mesh queried);
* the normal lines of the ED vertices met with the surface:
  :func:`ladders.study.surface_queries.line_hits` against the k-d tree candidate search
  that :mod:`ladders.study.wall_motion` keeps for the lines through an edge or a vertex.

Reported: the median time of ``--repeat`` calls, each building its own tree (as the
tracking does: the surface moves), the ratio, and the largest difference of the answers
(distances; the hit points of the lines). The CPU is named.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.study.cohort import make_synthetic_cohort, motion_forward  # noqa: E402
from ladders.study.imaging import (  # noqa: E402
    LabelImage,
    MeshingSettings,
    extract_surface,
    render_labels,
    short_axis_affine,
)
from ladders.study.surface_queries import closest_points, line_hits  # noqa: E402
from ladders.study.wall_motion import _line_hits, outward_vertex_normals  # noqa: E402


def _surface():
    cohort = make_synthetic_cohort(1)
    subject = cohort.subjects[0]
    ed = np.asarray(subject.ed, float)
    low, high = ed.min(0) - 15.0, ed.max(0) + np.array([15.0, 15.0, 8.0])
    spacing = np.array([1.5, 1.5, 8.0])
    shape = tuple(int(n) for n in np.ceil((high - low) / spacing))
    labels = render_labels(subject.parameters, short_axis_affine(low, 1.5, 8.0), shape, 1.0)
    es = motion_forward(subject.parameters, ed, 1.0)
    plane = (0.0, 0.0, float(es[:, 2].max()), 0.0, 0.0, 1.0)
    image = LabelImage(labels.astype(np.int64), short_axis_affine(low, 1.5, 8.0), Path("es"), 0)
    v, f, _ = extract_surface(image, 1, MeshingSettings(cut_plane=plane))
    return ed, cohort.faces, v, f


def _median_time(call, repeat):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        out = call()
        times.append(time.perf_counter() - start)
    return float(np.median(times)), out


def run(repeat: int) -> list[tuple]:
    ed, faces, v, f = _surface()
    normals = outward_vertex_normals(ed, faces)
    reach = 0.2 * float(np.linalg.norm(v.max(0) - v.min(0)))
    t_new, new = _median_time(lambda: closest_points(ed, v, f)[1], repeat)
    t_old, old = _median_time(
        lambda: trimesh.proximity.closest_point(trimesh.Trimesh(v, f, process=False), ed)[1], repeat
    )
    rows = [("closest points", len(ed), len(f), t_old, t_new, float(np.abs(new - old).max()))]
    t_new, new = _median_time(lambda: line_hits(ed, normals, v, f, reach), repeat)
    t_old, old = _median_time(lambda: _line_hits(ed, normals, v, f, reach), repeat)
    keep = np.abs(old[1]) <= reach
    a = {(int(i), int(j)): p for i, p, j in zip(new[0], new[2], new[3])}
    b = {(int(i), int(j)): p for i, p, j in zip(old[0][keep], old[2][keep], old[3][keep])}
    common = sorted(set(a) & set(b))
    gap = max((float(np.abs(a[k] - b[k]).max()) for k in common), default=float("nan"))
    rows.append(("normal lines met", len(ed), len(f), t_old, t_new, gap,
                 len(set(a) ^ set(b)), len(b)))  # fmt: skip
    for r in rows:
        print(r, flush=True)
    return rows


def _table(rows, repeat) -> str:
    lines = [
        "| query | queries | surface triangles | previous (ms) | libigl tree (ms) | ratio "
        "| largest difference (mm) |",
        "|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        name, n, m, old, new, gap = row[:6]
        extra = f"; hits found by one only: {row[6]} of {row[7]}" if len(row) > 6 else ""
        lines.append(f"| {name} | {n} | {m} | {1e3 * old:.1f} | {1e3 * new:.1f} | "
                     f"{old / new:.0f} | {gap:.1e}{extra} |")  # fmt: skip
    note = (
        "The ED vertices of the synthetic cohort's first subject (default atlas) queried "
        "against its end-systolic surface meshed from a 1.5 x 1.5 x 8 mm label image; median "
        f"of {repeat} calls, each building its tree. Previous: trimesh's closest point (R-tree) "
        "and the k-d tree candidate search of the normal lines."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=20)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    table = _table(run(args.repeat), args.repeat)
    print("\n" + table)
    if args.publish:
        publish("surface_queries", table, "python benchmarks/bench_surface_queries.py --publish")


if __name__ == "__main__":
    main()
