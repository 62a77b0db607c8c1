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

Usage: ``python benchmarks/bench_study.py [--full] [--deformation lddmm|svf|both]
[--kernel-backend numpy|numba|auto] [--keep DIR] [-- extra study flags]``.
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

TARGETS_S = {"default": 300.0, "full": 1800.0}


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
    rows = []
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
        rows.append(
            f"| {setting}: {r['subjects']} subjects x {len(r['alpha2'])} alpha^2, "
            f"{args.deformation} | {r['seconds']:.0f} s | {r['seconds'] / r['subjects']:.1f} s | "
            f"{r['registrations']:,} | {r['iterations'] / n:.0f} / {r['flow_passes'] / n:.0f} | "
            f"{1 - r['non_converged'] / n:.1%} | {r['peak_rss_mb']:.0f} MB | "
            f"{target / 60:.0f} min: {met} |"
        )
    if args.publish:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from generated_tables import publish

        head = ("| study | wall time | per subject | registrations | iterations / flow passes "
                "each | converged | peak RSS | target |\n|---|---|---|---|---|---|---|---|")  # fmt: skip
        name = f"study_{args.deformation}" + ("_full" if args.full else "")
        publish(name, head + "\n" + "\n".join(rows),
                f"python benchmarks/bench_study.py{' --full' if args.full else ''} "
                f"--deformation {args.deformation} --publish")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
