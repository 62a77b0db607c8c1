"""What checking a deformation model costs and finds: the check before a study, the validation.

For the built-in models and the point-distribution model of
``examples/point_distribution_model.py`` (loaded as a plugin, as ``--plugin`` does):

* ``check_deformation_model`` on the default study's atlas (the built-in cohort's,
  1009 vertices) and registration settings: what every ``symladders study`` now runs
  before its first registration (timed after one warm-up call, which compiles the
  kernels);
* ``validate_deformation_model`` (41-vertex atlas): its wall time, the contract's
  passed and skipped properties, and the pole ladder's relative errors at 1, 2 and 4
  rungs against the reference with their log-log slope (the claim: second order, a
  slope near -2, or round-off for the flat model).

``--publish`` writes a table of one row per CPU (``generated_tables.publish_rows``,
``docs/generated/deformation_models.md``) with the 1-minute load average at the start.

Usage: ``python benchmarks/bench_deformation_models.py [--publish]``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HEADER = ["load", "check before a study, 1009 vertices (lddmm / svf / pdm)",
          "validation (lddmm / svf / pdm)", "contract properties passed (lddmm / svf / pdm)",
          "pole ladder errors at 1, 2, 4 rungs, slope"]  # fmt: skip


def measure() -> dict:
    from ladders.study.cohort import make_synthetic_cohort
    from ladders.study.default_registration import DEFAULT_REGISTRATION
    from ladders.study.deformations import (
        check_deformation_model,
        load_plugin,
        validate_deformation_model,
    )

    load_plugin(str(ROOT / "examples" / "point_distribution_model.py"))
    atlas = make_synthetic_cohort(1).atlas
    out = {"load": os.getloadavg()[0], "models": {}}
    for name in ("lddmm", "svf", "pdm"):
        check_deformation_model(name, atlas, DEFAULT_REGISTRATION)  # warm-up: compiles
        start = time.perf_counter()
        check_deformation_model(name, atlas, DEFAULT_REGISTRATION)
        check = time.perf_counter() - start
        report = validate_deformation_model(name)
        values = list(report.checks.values())
        curve = report.convergence
        out["models"][name] = {
            "check_s": check,
            "validation_s": report.seconds,
            "passed": sum(v.startswith("passed") for v in values),
            "skipped": sum(v.startswith("skipped") for v in values),
            "errors": [float(e) for e in curve.errors],
            "slope": None if max(curve.errors) < 1e-6 else curve.slope,  # round-off: no order
            "verdict": report.checks["ladder convergence"],
        }
    return out


def row(result: dict) -> dict:
    m = result["models"]
    names = ("lddmm", "svf", "pdm")

    def ladder(name):
        r = m[name]
        slope = "round-off" if r["slope"] is None else f"slope {r['slope']:.2f}"
        return f"{name}: {', '.join(f'{e:.1e}' for e in r['errors'])} ({slope})"

    return dict(zip(HEADER, [
        f"{result['load']:.2f}",
        " / ".join(f"{m[n]['check_s']:.2f} s" for n in names),
        " / ".join(f"{m[n]['validation_s']:.1f} s" for n in names),
        " / ".join(f"{m[n]['passed']} ({m[n]['skipped']} skipped)" for n in names),
        "; ".join(ladder(n) for n in names),
    ]))  # fmt: skip


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--publish", action="store_true",
                        help="write the table to docs/generated (the docs include it)")  # fmt: skip
    args = parser.parse_args(argv)
    result = measure()
    cells = row(result)
    for key, value in cells.items():
        print(f"{key}: {value}")
    for name, r in result["models"].items():
        print(f"{name}: {r['verdict']}")
    if args.publish:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from generated_tables import publish_rows

        publish_rows("deformation_models", HEADER, cells,
                     "python benchmarks/bench_deformation_models.py --publish")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
