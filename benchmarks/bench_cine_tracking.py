"""Cine tracking benchmark: the ED mesh followed through synthetic cine images by FFD registration.

For each of ``--n-subjects`` synthetic subjects (``make_synthetic_cohort``, 241
vertices), a cycle of ``--frames`` frames is rendered (:func:`render_cine`, Gaussian
noise 0.02, sub-voxel supersampling 2) on two grids, a short-axis stack of
1.5 x 1.5 x 8 mm slices and a 1.5 mm isotropic grid, with and without tagging lines
(:class:`TagGrid` defaults), and tracked by :func:`track_cine` with each
``--reference``: every frame registered to ED, or consecutive frames composed forward
and backward. End-systole is the frame ``round(0.35 n)``, the cycle's ES phase set
to that frame's time, so that the true ES mesh is ``motion_forward(params, ed, 1)``.

Reported per grid and tagging, over subjects: the mean per-vertex ES error split into
its part along the true ES surface's normal and its tangential part, the mean motion
(ES vs ED, the error of not moving at all), the twist error (apex minus base rotation
about the long axis, degrees) and the time per subject and per frame.

Usage: ``python benchmarks/bench_cine_tracking.py [--n-subjects 2] [--frames 25]
[--grids both|short-axis|isotropic] [--spacing 20] [--jobs 2] [--reference ed,consecutive]
[--publish]``
(``--spacing``: the control points' spacing, mm; ``--jobs``: registrations at a time);
``--publish`` writes ``docs/generated/tracking_cine.md`` (with the CPU).
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.study.cohort import cycle_fraction, make_synthetic_cohort, motion_forward  # noqa: E402
from ladders.study.imaging import TagGrid, render_cine  # noqa: E402
from ladders.study.tracking.cine_tracking import CineTrackingSettings, track_cine  # noqa: E402
from ladders.study.wall_motion import outward_vertex_normals  # noqa: E402
from ladders.study.wall_rotation import twist_angle  # noqa: E402

GRIDS = {"short-axis 1.5 x 1.5 x 8 mm": (1.5, 1.5, 8.0), "isotropic 1.5 mm": (1.5, 1.5, 1.5)}
SETTINGS = CineTrackingSettings(control_point_spacing=20.0, sampling_percentage=0.05, iterations=20)


def grid(voxel):
    lo, hi = np.array([-50.0, -50.0, -16.0]), np.array([50.0, 50.0, 92.0])
    shape = tuple(int(n) for n in np.ceil((hi - lo) / np.asarray(voxel)) + 1)
    affine = np.eye(4)
    affine[:3, :3] = np.diag(voxel)
    affine[:3, 3] = lo
    return affine, shape


def twist(params, ed, es):
    """Apical minus basal rotation (degrees, counter-clockwise seen from the apex) of a
    subject in its own frame (apex at the origin, base-plane centre at ``z = c``)."""
    return twist_angle(ed, es, np.zeros(3), np.array([0.0, 0.0, params.long_axis]))


def split_error(moved, truth, faces) -> tuple[float, float]:
    """Mean error of ``moved`` against ``truth`` (k, 3) along the true normals and across."""
    error = moved - truth
    n = outward_vertex_normals(truth, faces)
    along = np.einsum("ij,ij->i", error, n)
    return float(np.abs(along).mean()), float(
        np.linalg.norm(error - along[:, None] * n, axis=1).mean()
    )


def run(n_subjects: int, n_frames: int, settings=SETTINGS, grids=tuple(GRIDS)):
    cohort = make_synthetic_cohort(n_subjects, n_vertices=241, seed=0)
    es_frame = int(round(0.35 * n_frames))
    fractions = cycle_fraction(np.arange(n_frames) / n_frames, es_frame / n_frames)
    rows = []
    for grid_name in grids:
        voxel = GRIDS[grid_name]
        affine, shape = grid(voxel)
        for tagging in (TagGrid(), None):
            out = {"normal": [], "tangential": [], "motion": [], "twist": [], "seconds": []}
            for i, subject in enumerate(cohort.subjects):
                params, ed = subject.parameters, subject.ed
                rng = np.random.default_rng(100 + i)
                series = np.stack(
                    [render_cine(params, affine, shape, f, rng, noise=0.02, tagging=tagging,
                                 supersample=2) for f in fractions]
                )  # fmt: skip
                start = time.perf_counter()
                tracked = track_cine(series, affine, ed, settings)
                out["seconds"].append(time.perf_counter() - start)
                truth = motion_forward(params, ed, fractions[es_frame])
                normal, tangential = split_error(tracked[es_frame], truth, cohort.faces)
                out["normal"].append(normal)
                out["tangential"].append(tangential)
                out["motion"].append(np.linalg.norm(truth - ed, axis=1).mean())
                out["twist"].append(
                    abs(twist(params, ed, tracked[es_frame]) - twist(params, ed, truth))
                )
                print(grid_name, "tagged" if tagging else "plain", subject.name,
                      {k: round(v[-1], 3) for k, v in out.items()}, flush=True)  # fmt: skip
            rows.append(
                (
                    grid_name,
                    tagging is not None,
                    shape,
                    {k: float(np.mean(v)) for k, v in out.items()},
                )
            )
    return rows, es_frame


def table(rows, n_subjects, n_frames, es_frame, settings=SETTINGS) -> str:
    lines = [
        f"{n_subjects} synthetic subject(s), {n_frames} frames (ES = frame {es_frame}), "
        f"{settings.metric}, "
        f"{settings.optimizer}, {settings.iterations} iterations per level, shrink "
        f"{settings.shrink_factors}, sampling {settings.sampling_percentage:g}, "
        f"combine={settings.combine}, {settings.threads} thread(s), {settings.jobs} "
        "registration(s) at a time. Reference `ed`: every frame registered to ED, started "
        "from its neighbour's fit (two chains, to mid-cycle and back from the last frame), "
        f"the metric sampling the voxels within {settings.mask_distance:g} mm of an ED vertex; "
        "`consecutive`: consecutive frames registered and composed forward and backward (UK "
        "Biobank). Errors at ES, mean over vertices and subjects, mm.",
        "",
        "| reference | control points (mm) | grid | voxels | tagging | normal error | tangential "
        "error | motion (no tracking) | twist error (deg) | s / subject | s / frame |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for reference, spacing, grid_name, tagged, shape, m in rows:
        lines.append(
            f"| {reference} | {spacing:g} | {grid_name} | {'x'.join(map(str, shape))} | "
            f"{'yes' if tagged else 'no'} | "
            f"{m['normal']:.2f} | {m['tangential']:.2f} | {m['motion']:.2f} | {m['twist']:.2f} | "
            f"{m['seconds']:.1f} | {m['seconds'] / n_frames:.2f} |"
        )
    return "\n".join(lines) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-subjects", type=int, default=2)
    parser.add_argument("--frames", type=int, default=25)
    parser.add_argument(
        "--grids", choices=("both", "short-axis", "isotropic"), default="both",
        help="the grids to run (default both)",
    )  # fmt: skip
    parser.add_argument("--publish", action="store_true")
    parser.add_argument("--spacing", default=f"{SETTINGS.control_point_spacing:g}",
                        help="control point spacings, mm, comma-separated")  # fmt: skip
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument(
        "--reference",
        default="ed,consecutive",
        help="what frames are registered to, comma-separated (ed, consecutive)",
    )
    args = parser.parse_args(argv)
    grids = [g for g in GRIDS if args.grids == "both" or g.startswith(args.grids)]
    rows, sets = [], []
    for reference in args.reference.split(","):
        for spacing in (float(x) for x in args.spacing.split(",")):
            settings = replace(SETTINGS, control_point_spacing=spacing, jobs=args.jobs,
                               reference=reference)  # fmt: skip
            got, es_frame = run(args.n_subjects, args.frames, settings, grids=grids)
            rows += [(reference, spacing, *r) for r in got]
            sets.append(settings)
    text = table(rows, args.n_subjects, args.frames, es_frame, sets[0])
    print(machine())
    print(text)
    if args.publish:
        command = "python benchmarks/bench_cine_tracking.py"
        command += f" --n-subjects {args.n_subjects} --frames {args.frames}"
        command += f" --grids {args.grids} --spacing {args.spacing} --jobs {args.jobs}"
        command += f" --reference {args.reference} --publish"
        print(publish("tracking_cine", text, command))


if __name__ == "__main__":
    main()
