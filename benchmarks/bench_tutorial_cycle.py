"""Run the whole-cycle tutorial's commands as a user types them, and time each one.

    python benchmarks/bench_tutorial_cycle.py              # in symladders-output/tutorial_cycle
    python benchmarks/bench_tutorial_cycle.py --publish    # docs/generated/tutorial_cycle.md

The commands are :data:`COMMANDS`, the single source of the tutorial's command block
(``docs/tutorial_cycle.md`` shows the published table, which lists them in order with
their run times and the last line each printed). Each runs in a shell (``bash -c``)
from the work folder; a command that fails stops the run with its output.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

#: The tutorial, in order: (what it does, the command).
COMMANDS = (
    ("a synthetic cohort through the cycle: 4-D label series, groups, covariates (the "
     "patients older and larger), ED landmarks, truth",
     "symladders cohort --cycle 25 --subjects 12 --imbalance 0.5 --landmarks -o cohort"),
    ("mesh the ED and ES frames (ES is frame 9 of 25, cohort/cycle.json)",
     "symladders mesh cohort/images/*.nii.gz --label 1 --frames 0,9 -o meshes --no-progress"),
    ("put every ED mesh in the atlas's vertex correspondence",
     "symladders correspond --atlas cohort/atlas.vtk --meshes meshes "
     "--landmarks cohort/landmarks.csv -o corresponded --no-progress"),
    ("follow each ED mesh through its 25 frames, the base's height from the valve planes",
     "symladders track corresponded cohort/images --label 1 --refine-ed "
     "--cut-planes cohort/valve_planes.csv -o tracked --no-progress"),
    ("transport every frame's motion to the atlas (pole ladder)",
     "symladders cycle-study tracked --atlas cohort/atlas.vtk --alpha2 100 -o cycle_study "
     "--no-progress"),
    ("test the groups per frame, on the peak, on the time to peak and on the whole "
     "trajectory, without the apical cap (AHA segment 17) that 8 mm slices resolve poorly",
     "symladders cycle-analyze cycle_study --groups cohort/groups.csv "
     "--compare patients,controls --tfce --aha cohort/landmarks.csv --exclude-segments 17 "
     "--no-progress"),
    ("the same tests adjusted for age, sex and body size, and the effect of age",
     "symladders cycle-analyze cycle_study --design cohort/design.csv "
     "--model 'group + age + sex + body_size' "
     "--contrast 'group[patients] - group[controls]' age --tfce --aha cohort/landmarks.csv "
     "--exclude-segments 17 --no-progress -o cycle_study/adjusted"),
)  # fmt: skip


def run(work: Path) -> list[tuple[str, str, float, str]]:
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    rows = []
    for what, command in COMMANDS:
        start = time.perf_counter()
        done = subprocess.run(["bash", "-c", command], cwd=work, capture_output=True, text=True)
        seconds = time.perf_counter() - start
        if done.returncode != 0:
            raise SystemExit(f"{command}: exit {done.returncode}\n{done.stdout}\n{done.stderr}")
        lines = [line for line in done.stdout.splitlines() if line.strip()]
        rows.append((what, command, seconds, lines[-1] if lines else ""))
        print(f"{seconds:7.1f} s  {command}\n          {rows[-1][3]}", flush=True)
    return rows


def far_vertices(work: Path, threshold: float = 3.0, band: float = 0.1) -> tuple[int, int, int]:
    """Where the correspondence's Hausdorff flags come from: of the input meshes' vertices
    farther than ``threshold`` from their corresponded atlas (those within its rim, as the
    quality table counts them), how many lie in the apical and in the basal ``band`` of the
    atlas's height; returns (all, apical, basal)."""
    from ladders.study.meshes import read_mesh
    from ladders.study.preparation.alignment import SimilarityTransform
    from ladders.study.preparation.surface_distance import on_rim
    from ladders.study.surface_queries import closest_points

    counts = np.zeros(3, dtype=int)
    for record in sorted((work / "corresponded" / "correspondence").glob("*.json")):
        transform = SimilarityTransform.from_dict(json.loads(record.read_text())["transform"])
        for phase in ("ed", "es"):
            v, f = read_mesh(work / "meshes" / f"{record.stem}_{phase}.vtk")
            cv, cf = read_mesh(work / "corresponded" / f"{record.stem}_{phase}.vtk")
            moved = transform.apply(v)
            closest, distance, _ = closest_points(moved, cv, cf)
            far = (distance > threshold) & ~on_rim(closest, cv, cf)
            low, high = cv[:, 2].min(), cv[:, 2].max()
            z = moved[far, 2]
            counts += [far.sum(), (z < low + band * (high - low)).sum(),
                       (z > high - band * (high - low)).sum()]  # fmt: skip
    return tuple(int(c) for c in counts)


def _table(rows, far=None) -> str:
    total = sum(r[2] for r in rows)
    lines = ["| step | command | time (s) | its last line of output |", "|---|---|---|---|"]
    for i, (what, command, seconds, last) in enumerate(rows, start=1):
        last = last.replace("|", "\\|")
        lines.append(f"| {i}. {what} | `{command}` | {seconds:.0f} | {last} |")
    note = (
        f"The tutorial's commands run in order in an empty folder, {total:.0f} s in all "
        "(12 subjects, 25 frames, 1,009 vertices, 2 jobs)."
    )
    if far is not None:
        note += (
            f" Of the meshes' vertices more than 3 mm from their corresponded atlas (within "
            f"its rim, as `quality.md` counts them; the flag `Hausdorff distance > 3`), {far[1]} "
            f"of {far[0]} lie in the apical tenth of the atlas's height and {far[2]} in the "
            "basal tenth."
        )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("symladders-output/tutorial_cycle"))
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    rows = run(args.work.resolve())
    table = _table(rows, far_vertices(args.work.resolve()))
    print("\n" + table)
    if args.publish:
        publish("tutorial_cycle", table, "python benchmarks/bench_tutorial_cycle.py --publish")


if __name__ == "__main__":
    main()
