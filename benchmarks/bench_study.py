"""Wall time of the study (paper, Section 3) on the built-in cohort.

Runs ``symladders study`` in a subprocess for the default setting (12 subjects,
5 values of alpha^2) and, with ``--full``, the paper's setting (138 subjects,
7 values of alpha^2, both variants), each into a fresh temporary folder, and
prints wall time, peak memory of the parent process tree's largest member,
number of registrations and the targets (default <= 10 min, full <= 30 min on 2 cores).

Usage: ``python benchmarks/bench_study.py [--full] [--kernel-backend numpy|numba|auto]``.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGETS_S = {"default": 600.0, "full": 1800.0}


def run(setting: str, backend: str, jobs: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        args = [
            sys.executable,
            "-m",
            "ladders.study.cli",
            "study",
            "--output",
            tmp,
            "--no-progress",
        ]
        args += ["--kernel-backend", backend, "--jobs", str(jobs)]
        if setting == "full":
            args.append("--full")
        start = time.perf_counter()
        proc = subprocess.run(args, capture_output=True, text=True)
        seconds = time.perf_counter() - start
        if proc.returncode != 0:
            raise RuntimeError(proc.stderr[-3000:])
        manifest = json.loads((Path(tmp) / "manifest.json").read_text())
    peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    return {
        "setting": setting,
        "seconds": seconds,
        "subjects": manifest["n_subjects"],
        "alpha2": manifest["config"]["alpha2"],
        "registrations": manifest["registrations"],
        "non_converged": manifest["non_converged_registrations"],
        "peak_rss_mb": peak_mb,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true", help="also run the paper's full setting")
    parser.add_argument("--kernel-backend", default="auto", choices=("auto", "numpy", "numba"))
    parser.add_argument("--jobs", type=int, default=-1)
    args = parser.parse_args(argv)
    settings = ["default", "full"] if args.full else ["default"]
    print(f"kernel backend: {args.kernel_backend}, jobs: {args.jobs}")
    for setting in settings:
        r = run(setting, args.kernel_backend, args.jobs)
        target = TARGETS_S[setting]
        met = "met" if r["seconds"] <= target else "NOT met"
        print(
            f"{setting:8s} {r['subjects']:4d} subjects x {len(r['alpha2'])} alpha^2: "
            f"{r['seconds']:8.1f} s wall ({r['seconds'] / r['subjects']:.2f} s/subject), "
            f"{r['registrations']} registrations ({r['non_converged']} at the iteration limit), "
            f"peak RSS {r['peak_rss_mb']:.0f} MB; target <= {target / 60:.0f} min: {met}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
