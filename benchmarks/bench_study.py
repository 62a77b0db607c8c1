"""Wall time of the study (paper, Section 3) on the built-in cohort.

Runs ``symladders study`` in a subprocess for the default setting and, with
``--full``, the paper's setting (138 subjects, 7 values of alpha^2, both
variants), each into a fresh temporary folder, and prints wall time, peak memory
of the parent process tree's largest member, the number of registrations, the
mean optimiser iterations per registration, the fraction that met the
optimiser's tolerance and the targets (default <= 5 min, full <= 30 min on 2
cores). ``--deformation both`` runs the LDDMM and the SVF studies (targets doubled).

``--keep DIR`` writes the study into ``DIR`` (kept, with its tables and figures)
instead of a temporary folder; the folder must not hold results of the same
settings, or they would be reused.

``--publish`` writes each setting's row into a table of one row per CPU
(``generated_tables.publish_rows``): ``docs/generated/study_<deformation>.md`` for the
default setting, ``study_<deformation>_full.md`` for the full one. A run replaces the
row of its CPU (model and SIMD level) and keeps the others; the row records the
1-minute load average at the start of the run, since other jobs may share the CPU.
A table published before it kept one row per CPU becomes the first stored row.

Usage: ``python benchmarks/bench_study.py [--full] [--deformation lddmm|svf|both]
[--kernel-backend numpy|numba|auto] [--keep DIR] [--publish] [-- extra study flags]``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGETS_S = {"default": 300.0, "full": 1800.0}
HEADER = ["load", "subjects x alpha^2", "wall time", "per subject", "registrations",
          "iterations / flow passes each", "converged", "peak RSS", "target"]  # fmt: skip


def _manifests(folder: Path) -> list[dict]:
    both = [folder / m / "manifest.json" for m in ("lddmm", "svf")]
    paths = both if both[0].exists() else [folder / "manifest.json"]
    return [json.loads(p.read_text()) for p in paths]


def run(setting, backend, jobs, deformation, extra, keep=None) -> dict:
    with tempfile.TemporaryDirectory() as scratch:
        tmp = str(keep / setting) if keep is not None else scratch
        args = [
            sys.executable,
            "-m",
            "ladders.study.cli",
            "study",
            "--output",
            tmp,
            "--no-progress",
        ]
        args += ["--kernel-backend", backend, "--jobs", str(jobs), "--no-meshes"]
        args += ["--deformation", deformation, *extra]
        if setting == "full":
            args.append("--full")
        load = os.getloadavg()[0]
        start = time.perf_counter()
        proc = subprocess.run(args, capture_output=True, text=True)
        seconds = time.perf_counter() - start
        if proc.returncode != 0:
            raise RuntimeError(proc.stderr[-3000:])
        manifests = _manifests(Path(tmp))
    peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    total = lambda key: sum(m[key] for m in manifests)  # noqa: E731
    return {
        "setting": setting,
        "load": load,
        "seconds": seconds,
        "subjects": manifests[0]["n_subjects"],
        "alpha2": manifests[0]["config"]["alpha2"],
        "registrations": total("registrations"),
        "non_converged": total("non_converged_registrations"),
        "iterations": total("optimiser_iterations"),
        "flow_passes": total("flow_evaluations"),
        "peak_rss_mb": peak_mb,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true", help="also run the paper's full setting")
    parser.add_argument("--kernel-backend", default="auto", choices=("auto", "numpy", "numba"))
    parser.add_argument("--jobs", type=int, default=-1)
    parser.add_argument("--deformation", default="lddmm", choices=("lddmm", "svf", "both"))
    parser.add_argument("--keep", type=Path, default=None, help="keep the study in this folder")
    parser.add_argument("--publish", action="store_true",
                        help="write the table to docs/generated (README and docs include it)")  # fmt: skip
    parser.add_argument("extra", nargs="*", help="further flags of symladders study (after --)")
    args = parser.parse_args(argv)
    rows = {}
    settings = ["default", "full"] if args.full else ["default"]
    print(f"kernel backend: {args.kernel_backend}, jobs: {args.jobs}, {args.deformation}")
    for setting in settings:
        r = run(setting, args.kernel_backend, args.jobs, args.deformation, args.extra, args.keep)
        target = TARGETS_S[setting] * (2 if args.deformation == "both" else 1)
        met = "met" if r["seconds"] <= target else "NOT met"
        print(
            f"{setting:8s} {r['subjects']:4d} subjects x {len(r['alpha2'])} alpha^2: "
            f"{r['seconds']:8.1f} s wall ({r['seconds'] / r['subjects']:.2f} s/subject), "
            f"{r['registrations']} registrations, "
            f"{r['iterations'] / max(r['registrations'], 1):.0f} iterations and "
            f"{r['flow_passes'] / max(r['registrations'], 1):.0f} flow passes each on average, "
            f"{1 - r['non_converged'] / max(r['registrations'], 1):.1%} converged; "
            f"peak RSS {r['peak_rss_mb']:.0f} MB; target <= {target / 60:.0f} min: {met}"
        )
        n = max(r["registrations"], 1)
        rows[setting] = dict(zip(HEADER, [
            f"{r['load']:.2f}", f"{r['subjects']} x {len(r['alpha2'])}", f"{r['seconds']:.0f} s",
            f"{r['seconds'] / r['subjects']:.1f} s", f"{r['registrations']:,}",
            f"{r['iterations'] / n:.0f} / {r['flow_passes'] / n:.0f}",
            f"{1 - r['non_converged'] / n:.1%}", f"{r['peak_rss_mb']:.0f} MB",
            f"{target / 60:.0f} min: {met}",
        ]))  # fmt: skip
    if args.publish:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from generated_tables import GENERATED, publish_rows

        for setting, row in rows.items():
            name = f"study_{args.deformation}" + ("_full" if setting == "full" else "")
            publish_rows(name, HEADER, row,
                         f"python benchmarks/bench_study.py{' --full' if args.full else ''} "
                         f"--deformation {args.deformation} --publish",
                         seed=earlier_rows(GENERATED, name))  # fmt: skip
    return 0


def earlier_rows(folder: Path, name: str) -> list[dict]:
    """The row of ``<name>.md`` as published before the table kept one row per CPU.

    Used once, when ``<name>.rows.json`` does not exist yet: the measured row (its
    CPU, cores, SIMD level, date and cells, the study's setting shortened to
    ``subjects x alpha^2``) becomes the first stored row; [] if there is none.
    """
    from generated_tables import read_table

    path = folder / f"{name}.md"
    if (folder / f"{name}.rows.json").exists() or not path.is_file():
        return []
    if "one row per CPU" in path.read_text(encoding="utf-8").splitlines()[0]:
        return []
    old = read_table(path)
    seed = []
    for cells in old["rows"]:
        cells = dict(cells)
        study = cells.pop("study", "")
        match = re.search(r"(\d+) subjects x (\d+) alpha\^2", study)
        if match:
            cells["subjects x alpha^2"] = f"{match[1]} x {match[2]}"
        seed.append({"cpu": old["cpu"], "cores": old["cores"], "simd": old["simd"],
                     "date": old["date"], "cells": cells})  # fmt: skip
    return seed


if __name__ == "__main__":
    sys.exit(main())
