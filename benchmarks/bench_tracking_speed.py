"""Speed of ``symladders track``: one subject of 25 frames at 1.5 x 1.5 x 8 mm, label and cine.

    python benchmarks/bench_tracking_speed.py [--work DIR] [--routes labels,cine] [--publish]

The whole-cycle cohort (:func:`~ladders.study.population.make_two_group_cycles`, seed 0,
25 frames, the default atlas) is written as short-axis series of 1.5 x 1.5 x 8 mm voxels,
as label images and as cine intensity images
(:func:`~ladders.study.population.write_cycle_cohort`). Each subject's true ED mesh (in the
atlas's correspondence, in the images' frame) is tracked through its series by
:func:`~ladders.study.tracking.track_cohort`, the function behind ``symladders track``:

* label series: every frame meshed, then projection with ``refine_ed`` (the
  command's ``--refine-ed``), timed for two subjects one after the other on one
  worker (time per subject on one core) and two at a time on the two cores
  (throughput per subject), without and with the cohort's true valve plane of every
  frame (``--cut-planes``: the affine fits anchored, the pairs at a rim left out);
* cine series: the B-spline registrations with the defaults of
  :class:`~ladders.study.tracking.CineTrackingSettings`, every frame registered to ED
  (the default ``reference="ed"``, two chains) and consecutive frames composed forward
  and backward (``reference="consecutive"``), each timed for one subject with one
  registration at a time and with two (``--registration-jobs 2``: the same result on
  the two cores).

The wall-clock time includes reading the series and writing the tracked meshes. The
label route's per-stage split is measured by a profile of one subject in
``bench_tracking.py``; the gain of the compiled surface queries over the previous
implementation is measured by ``bench_surface_queries.py``. The CPU is named.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.study.population import (  # noqa: E402
    cycle_valve_planes,
    make_two_group_cycles,
    write_cycle_cohort,
)
from ladders.study.tracking import CineTrackingSettings, TrackingSettings, track_cohort  # noqa: E402

TARGET = 60.0  # seconds for one subject of 25 frames on 2 cores


def _cohort(work: Path, kind: str, n_frames: int) -> Path:
    root = work / kind
    if not (root / "cycle.json").is_file():
        c = make_two_group_cycles(n_subjects=2, n_frames=n_frames)
        write_cycle_cohort(c, root, kind, 1.5, 8.0)
    return root


def _meshes(root: Path, subjects: list[str], folder: Path) -> Path:
    """A folder holding only the given subjects' true ED meshes."""
    folder.mkdir(parents=True, exist_ok=True)
    for s in subjects:
        shutil.copy(root / f"{s}_ed.vtk", folder / f"{s}_ed.vtk")
    return folder


def _timed(meshes, images, out, settings, jobs, cut_planes=None) -> tuple[float, int]:
    shutil.rmtree(out, ignore_errors=True)
    start = time.perf_counter()
    outcome = track_cohort(meshes, images, out, 1, settings, cut_planes=cut_planes, jobs=jobs,
                           progress=False)  # fmt: skip
    seconds = time.perf_counter() - start
    if outcome.failed:
        raise RuntimeError(f"tracking failed: {outcome.failed}")
    return seconds, len(outcome.records)


def run(work: Path, routes: list[str], n_frames: int) -> list[tuple[str, str, float]]:
    rows = []
    if "labels" in routes:
        root = _cohort(work, "labels", n_frames)
        subjects = sorted(p.stem[:-3] for p in root.glob("*_ed.vtk"))
        meshes = _meshes(root, subjects, work / "labels_ed")
        planes = cycle_valve_planes(make_two_group_cycles(n_subjects=2, n_frames=n_frames))
        for route, cut in (("label series, projection + refine_ed", None),
                           ("label series, projection + refine_ed + valve planes", planes)):  # fmt: skip
            for jobs, label in ((1, "one worker (1 core), per subject"),
                                (2, "two subjects at a time (2 cores), per subject")):  # fmt: skip
                settings = TrackingSettings(refine_ed=True, estimate_planes="never")
                seconds, n = _timed(meshes, root / "images", work / "labels_tracked", settings,
                                    jobs, cut)  # fmt: skip
                rows.append((route, label, seconds / n))
                print(rows[-1], flush=True)
    if "cine" in routes:
        root = _cohort(work, "cine", n_frames)
        subject = sorted(p.stem[:-3] for p in root.glob("*_ed.vtk"))[0]
        meshes = _meshes(root, [subject], work / "cine_ed")
        for reference, route in (("ed", "cine series, B-spline, every frame to ED (default)"),
                                 ("consecutive", "cine series, B-spline, consecutive frames "
                                                 "forward and backward")):  # fmt: skip
            for jobs in (1, 2):
                settings = CineTrackingSettings(jobs=jobs, reference=reference)
                seconds, _ = _timed(meshes, [root / "images" / f"{subject}.nii.gz"],
                                    work / "cine_tracked", settings, 1)  # fmt: skip
                rows.append((route, f"one subject, {jobs} registration{'s' * (jobs > 1)} at a "
                             f"time ({jobs} core{'s' * (jobs > 1)})", seconds))  # fmt: skip
                print(rows[-1], flush=True)
    return rows


def _table(rows, n_frames) -> str:
    lines = [
        "| route | how | seconds per subject | target |",
        "|---|---|---|---|",
    ]
    for route, how, seconds in rows:
        lines.append(f"| {route} | {how} | {seconds:.1f} | {TARGET:.0f} |")
    note = (
        f"One synthetic subject of {n_frames} frames at 1.5 x 1.5 x 8 mm (the default atlas), "
        "tracked by `track_cohort` (`symladders track`) from its true ED mesh; wall-clock "
        "time including reading the series and writing the meshes. Cine with every frame to "
        f"ED: the metric samples the voxels within {CineTrackingSettings().mask_distance:g} mm "
        "of the ED mesh (the default)."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("symladders-output/bench_tracking_speed"))
    parser.add_argument("--routes", default="labels,cine")
    parser.add_argument("--frames", type=int, default=25)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    routes = [r.strip() for r in args.routes.split(",") if r.strip()]
    if not routes or set(routes) - {"labels", "cine"}:
        parser.error(f"--routes: expected labels and/or cine, got {args.routes!r}")
    print(machine(), flush=True)
    table = _table(run(args.work, routes, args.frames), args.frames)
    print("\n" + table)
    if args.publish:
        command = "python benchmarks/bench_tracking_speed.py --publish"
        if args.routes != "labels,cine":
            command += f" --routes {args.routes}"
        publish("tracking_speed", table, command)


if __name__ == "__main__":
    main()
