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
import shutil
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

#: The tutorial, in order: (what it does, the command).
COMMANDS = (
    ("a synthetic cohort through the cycle: 4-D label series, groups, ED landmarks, truth",
     "symladders cohort --cycle 25 --subjects 12 --landmarks -o cohort"),
    ("mesh the ED and ES frames (ES is frame 9 of 25, cohort/cycle.json)",
     "symladders mesh cohort/images/*.nii.gz --label 1 --frames 0,9 -o meshes --no-progress"),
    ("put every ED mesh in the atlas's vertex correspondence",
     "symladders correspond --atlas cohort/atlas.vtk --meshes meshes "
     "--landmarks cohort/landmarks.csv -o corresponded --no-progress"),
    ("follow each ED mesh through its 25 frames",
     "symladders track corresponded cohort/images --label 1 --refine-ed -o tracked "
     "--no-progress"),
    ("transport every frame's motion to the atlas (pole ladder)",
     "symladders cycle-study tracked --atlas cohort/atlas.vtk --alpha2 100 -o cycle_study "
     "--no-progress"),
    ("test the groups per frame, on the peak and on the time to peak, without the apical "
     "cap (AHA segment 17) that 8 mm slices resolve poorly",
     "symladders cycle-analyze cycle_study --groups cohort/groups.csv "
     "--compare patients controls --tfce --aha cohort/landmarks.csv --exclude-segments 17"),
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


def _table(rows) -> str:
    total = sum(r[2] for r in rows)
    lines = ["| step | command | time (s) | its last line of output |", "|---|---|---|---|"]
    for i, (what, command, seconds, last) in enumerate(rows, start=1):
        last = last.replace("|", "\\|")
        lines.append(f"| {i}. {what} | `{command}` | {seconds:.0f} | {last} |")
    note = (
        f"The tutorial's commands run in order in an empty folder, {total:.0f} s in all "
        "(12 subjects, 25 frames, 1,009 vertices, 2 jobs)."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("symladders-output/tutorial_cycle"))
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    table = _table(run(args.work.resolve()))
    print("\n" + table)
    if args.publish:
        publish("tutorial_cycle", table, "python benchmarks/bench_tutorial_cycle.py --publish")


if __name__ == "__main__":
    main()
