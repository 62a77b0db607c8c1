"""Motion through the whole cycle from label series, against the truth (``symladders track``).

    python benchmarks/bench_tracking.py [--subjects 4] [--frames 25] [--jobs 2] [--publish]

For the first subjects of the synthetic cohort (241 vertices), the label series of
the whole cycle (``--frames`` frames, end-systole at 35 % of the cycle) is rendered
from the known motion (:func:`ladders.study.imaging.render_labels`) at two
acquisitions, a short-axis stack of 1.5 x 1.5 x 8 mm voxels and 1.5 mm isotropic
voxels; every frame is meshed as ``symladders mesh`` does, cut at its true valve
plane, and the subject's true ED surface (in correspondence with its own truth) is
tracked through the frames (:func:`ladders.study.tracking.track_surfaces`) by each
method, with and without ``refine_ed``. Against the true moved vertices
(:func:`ladders.study.cohort.motion_forward`), means over the subjects:

* at end-systole, the mean per-vertex error along the true normals (what a surface
  shows) and along the wall (tangential: what it does not show);
* the twist at end-systole: the rotation about the long axis of the apical third of
  the vertices minus that of the basal third (degrees, rotations of vertices within
  5 mm of the axis left out), true and tracked, and the absolute error;
* the mean per-vertex error at the last frame (the drift of the chain);
* the time per subject (tracking only; meshing the frames is listed apart).
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

from ladders.study.cohort import cycle_fraction, make_synthetic_cohort, motion_forward  # noqa: E402
from ladders.study.imaging import (  # noqa: E402
    LabelImage,
    MeshingSettings,
    extract_surface,
    render_labels,
    short_axis_affine,
)
from ladders.study.tracking import TrackingSettings, track_surfaces  # noqa: E402
from ladders.study.wall_motion import outward_vertex_normals  # noqa: E402

ACQUISITIONS = {"SAX 1.5 x 1.5 x 8 mm": (1.5, 8.0), "iso 1.5 mm": (1.5, 1.5)}
METHODS = {
    "projection": TrackingSettings(refine_ed=False),
    "projection + refine_ed": TrackingSettings(refine_ed=True),
    "registration": TrackingSettings(method="registration", refine_ed=False),
    "registration + refine_ed": TrackingSettings(method="registration", refine_ed=True),
}


def _frames(params, ed, n_frames, in_plane, thickness):
    """Meshed frames (cut at the true valve plane), true vertices, the time spent meshing."""
    low, high = ed.min(0) - np.array([15.0, 15.0, 15.0]), ed.max(0) + np.array([15.0, 15.0, 8.0])
    spacing = np.array([in_plane, in_plane, thickness])
    shape = tuple(int(n) for n in np.ceil((high - low) / spacing))
    affine = short_axis_affine(low, in_plane, thickness)
    fractions = [float(cycle_fraction(t / n_frames)) for t in range(n_frames)]
    truth = [motion_forward(params, ed, f) for f in fractions]
    surfaces, meshing = [], 0.0
    for t, f in enumerate(fractions):
        labels = render_labels(params, affine, shape, f)
        start = time.perf_counter()
        plane = (0.0, 0.0, float(truth[t][:, 2].max()), 0.0, 0.0, 1.0)
        image = LabelImage(labels.astype(np.int64), affine, Path(f"frame_{t}"), t)
        v, fa, _ = extract_surface(image, 1, MeshingSettings(cut_plane=plane))
        meshing += time.perf_counter() - start
        surfaces.append((v, fa))
    return surfaces, truth, fractions, meshing


def _rotation(before, after):
    """Rotation about the long axis (z) of every vertex, degrees (NaN within 5 mm of it)."""
    angle = np.degrees(
        np.arctan2(after[:, 1], after[:, 0]) - np.arctan2(before[:, 1], before[:, 0])
    )
    angle = (angle + 180.0) % 360.0 - 180.0
    return np.where(np.hypot(before[:, 0], before[:, 1]) > 5.0, angle, np.nan)


def _twist(ed, before, after):
    rotation = _rotation(before, after)
    apical, basal = (
        ed[:, 2] <= np.quantile(ed[:, 2], 1 / 3),
        ed[:, 2] >= np.quantile(ed[:, 2], 2 / 3),
    )
    return np.nanmean(rotation[apical]) - np.nanmean(rotation[basal])


def _measure(ed, faces, tracked, truth, fractions) -> dict:
    es = int(np.argmax(fractions))
    error = tracked[es] - truth[es]
    normals = outward_vertex_normals(truth[es], faces)
    normal = np.einsum("kd,kd->k", error, normals)
    tangential = np.linalg.norm(error - normal[:, None] * normals, axis=1)
    true_twist, twist = _twist(ed, ed, truth[es]), _twist(ed, ed, tracked[es])
    return {
        "normal": np.abs(normal).mean(),
        "tangential": tangential.mean(),
        "true_twist": true_twist,
        "twist": twist,
        "twist_error": abs(twist - true_twist),
        "last": np.linalg.norm(tracked[-1] - truth[-1], axis=1).mean(),
    }


def run_subject(index: int, n_frames: int, methods: list[str]) -> list[dict]:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    cohort = make_synthetic_cohort(index + 1, n_vertices=241)
    subject = cohort.subjects[index]
    ed, faces = np.asarray(subject.ed, float), cohort.faces
    rows = []
    for acquisition, (in_plane, thickness) in ACQUISITIONS.items():
        surfaces, truth, fractions, meshing = _frames(subject.parameters, ed, n_frames, in_plane,
                                                      thickness)  # fmt: skip
        for method in methods:
            start = time.perf_counter()
            out = track_surfaces(ed, faces, surfaces, METHODS[method])
            seconds = time.perf_counter() - start
            rows.append({"acquisition": acquisition, "method": method, "seconds": seconds,
                         "meshing": meshing, **_measure(ed, faces, out.vertices, truth, fractions)})  # fmt: skip
            print(f"subject {index} {acquisition} {method}: {rows[-1]}", flush=True)
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=4)
    parser.add_argument("--frames", type=int, default=25)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--methods", default=",".join(METHODS),
                        help=f"comma-separated, among: {', '.join(METHODS)}")  # fmt: skip
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        parser.error(f"--methods: unknown {unknown}")
    from joblib import Parallel, delayed

    per_subject = Parallel(n_jobs=args.jobs)(
        delayed(run_subject)(i, args.frames, methods) for i in range(args.subjects)
    )
    rows = [r for subject in per_subject for r in subject]
    lines = [
        "| acquisition | method | ES normal error (mm) | ES tangential error (mm) | true twist (deg) "
        "| tracked twist (deg) | twist error (deg) | last-frame error (mm) | tracking (s / subject) "
        "| meshing (s / subject) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for acquisition in ACQUISITIONS:
        for method in methods:
            sel = [r for r in rows if r["acquisition"] == acquisition and r["method"] == method]
            mean = {
                k: float(np.mean([r[k] for r in sel]))
                for k in sel[0]
                if k not in ("acquisition", "method")
            }
            lines.append(
                f"| {acquisition} | {method} | {mean['normal']:.2f} | {mean['tangential']:.2f} | "
                f"{mean['true_twist']:.1f} | {mean['twist']:.1f} | {mean['twist_error']:.1f} | "
                f"{mean['last']:.2f} | {mean['seconds']:.0f} | {mean['meshing']:.0f} |"
            )
    note = (
        f"{args.subjects} synthetic subjects (241 vertices), {args.frames} frames of the whole "
        f"cycle, each frame meshed and cut at its true valve plane; means over the subjects; "
        f"{args.jobs} subjects at a time."
    )
    print(machine())
    table = note + "\n\n" + "\n".join(lines)
    print(table)
    if args.publish:
        command = (
            f"python benchmarks/bench_tracking.py --subjects {args.subjects} --frames {args.frames}"
        )
        if args.methods != ",".join(METHODS):
            command += f" --methods '{args.methods}'"
        path = publish("tracking_labels", table, command)
        print(f"written {path}")


if __name__ == "__main__":
    main()
