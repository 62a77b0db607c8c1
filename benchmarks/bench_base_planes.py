"""Valve planes estimated from label series against the true ones, and what they do to the tracking.

    python benchmarks/bench_base_planes.py [--subjects 8] [--work DIR] [--jobs 2] [--publish]
                                           # docs/generated/base_planes.md
    python benchmarks/bench_base_planes.py --table-only --publish   # the rows measured before

Two ground truths, each rendered as short-axis label series of 1.5 x 1.5 x 8 mm and of
1.5 mm isotropic voxels, 25 frames:

* the synthetic whole-cycle cohort (``make_two_group_cycles``, seed 0, the first
  ``--subjects`` subjects), written as ``symladders cohort --cycle 25 --images labels``
  writes it (``write_cycle_cohort``: ``valve_planes.csv`` is the truth, the plane of the
  rim of every true frame), tracked from the subjects' true ED meshes;
* an analytic ventricle of known motion (``AnalyticVentricle``: a prolate cavity whose
  valve plane is tilted by 12 degrees against the slices, apex fixed, uniform shortening
  and a radial contraction uniform along the axis or 30 % stronger at the apex), and the
  same with its base level with the slices and its descent 5 % of the cycle later than the
  contraction (the estimate's assumption broken). Its truth is the plane of the moved rim.

Each is tracked by ``track_cohort`` (``symladders track``) five ways: the former defaults
(no refine_ed, no planes), refine_ed without planes, refine_ed with the true planes
(``--cut-planes``), refine_ed with the planes estimated from the images (the defaults;
estimated on the isotropic series too, ``estimate_planes="always"``), and the chain with
the estimated planes. Planes: the error of the estimated height along the ED normal and
the angle between the estimated and the true normals, against the middle of the heights
the last slice with cavity allows (the rim of a plain meshing). Tracking: the error at
ES of every vertex against the true place of the material point it started from, along
the long axis, along the wall and across it, means over the vertices and the subjects;
the time of ``track_cohort`` per subject with the 1-minute load average.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_tracking_label_causes import errors  # noqa: E402
from generated_tables import machine, publish  # noqa: E402

from ladders.study.cohort.analytic_ventricle import AnalyticVentricle  # noqa: E402
from ladders.study.imaging import write_series  # noqa: E402
from ladders.study.meshes.mesh_io import read_mesh, write_mesh  # noqa: E402
from ladders.study.population import (  # noqa: E402
    cycle_grid,
    cycle_valve_planes,
    make_two_group_cycles,
    write_cycle_cohort,
)
from ladders.study.sequences import read_tracked_frames  # noqa: E402
from ladders.study.tracking import TrackingSettings, rim_plane, track_cohort  # noqa: E402
from ladders.study.wall_motion import outward_vertex_normals  # noqa: E402

N_FRAMES = 25
ACQUISITIONS = {"SAX 1.5 x 1.5 x 8 mm": 8.0, "iso 1.5 mm": 1.5}
#: The analytic ventricles: overrides of AnalyticVentricle's defaults.
ANALYTIC = {
    "analytic, tilted 12 deg, contraction uniform along the axis": {"radial_gradient": 0.0},
    "analytic, tilted 12 deg, contraction 30 % stronger at the apex": {},
    "analytic, base level, its descent 5 % of the cycle late": {"tilt": 0.0, "delay": 0.05},
}
#: The trackings: (refine_ed, planes: None, "true" or "estimated").
TRACKINGS = {
    "former defaults: chain, no planes": (False, None),
    "refine_ed, no planes": (True, None),
    "refine_ed, true planes": (True, "true"),
    "refine_ed, estimated planes (defaults)": (True, "estimated"),
    "chain, estimated planes": (False, "estimated"),
}


def _settings(refine: bool, planes) -> TrackingSettings:
    estimate = "always" if planes == "estimated" else "never"
    return TrackingSettings(refine_ed=refine, estimate_planes=estimate)


def _track(meshes, images, out, refine, planes, truth_planes, jobs) -> float:
    """Track a folder (resumable); seconds per subject of this run (NaN when all were done)."""
    start = time.perf_counter()
    outcome = track_cohort(meshes, images, out, 1, _settings(refine, planes),
                           cut_planes=truth_planes if planes == "true" else None, jobs=jobs,
                           progress=False)  # fmt: skip
    seconds = time.perf_counter() - start
    done = [r for r in outcome.records if r["status"] == "ok"]
    if outcome.failed:
        print(f"  {out.name}: failed {outcome.failed}", flush=True)
    return seconds * jobs / len(done) if done else float("nan")


def _frames(folder: Path, names) -> np.ndarray:
    sequences = read_tracked_frames(folder)
    return np.stack([[read_mesh(p)[0] for p in sequences[s]] for s in names])


def _plane_errors(folder: Path, names, truth: dict, es: int) -> dict:
    """Height (mm) and tilt (deg) errors of the estimated planes in each subject's record
    (``es``: the end-systolic frame)."""
    out = {"es": [], "all": [], "tilt": [], "middle_es": [], "consistent": []}
    for name in names:
        record = json.loads((folder / f"{name}.json").read_text())["estimated_planes"]
        est, true = np.array(record["planes"]), np.array(truth[name])
        normal = true[0, 3:]
        error = est[:, :3] @ normal - true[:, :3] @ normal
        middle = np.array(record["bounds"]).mean(axis=1) - true[:, :3] @ normal
        out["es"].append(error[es])
        out["all"].append(np.abs(error).max())
        out["middle_es"].append(middle[es])
        cos = np.clip(np.einsum("kd,kd->k", est[:, 3:], true[:, 3:]), -1.0, 1.0)
        out["tilt"].append(np.degrees(np.arccos(cos)).max())
        out["consistent"].append(bool(record["consistent"]))
    return out


def run_cohort(work: Path, n: int, jobs: int) -> list[dict]:
    c = make_two_group_cycles(n_subjects=n, n_frames=N_FRAMES)
    truth = {s: [p[str(t)] for t in range(N_FRAMES)] for s, p in cycle_valve_planes(c).items()}
    rows = []
    for acquisition, thickness in ACQUISITIONS.items():
        root = work / f"cohort_{thickness:g}"
        if not (root / "cohort" / "cycle.json").is_file():
            write_cycle_cohort(c, root / "cohort", "labels", 1.5, thickness)
        images = root / "cohort" / "images"
        for label, (refine, planes) in TRACKINGS.items():
            out = root / label.split(" (")[0].replace(",", "").replace(" ", "_")
            load = os.getloadavg()[0]
            seconds = _track(root / "cohort", images, out, refine, planes, cycle_valve_planes(c),
                             jobs)  # fmt: skip
            e = errors(c, list(c.names), _frames(out, c.names), [np.eye(4)] * n)
            row = {"data": f"synthetic cohort ({n} subjects)", "acquisition": acquisition,
                   "tracking": label, "seconds": seconds, "load": load, **e}  # fmt: skip
            if planes == "estimated":
                row["planes"] = _plane_errors(out, c.names, truth, int(np.argmax(c.fractions)))
            rows.append(row)
            print(json.dumps({k: v for k, v in row.items() if k != "planes"}), flush=True)
    return rows


def _analytic_errors(av, v, f, tracked, times) -> dict:
    es = int(np.argmax(av.fraction(times)))
    truth = av.motion(tracked[0], times[es])
    e = tracked[es] - truth
    nu = outward_vertex_normals(truth, f)
    across = np.einsum("kd,kd->k", e, nu)
    return {"long_axis": float(np.abs(e[:, 2]).mean()), "normal": float(np.abs(across).mean()),
            "along_wall": float(np.linalg.norm(e - across[:, None] * nu, axis=1).mean())}  # fmt: skip


def run_analytic(work: Path) -> list[dict]:
    rows = []
    for data, overrides in ANALYTIC.items():
        av = AnalyticVentricle(**overrides)
        v, f = av.mesh()
        times = av.times(N_FRAMES)
        truth = [rim_plane(av.motion(v, t), f).tolist() for t in times]
        for acquisition, thickness in ACQUISITIONS.items():
            root = work / f"analytic_{list(ANALYTIC).index(data)}_{thickness:g}"
            meshes, images = root / "meshes", root / "images"
            if not (images / "av.nii.gz").is_file():
                affine, shape = cycle_grid(v, 1.5, thickness)
                meshes.mkdir(parents=True, exist_ok=True)
                write_mesh(meshes / "av_ed.vtk", v, f)
                write_series(images / "av.nii.gz", [av.labels(affine, shape, t) for t in times],
                             affine)  # fmt: skip
            for label, (refine, planes) in TRACKINGS.items():
                out = root / label.split(" (")[0].replace(",", "").replace(" ", "_")
                load = os.getloadavg()[0]
                seconds = _track(meshes, images, out, refine, planes,
                                 {"av": {str(t): p for t, p in enumerate(truth)}}, 1)  # fmt: skip
                tracked = _frames(out, ["av"])[0]
                row = {"data": data, "acquisition": acquisition, "tracking": label,
                       "seconds": seconds, "load": load, "subjects": 1,
                       **_analytic_errors(av, v, f, tracked, times)}  # fmt: skip
                if planes == "estimated":
                    es = int(np.argmax(av.fraction(times)))
                    row["planes"] = _plane_errors(out, ["av"], {"av": truth}, es)
                rows.append(row)
                print(json.dumps({k: v for k, v in row.items() if k != "planes"}), flush=True)
    return rows


def _mean_max(values) -> str:
    a = np.abs(np.asarray(values, dtype=float))
    return f"{a.mean():.2f} / {a.max():.2f}"


def _table(rows: list[dict]) -> str:
    planes = [
        "| data | acquisition | height error at ES, mean / max (mm) | largest height error "
        "over the frames, mean / max (mm) | tilt error, largest (deg) | the last slice's "
        "middle: height error at ES, mean / max (mm) | amplitude consistent with every frame |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if r["tracking"] != "refine_ed, estimated planes (defaults)":
            continue
        p = r["planes"]
        planes.append(
            f"| {r['data']} | {r['acquisition']} | {_mean_max(p['es'])} | {_mean_max(p['all'])} "
            f"| {max(p['tilt']):.2f} | {_mean_max(p['middle_es'])} | "
            f"{sum(p['consistent'])} of {len(p['consistent'])} |"
        )
    tracking = [
        "| data | acquisition | tracking | ES error along the long axis (mm) | along the wall "
        "/ across it (mm) | time per subject (s) | load |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        tracking.append(
            f"| {r['data']} | {r['acquisition']} | {r['tracking']} | {r['long_axis']:.2f} | "
            f"{r['along_wall']:.2f} / {r['normal']:.2f} | {r['seconds']:.1f} | {r['load']:.1f} |"
        )
    note = (
        f"Label series of {N_FRAMES} frames (ES at 35 % of the cycle), tracked by `track_cohort` "
        "from the true ED meshes by projection. Planes: the estimate of every frame "
        "(`estimate_base_planes`) against the true plane, the height along the ED normal and "
        "the angle between the normals; 'the last slice's middle': the middle of the heights "
        "the frame's cavity allows, where a plain meshing puts the rim. Tracking: errors at ES "
        "against the true place of the material point each vertex started from, means over "
        "the vertices and the subjects; seconds of `track_cohort` per subject (two subjects at "
        "a time for the cohort, one for the analytic ventricle), under the 1-minute load "
        "average shown."
    )
    return note + "\n\n" + "\n".join(planes) + "\n\n" + "\n".join(tracking) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=8)
    parser.add_argument("--work", type=Path, default=Path("symladders-output/bench_base_planes"))
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--table-only", action="store_true",
                        help="the table of the rows measured before (WORK/rows.json)")  # fmt: skip
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    if args.table_only:
        rows = json.loads((args.work / "rows.json").read_text())
    else:
        rows = run_analytic(args.work) + run_cohort(args.work, args.subjects, args.jobs)
        (args.work / "rows.json").write_text(json.dumps(rows, indent=1, default=float))
    table = _table(rows)
    print("\n" + table)
    if args.publish:
        publish("base_planes", table, "python benchmarks/bench_base_planes.py --publish")


if __name__ == "__main__":
    main()
