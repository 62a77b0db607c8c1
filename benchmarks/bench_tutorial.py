"""What each step of the own-data tutorial costs: its commands, timed on synthetic label images.

    python benchmarks/bench_tutorial.py [--subjects 20] [--spacing 1.5] [--work DIR]

The command block of ``docs/tutorial_own_data.md`` (the one after the marker
``<!-- tutorial-commands -->``) is read from the page and run as written, one
command after the other, in a scratch folder that holds what the tutorial asks the
reader to bring:

* ``images/``: label images of a two-group synthetic cohort
  (``make_two_group_cohort``: the default hypokinesia in half the subjects), one
  NIfTI file per subject and frame (``case01_ed.nii.gz``, ``case01_es.nii.gz``),
  the cavity as label 1 and a right ventricle against the septum as label 2,
  isotropic voxels of ``--spacing`` mm, both frames of a subject on one grid;
* ``planes.csv``: each image's valve plane (the base plane of its frame);
* ``groups.csv``: ``subject,group``.

Each command's wall time is written to ``docs/generated/tutorial_times.md`` and
into the tutorial's marked region. ``tests/test_tutorial_own_data.py`` runs the
same block on a smaller cohort with speed options added.
"""

from __future__ import annotations

import argparse
import csv
import glob
import os
import re
import shlex
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from generated_tables import publish  # noqa: E402

TUTORIAL = ROOT / "docs" / "tutorial_own_data.md"
#: The marker the tutorial's command block follows.
MARKER = "<!-- tutorial-commands -->"

__all__ = ["tutorial_commands", "write_image_cohort", "run_command", "MARKER", "TUTORIAL"]


def tutorial_commands(path: Path = TUTORIAL) -> list[list[str]]:
    """The commands of the fenced block after :data:`MARKER`, each split as a shell would
    (comments dropped, ``\\`` continuations joined; globs are left for :func:`run_command`)."""
    text = Path(path).read_text(encoding="utf-8")
    match = re.search(re.escape(MARKER) + r"\s*\n```(?:bash|sh|console)?\n(.*?)^```", text,
                      flags=re.S | re.M)  # fmt: skip
    if match is None:
        raise ValueError(f"{path}: no fenced block after {MARKER}")
    joined = re.sub(r"\\\n", " ", match.group(1))
    commands = [shlex.split(line, comments=True) for line in joined.splitlines()]
    return [c for c in commands if c]


def _expand(arg: str, cwd: Path) -> list[str]:
    if not any(ch in arg for ch in "*?["):
        return [arg]
    found = sorted(glob.glob(arg, root_dir=cwd))
    if not found:
        raise FileNotFoundError(f"{arg}: no file matches in {cwd}")
    return found


def run_command(command: list[str], cwd: Path, extra: list[str] = ()) -> tuple[int, str, str]:
    """``symladders ...`` run from ``cwd`` as a shell would (a new process, globs expanded
    there), ``extra`` appended; exit status, standard output, standard error.

    A new process, not ``main()`` in this one: parallel workers started earlier in this
    process keep the working directory they were started in, so relative paths (as a
    user types them) would resolve elsewhere."""
    import subprocess

    if command[0] != "symladders":
        raise ValueError(f"not a symladders command: {shlex.join(command)}")
    argv = [a for arg in command[1:] for a in _expand(arg, cwd)] + [str(a) for a in extra]
    done = subprocess.run(
        [sys.executable, "-m", "ladders.study.cli", *argv], cwd=cwd, capture_output=True,
        text=True, check=False,
    )  # fmt: skip
    return done.returncode, done.stdout, done.stderr


def write_image_cohort(
    folder, n_subjects: int = 20, spacing: float = 1.5, n_vertices: int = 1009, seed: int = 0
):
    """Label images, ``planes.csv`` and ``groups.csv`` of a synthetic two-group cohort.

    Returns the :class:`~ladders.study.population.TwoGroupCohort` (its subjects renamed
    ``case01``, ... as the files are) and ``{old name: new name}``.
    """
    from ladders.study.imaging import add_rv_label, voxelize, write_label_image
    from ladders.study.population import make_two_group_cohort
    from ladders.study.preparation.synthetic_landmarks import synthetic_landmarks

    folder = Path(folder)
    images = folder / "images"
    data = make_two_group_cohort(n_subjects, n_vertices=n_vertices, seed=seed)
    names = {s.name: f"case{i + 1:02d}" for i, s in enumerate(data.cohort.subjects)}
    planes = []
    for s in data.cohort.subjects:
        both = np.vstack([s.ed, s.es])
        low = both.min(axis=0) - 22.0  # room for the right ventricle beside the septum
        shape = tuple(int(n) for n in np.ceil((both.max(axis=0) + 22.0 - low) / spacing))
        affine = np.diag([spacing, spacing, spacing, 1.0])
        affine[:3, 3] = low
        apex = synthetic_landmarks(s.ed).apex
        for phase in ("ed", "es"):
            v = getattr(s, phase)
            top = (0.0, 0.0, float(v[:, 2].max()))  # the valve plane of this frame, z up
            labels = voxelize(v, data.cohort.faces, affine, shape, label=1)
            labels = add_rv_label(labels, affine, apex, top, (-1.0, 0.0, 0.0), rv_label=2)
            name = f"{names[s.name]}_{phase}.nii.gz"
            write_label_image(images / name, labels, affine)
            planes.append((name, *top, 0.0, 0.0, 1.0))
    with open(folder / "planes.csv", "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(["image", "x", "y", "z", "nx", "ny", "nz"])
        writer.writerows([p[0], *(f"{x:.3f}" for x in p[1:])] for p in planes)
    with open(folder / "groups.csv", "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(["subject", "group"])
        writer.writerows((names[k], g) for k, g in data.groups.items())
    return data, names


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=20)
    parser.add_argument("--spacing", type=float, default=1.5, help="voxel size (mm)")
    parser.add_argument("--work", type=Path, default=None, help="scratch folder (default: temp)")
    parser.add_argument("--no-publish", action="store_true", help="print the table only")
    args = parser.parse_args(argv)
    commands = tutorial_commands()
    with tempfile.TemporaryDirectory() as scratch:
        work = args.work or Path(scratch)
        work.mkdir(parents=True, exist_ok=True)
        start = time.perf_counter()
        data, _ = write_image_cohort(work, args.subjects, args.spacing)
        n_patients = int(data.labels.sum())
        print(f"label images: {time.perf_counter() - start:.0f} s", flush=True)
        rows = []
        for command in commands:
            start = time.perf_counter()
            status, out, err = run_command(command, work, ["--no-progress"])
            seconds = time.perf_counter() - start
            load = os.getloadavg()[0]
            print(f"{' '.join(command)}: {seconds:.1f} s, exit {status}", flush=True)
            if status != 0:
                raise SystemExit(f"{' '.join(command)} failed ({status}):\n{out}\n{err}")
            rows.append((command, seconds, load))
    total = sum(r[1] for r in rows)
    lines = ["| step | command | wall time | machine load at its end |", "|---|---|---:|---:|"]
    for command, seconds, load in rows:
        lines.append(f"| {command[1]} | `{' '.join(command)}` | {seconds:.0f} s | {load:.1f} |")
    lines.append(f"| all | | {total:.0f} s | |")
    note = (
        f"The tutorial's commands as written (progress lines off), one after the other, on "
        f"{args.subjects} subjects ({n_patients} patients) of the synthetic two-group cohort "
        f"as label images: {args.spacing:g} mm isotropic voxels, LV label 1, RV label 2, two "
        "frames per subject. Machine load: the 1-minute load average of the whole machine "
        "(other processes included); above the core count, the times are longer than on an "
        "idle machine."
    )
    table = f"{note}\n\n" + "\n".join(lines)
    print(table)
    if not args.no_publish:
        publish("tutorial_times", table, "python benchmarks/bench_tutorial.py")


if __name__ == "__main__":
    main()
