"""Wall thickness, thickening and strain from label series, against the generator's truth.

    python benchmarks/bench_wall.py [--subjects 6] [--frames 25] [--jobs 2] [--publish]

The first subjects of the whole-cycle two-group cohort
(:func:`ladders.study.population.make_two_group_cycles`, 1009 vertices, half of them
patients with the cycle's hypokinesia of segments 7, 8, 13, 14) are rendered as label
series (blood pool 1, myocardium 2) at two acquisitions, a short-axis stack of
1.5 x 1.5 x 8 mm voxels and 1.5 mm isotropic voxels. Every frame is meshed as
``symladders track`` meshes it (``TrackingSettings().meshing``, cut at the frame's true
valve plane, as the cohort's ``valve_planes.csv`` gives it). Two routes:

* **true endocardium**: the generator's endocardium at every frame, the epicardium
  meshed from each frame's labels: the error of the epicardium alone (and, for the
  strains, of the mesh's discretisation alone);
* **tracked**: ``symladders track --refine-ed --cut-planes valve_planes.csv
  --myocardium-label 2`` (:func:`~ladders.study.tracking.track_surfaces` from the true
  ED mesh, the valve planes anchoring the base, and
  :func:`~ladders.study.tracking.track_epicardium`), what ``symladders wall`` measures.

Against :func:`ladders.study.wall.true_wall_maps` (the same definitions on the
generator's exact surfaces and motion), means over the subjects of: per vertex, the
absolute error of the thickness at ED (and its mean signed error, the bias), of the
peak thickening, and of the peak radial, circumferential and longitudinal strain
(percentage points); per AHA segment (the peak of the segment's mean curve), the same;
per ring of the AHA model. What the tracked strains' errors come from: the strains of
the true frames moved by the normal part alone, or the part along the wall alone, of
each tracked vertex's error (the true surface's normals).
``rim``: the fraction of vertex-frames whose closest epicardium is its rim. Times per
subject on one core (the subjects ``--jobs`` at a time), with the load average.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.study.cohort.synthetic_lv import lv_grid  # noqa: E402
from ladders.study.imaging import (  # noqa: E402
    LabelImage,
    MeshingSettings,
    extract_epicardium,
    extract_surface,
)
from ladders.study.population import make_two_group_cycles  # noqa: E402
from ladders.study.population.aha_model import aha_segments  # noqa: E402
from ladders.study.population.cycle_images import cycle_grid, valve_planes  # noqa: E402
from ladders.study.preparation.synthetic_landmarks import synthetic_landmarks  # noqa: E402
from ladders.study.tracking import TrackingSettings, track_surfaces  # noqa: E402
from ladders.study.tracking.epicardium_tracking import track_epicardium  # noqa: E402
from ladders.study.wall import (  # noqa: E402
    PEAK_SENSE,
    signed_peaks,
    surface_strains,
    true_wall_maps,
    wall_maps,
)
from ladders.study.wall_motion import outward_vertex_normals  # noqa: E402

ACQUISITIONS = {"SAX 1.5 x 1.5 x 8 mm": (1.5, 8.0), "iso 1.5 mm": (1.5, 1.5)}
SETTINGS = TrackingSettings(refine_ed=True)
STRAINS = ("radial", "circumferential", "longitudinal")
GRID = (42, 24)  # 1009 vertices


def _segment_curves(curves: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Mean of each segment's vertices at every frame, NaN (the truth's apex point) left out."""
    out = np.empty((curves.shape[0], 17))
    for j in range(17):
        out[:, j] = np.nanmean(curves[:, segments == j + 1], axis=1)
    return out


#: The AHA rings: their segments.
RINGS = {"basal": range(1, 7), "mid": range(7, 13), "apical": range(13, 17), "apex": (17,)}


def _errors(maps, truth, segments) -> dict:
    """Per-vertex and per-segment absolute errors against the truth (mm, percentage points),
    and per ring of the AHA model (per-vertex errors averaged over the ring's vertices)."""
    out = {"thickness_ed": np.abs(maps.thickness[0] - truth.thickness[0]).mean(),
           "bias_ed": (maps.thickness[0] - truth.thickness[0]).mean(),
           "rim": maps.on_rim.mean()}  # fmt: skip
    for ring, members in RINGS.items():
        where = np.isin(segments, members)
        out[f"{ring}:thickness_ed"] = np.abs(maps.thickness[0] - truth.thickness[0])[where].mean()
        out[f"{ring}:bias_ed"] = (maps.thickness[0] - truth.thickness[0])[where].mean()
        for name in STRAINS:
            error = np.abs(maps.peak(name) - truth.peak(name))[where]
            out[f"{ring}:{name}"] = 100.0 * np.nanmean(error)
    for name in ("thickening", *STRAINS):
        scale = 100.0 if name in STRAINS else 1.0
        got, true = maps.measure(name), truth.measure(name)
        out[name] = scale * np.nanmean(np.abs(maps.peak(name) - truth.peak(name)))
        sense = PEAK_SENSE[name]
        seg = [signed_peaks(_segment_curves(c, segments), sense) for c in (got, true)]
        out[f"{name}_segment"] = scale * np.nanmean(np.abs(seg[0] - seg[1]))
    seg_ed = [_segment_curves(m.thickness[:1], segments)[0] for m in (maps, truth)]
    out["thickness_ed_segment"] = np.abs(seg_ed[0] - seg_ed[1]).mean()
    return out


def _split_errors(tracked, true_frames, faces, truth, lm) -> dict:
    """Peak strain errors (pp) of the true frames moved by one part of the tracking's error."""
    error = tracked - true_frames
    normals = np.stack([outward_vertex_normals(v, faces) for v in true_frames])
    normal = np.einsum("tkd,tkd->tk", error, normals)[..., None] * normals
    out = {}
    for part, moved in (("normal part", true_frames + normal),
                        ("along the wall", true_frames + error - normal)):  # fmt: skip
        strains = dict(zip(("circumferential", "longitudinal"),
                           surface_strains(moved, faces, lm.apex, lm.base)))  # fmt: skip
        for name, curves in strains.items():
            peak = signed_peaks(curves, PEAK_SENSE[name])
            out[f"{part}:{name}"] = 100.0 * np.nanmean(np.abs(peak - truth.peak(name)))
    return out


def _truth_means(truth, segments) -> dict:
    out = {"thickness_ed": truth.thickness[0].mean()}
    for name in ("thickening", *STRAINS):
        out[name] = (100.0 if name in STRAINS else 1.0) * np.nanmean(truth.peak(name))
    return out


def run_subject(index: int, n_subjects: int, n_frames: int) -> list[dict]:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    cycles = make_two_group_cycles(n_subjects=n_subjects, n_frames=n_frames)
    params, abnormality = cycles.motion_of(index)
    faces = cycles.faces
    theta, phi, _ = lv_grid(*GRID)
    atlas = cycles.data.cohort.atlas
    lm = synthetic_landmarks(atlas)
    segments = aha_segments(atlas, lm.apex, lm.base, lm.septum, faces)
    true_frames = cycles.frames[index]
    start = time.perf_counter()
    truth = true_wall_maps(params, theta, phi, cycles.fractions, abnormality)
    rows = [{"route": "truth", "acquisition": "", "truth_seconds": time.perf_counter() - start,
             **_truth_means(truth, segments)}]  # fmt: skip
    planes = valve_planes(true_frames, faces)
    for acquisition, (in_plane, thickness) in ACQUISITIONS.items():
        affine, shape = cycle_grid(true_frames[0], in_plane, thickness)
        images = [LabelImage(cycles.render_labels(index, affine, shape, t).astype(np.int64), affine,
                             Path(f"frame_{t}"), t) for t in range(n_frames)]  # fmt: skip
        meshing = [MeshingSettings(**{**SETTINGS.meshing.as_dict(), "cut_plane": tuple(p)})
                   for p in planes]  # fmt: skip
        start = time.perf_counter()
        epicardia = [extract_epicardium(im, 1, 2, m)[:2] for im, m in zip(images, meshing)]
        epi_meshing = time.perf_counter() - start
        start = time.perf_counter()
        maps = wall_maps(true_frames, faces, epicardia, lm.apex, lm.base)
        maps_seconds = time.perf_counter() - start
        rows.append({"route": "true endocardium", "acquisition": acquisition,
                     **_errors(maps, truth, segments), "maps_seconds": maps_seconds,
                     "epi_meshing": epi_meshing})  # fmt: skip
        surfaces = [extract_surface(im, 1, m)[:2] for im, m in zip(images, meshing)]
        tracked = track_surfaces(true_frames[0], faces, surfaces, SETTINGS, base_planes=planes)
        start = time.perf_counter()
        epicardium, _ = track_epicardium(images, 1, 2, SETTINGS, meshing, planes)
        epi_tracking = time.perf_counter() - start
        maps = wall_maps(tracked.vertices, faces,
                         [(v, epicardium.faces) for v in epicardium.vertices], lm.apex, lm.base)  # fmt: skip
        rows.append({"route": "tracked", "acquisition": acquisition,
                     **_errors(maps, truth, segments), "epi_tracking": epi_tracking,
                     **_split_errors(tracked.vertices, true_frames, faces, truth, lm)})  # fmt: skip
        print(f"subject {index} {acquisition}: {rows[-2]}\n  {rows[-1]}", flush=True)
    return rows


def _table(rows: list[dict], keys: list[str], digits: dict, routes=("true endocardium", "tracked"),
           rings=("",)) -> list[str]:  # fmt: skip
    lines = []
    for acquisition in ACQUISITIONS:
        for route in routes:
            for ring in rings:
                sel = [r for r in rows if r["route"] == route and r["acquisition"] == acquisition]
                mean = {k: float(np.mean([r[ring + k] for r in sel])) for k in keys}
                cells = [f"{mean[k]:.{digits.get(k, 2)}f}" for k in keys]
                name = ring.rstrip(":") or route
                lines.append(f"| {acquisition} | {name} | " + " | ".join(cells) + " |")
    return lines


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=6)
    parser.add_argument("--frames", type=int, default=25)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    from joblib import Parallel, delayed

    load = os.getloadavg()[0]
    start = time.perf_counter()
    per_subject = Parallel(n_jobs=args.jobs)(
        delayed(run_subject)(i, args.subjects, args.frames) for i in range(args.subjects)
    )
    wall = time.perf_counter() - start
    rows = [r for subject in per_subject for r in subject]
    truth = [r for r in rows if r["route"] == "truth"]
    t = {
        k: float(np.mean([r[k] for r in truth]))
        for k in truth[0]
        if k not in ("route", "acquisition")
    }
    vertex = ["thickness_ed", "bias_ed", "thickening", *STRAINS, "rim"]
    segment = ["thickness_ed_segment", *(f"{n}_segment" for n in ("thickening", *STRAINS))]
    head = ("| acquisition | route | ED thickness (mm) | ED bias (mm) | peak thickening (mm) | "
            "peak radial (pp) | peak circumferential (pp) | peak longitudinal (pp) | rim |")  # fmt: skip
    lines = [
        "Per vertex, mean absolute error (bias: mean signed error of the ED thickness):", "",
        head, "|---|---|---|---|---|---|---|---|---|",
        f"| truth (mean) | | {t['thickness_ed']:.2f} | | {t['thickening']:.2f} | "
        f"{t['radial']:.1f} | {t['circumferential']:.1f} | {t['longitudinal']:.1f} | |",
        *_table(rows, vertex, {"rim": 3, **{s: 1 for s in STRAINS}}), "",
        "Per AHA segment (the peak of the segment's mean curve), mean absolute error over the "
        "17 segments:", "",
        "| acquisition | route | ED thickness (mm) | peak thickening (mm) | peak radial (pp) | "
        "peak circumferential (pp) | peak longitudinal (pp) |", "|---|---|---|---|---|---|---|",
        *_table(rows, segment, {f"{s}_segment": 1 for s in STRAINS}), "",
        "Tracked, per ring of the AHA model (per-vertex errors averaged over the ring's "
        "vertices; bias: mean signed error of the ED thickness):", "",
        "| acquisition | ring | ED thickness (mm) | ED bias (mm) | peak radial (pp) | "
        "peak circumferential (pp) | peak longitudinal (pp) |", "|---|---|---|---|---|---|---|",
        *_table(rows, ["thickness_ed", "bias_ed", *STRAINS], {s: 1 for s in STRAINS},
                routes=("tracked",), rings=tuple(f"{r}:" for r in RINGS)), "",
        "Tracked, per vertex: the strains of the true frames moved by one part of the "
        "tracking's error (along the true surface's normal, or along the wall):", "",
        "| acquisition | error kept | peak circumferential (pp) | peak longitudinal (pp) |",
        "|---|---|---|---|",
        *_table(rows, ["circumferential", "longitudinal"], {s: 1 for s in STRAINS}, routes=("tracked",),
                rings=("", "normal part:", "along the wall:")),
    ]  # fmt: skip
    sel = lambda route, key: np.mean([r[key] for r in rows if r["route"] == route])  # noqa: E731
    note = (
        f"{args.subjects} subjects of the whole-cycle cohort (1009 vertices, "
        f"{sum(make_two_group_cycles(n_subjects=args.subjects, n_frames=3).patients)} with the "
        f"hypokinesia), {args.frames} frames, the true valve planes; pp: percentage points of "
        f"strain. Times per subject and acquisition on one core ({args.jobs} subjects at a "
        f"time, load {load:.2f} at the start): the epicardium's meshing "
        f"{sel('true endocardium', 'epi_meshing'):.1f} s and, tracked, its meshing and "
        f"tracking {sel('tracked', 'epi_tracking'):.1f} s; the maps "
        f"{sel('true endocardium', 'maps_seconds'):.2f} s; the truth "
        f"{t['truth_seconds']:.0f} s; {wall:.0f} s in all."
    )
    table = note + "\n\n" + "\n".join(lines)
    print(machine())
    print(table)
    if args.publish:
        command = (
            f"python benchmarks/bench_wall.py --subjects {args.subjects} --frames {args.frames}"
        )
        print(f"written {publish('wall_errors', table, command)}")


if __name__ == "__main__":
    main()
