"""The one command at population scale: seconds per subject per step and memory per worker.

    python benchmarks/bench_route_scale.py [--subjects 200] [--series 40] [--frames 25]
                                           [--workers 2] [--work DIR] [--publish]

A whole-cycle synthetic cohort (``make_two_group_cycles``) is written as a user holds
it (``write_image_cohort``: short-axis label stacks of 1.5 x 1.5 x 8 mm with a
right-ventricle label, ``subjects.csv``, ``study.toml``): ``--series`` subjects as
4-D series of ``--frames`` frames (tracked through the cycle), the others as their ED
and ES images. ``symladders run study.toml`` runs it as written, with
``execution.backend = "dask"`` on a Dask ``LocalCluster`` of ``--workers`` worker
processes (one thread each) started here. Before every step the workers' peak resident
memory is reset (Linux ``/proc/self/clear_refs``), after it it is read (``VmHWM``), so
that each step's peak per worker is its own; the route's own process (which runs the
analysis) is measured too (its peak since it started).

Per step: its wall time, the subjects it handled, seconds per subject (wall) and
core-seconds per subject (wall x workers), the peak memory per worker and of the
route's process. The last line extrapolates the ED/ES route (every step but the
tracking and the cycle's) to 1,000 subjects on the same cores: the per-subject steps
scale with the subjects, the atlas is estimated from a subset of fixed size
(``atlas.subset``) and is counted as measured.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from generated_tables import machine, publish  # noqa: E402

from ladders.study.cli import main as symladders  # noqa: E402
from ladders.study.population import make_two_group_cycles  # noqa: E402
from ladders.study.population.image_cohort import write_image_cohort  # noqa: E402
from ladders.study.route import run_route  # noqa: E402

#: The steps of the ED/ES route (the tracking and the cycle's are not).
ED_ES_STEPS = ("mesh", "atlas", "correspond", "study", "analysis", "report")


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _output(argv) -> str:
    """A step's output folder (``-o``): its key (two steps may run one program)."""
    argv = [str(a) for a in argv]
    return argv[argv.index("-o") + 1] if "-o" in argv else " ".join(argv)


def _reset_peak() -> bool:
    """Reset this process's peak resident set (Linux: ``clear_refs`` 5); False elsewhere."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
        return True
    except OSError:
        return False


def _resident_peak_mb() -> float:
    """This process's peak resident set since the last reset (``VmHWM``), in MB."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return _peak_mb()


def _cohort(folder: Path, n: int, n_series: int, n_frames: int, seed: int) -> Path:
    cycles = make_two_group_cycles(n, n_frames=n_frames, seed=seed)
    write_image_cohort(cycles, folder, n_series=n_series)
    settings = folder / "study.toml"
    text = settings.read_text(encoding="utf-8")
    settings.write_text(text + '\n[execution]\nbackend = "dask"\n', encoding="utf-8")
    return settings


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=200)
    parser.add_argument("--series", type=int, default=40)
    parser.add_argument("--frames", type=int, default=25)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--work", type=Path, default=None)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    from dask.distributed import Client, LocalCluster

    with tempfile.TemporaryDirectory() as scratch:
        work = args.work or Path(scratch)
        settings = work / "study.toml"
        if not settings.is_file():
            start = time.perf_counter()
            _cohort(work, args.subjects, args.series, args.frames, args.seed)
            print(f"cohort written in {time.perf_counter() - start:.0f} s", flush=True)
        cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True)
        client = Client(cluster)
        measured = {}

        def execute(argv):
            client.run(_reset_peak)
            main_before = _peak_mb()
            start = time.perf_counter()
            status = symladders(argv)
            seconds = time.perf_counter() - start
            peaks = client.run(_resident_peak_mb)
            measured[_output(argv)] = {
                "seconds": seconds, "load": os.getloadavg()[0],
                "worker_mb": max(peaks.values()),
                "main_mb": max(_peak_mb(), main_before),
            }  # fmt: skip
            return status

        try:
            outcome = run_route(settings, execute, scheduler=cluster.scheduler_address,
                                echo=lambda line: print(line, flush=True))  # fmt: skip
        finally:
            client.close()
            cluster.close()
        record = json.loads((Path(outcome.settings.output) / "run.json").read_text())
    counts = {"mesh": args.subjects, "atlas": min(args.subjects, 50), "correspond": args.subjects,
              "track": args.series, "study": args.subjects, "analyze": args.subjects,
              "cycle-study": args.series, "cycle-analyze": args.series, "wall": args.series,
              "wall-analysis": args.series}  # fmt: skip
    lines = [
        f"{args.subjects} subjects of the whole-cycle cohort as short-axis label stacks (1.5 x "
        f"1.5 x 8 mm, RV label), {args.series} of them as {args.frames}-frame series; "
        f'`symladders run study.toml` with `backend = "dask"` on a LocalCluster of '
        f"{args.workers} single-threaded workers ({machine()}). Peak memory: the largest "
        "resident set of a worker during the step (reset before each step), and "
        "of the route's own process.",
        "",
        "| step | subjects | wall time | s per subject | core-s per subject | peak per worker "
        "| route process | load |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    total_ed_es = 0.0
    per_subject_ed_es = 0.0
    for step in outcome.steps:
        if step.argv is None or _output(step.argv) not in measured:
            continue
        m = measured[_output(step.argv)]
        n = counts.get(step.name, counts.get(step.program, args.subjects))
        lines.append(
            f"| {step.name} | {n} | {m['seconds']:.0f} s | {m['seconds'] / n:.2f} | "
            f"{m['seconds'] * args.workers / n:.2f} | {m['worker_mb']:.0f} MB | "
            f"{m['main_mb']:.0f} MB | {m['load']:.1f} |"
        )
        if step.name in ED_ES_STEPS:
            total_ed_es += m["seconds"]
            if step.name != "atlas":
                per_subject_ed_es += m["seconds"] / n
    atlas = next((measured[_output(s.argv)]["seconds"] for s in outcome.steps
                  if s.name == "atlas" and _output(s.argv) in measured), 0.0)  # fmt: skip
    projected = atlas + 1000 * per_subject_ed_es
    lines += ["", f"The ED/ES route took {total_ed_es / 60:.1f} min for {args.subjects} subjects; "
              f"extrapolated to 1,000 subjects (the atlas from its subset as measured, the other "
              f"steps per subject): {projected / 60:.0f} min on these {args.workers} workers."]  # fmt: skip
    table = "\n".join(lines)
    print(table)
    print(json.dumps(record["steps"], indent=1))
    if args.publish:
        publish("route_scale", table, "python benchmarks/bench_route_scale.py --publish")


if __name__ == "__main__":
    main()
