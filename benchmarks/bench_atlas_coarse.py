"""The atlas's registrations coarse to fine against directly: its objective over the iterations.

    python benchmarks/bench_atlas_coarse.py [--subjects 20] [--iterations 6] [--factors 1,3]
                                            [--work DIR] [--jobs 2] [--publish]

The cohort of ``bench_route.py`` (``make_covariate_cohort``, an age confound at imbalance
1, the planted hypokinesia, written as a user holds it: label images of 1.5 mm voxels
with a right-ventricle label) is meshed by the route's own ``mesh`` step (``symladders
run``, stopped before its atlas). The atlas of the first ``--subjects`` ED meshes is then
estimated by ``build_atlas`` with the defaults of ``symladders atlas`` (varifold term,
``sigma_w`` 5 mm, the landmark table, start at the first subject), ``--iterations``
iterations and ``tol`` 0, once per ``--factors`` value of ``atlas_coarse_factor`` (1: each
registration at ``sigma_w`` directly; 3: at 15 mm first, then at 5 mm from there).

Per factor and evaluation of the atlas (the start's, then one per iteration): the total
registration objective ``sum_i C_i`` (each ``C_i`` the narrow, 5 mm term's objective,
whatever the factor), the atlas's move, and the processor time of the registrations.
A Karcher iteration that lowers ``sum_i C_i`` is what a mean should do; a rise means the
registrations are not finding each subject's minimum.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_atlas_scale import first_inputs  # noqa: E402
from bench_route import _cohort  # noqa: E402
from generated_tables import machine, publish  # noqa: E402

from ladders.study.cli import main as symladders  # noqa: E402
from ladders.study.preparation import CorrespondenceSettings  # noqa: E402
from ladders.study.preparation.atlas_run import build_atlas  # noqa: E402
from ladders.study.preparation.landmarks import read_landmarks  # noqa: E402
from ladders.study.route import run_route  # noqa: E402


class _MeshesWritten(Exception):
    """Stops the route once its meshes are written."""


def meshes(work: Path, n: int, seed: int) -> Path:
    """The route's ``mesh`` step on the bench_route cohort of ``n`` subjects; its folder."""
    folder = work / "study_results" / "meshes"
    if (folder / "landmarks.csv").is_file():
        return folder
    settings = work / "study.toml"
    if not settings.is_file():
        _cohort(work, n, True, seed, 1.0)

    def execute(argv):
        if argv[0] != "mesh":
            raise _MeshesWritten
        return symladders([str(a) for a in argv])

    try:
        run_route(settings, execute, echo=lambda line: print(line, flush=True))
    except _MeshesWritten:
        pass
    return folder


def atlas(folder: Path, work: Path, n: int, factor: float, iterations: int, jobs: int) -> dict:
    """``build_atlas`` of the first ``n`` ED meshes with ``atlas_coarse_factor = factor``."""
    stored = work / "atlases" / f"factor_{factor:g}.json"
    if stored.is_file():
        return json.loads(stored.read_text())
    inputs = first_inputs(folder, n)
    table = read_landmarks(folder / "landmarks.csv")
    start = time.perf_counter()
    run = build_atlas(
        folder, work / "atlases" / f"factor_{factor:g}.vtk",
        CorrespondenceSettings(atlas_coarse_factor=factor), tol=0.0, max_iter=iterations,
        inputs=inputs, landmarks={k: table[k] for k in inputs.names}, subset=None, jobs=jobs,
        resume=False,
        progress=lambda it, obj, norm: print(f"  factor {factor:g}: evaluation {it}: "
                                             f"objective {obj:.6g}", flush=True),
    )  # fmt: skip
    r = run.record
    out = {"objectives": r["objectives"], "moves": r["moves"], "cpu_seconds": r["cpu_seconds"],
           "seconds": time.perf_counter() - start, "load": os.getloadavg()[0], "jobs": jobs}  # fmt: skip
    stored.write_text(json.dumps(out, indent=1))
    return out


def table(rows: dict, n: int, iterations: int) -> str:
    lines = [
        f"The atlas of the first {n} ED meshes of the `bench_route.py` cohort (label images, "
        "1.5 mm voxels, an age confound at imbalance 1), `symladders atlas` defaults (varifold "
        f"term, sigma_w 5 mm, landmarks, start at the first subject), {iterations} iterations, "
        f"tol 0 ({machine()}). Objective: `sum_i C_i` of the registrations onto the 5 mm term "
        "at each evaluation of the atlas, the start's first; move: per-vertex RMS of each "
        "iteration (mm).",
        "",
        "| registration | objective per evaluation | rises | moves (mm) | registrations' "
        "CPU per evaluation (s) | wall (s) | load |",
        "|---|---|---:|---|---:|---:|---:|",
    ]
    for factor, r in rows.items():
        obj = r["objectives"]
        rises = sum(b > a for a, b in zip(obj, obj[1:]))
        name = ("directly at 5 mm" if factor == 1 else
                f"coarse to fine: {5 * factor:g} mm, then 5 mm")  # fmt: skip
        cpu = sum(r["cpu_seconds"]) / len(r["cpu_seconds"])
        lines.append(
            f"| {name} | {' -> '.join(f'{o:,.0f}' for o in obj)} | {rises} | "
            f"{', '.join(f'{m:.2f}' for m in r['moves'])} | {cpu:.0f} | {r['seconds']:.0f} | "
            f"{r['load']:.1f} |"
        )
    return "\n".join(lines)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=20)
    parser.add_argument("--cohort", type=int, default=40, help="subjects written and meshed")
    parser.add_argument("--iterations", type=int, default=6)
    parser.add_argument("--factors", default="1,3")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--work", type=Path, default=None)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as scratch:
        work = args.work or Path(scratch)
        work.mkdir(parents=True, exist_ok=True)
        folder = meshes(work, args.cohort, args.seed)
        rows = {float(f): atlas(folder, work, args.subjects, float(f), args.iterations,
                                args.jobs) for f in args.factors.split(",")}  # fmt: skip
    text = table(rows, args.subjects, args.iterations)
    print(text)
    if args.publish:
        publish("atlas_coarse", text, "python benchmarks/bench_atlas_coarse.py --publish")


if __name__ == "__main__":
    main()
