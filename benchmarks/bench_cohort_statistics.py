"""The built-in cohort's figures: size, volumes, ejection fraction and distances, per subject.

    python benchmarks/bench_cohort_statistics.py             # print
    python benchmarks/bench_cohort_statistics.py --publish   # docs/generated/cohort_statistics.md

:func:`ladders.study.cohort.cohort_statistics` on the default cohort
(``make_synthetic_cohort()``: 138 subjects, seed 0, 1009 vertices): min, mean and max
over the subjects of the end-diastolic long axis and base radius (mm), the cavity
volumes (ml), the ejection fraction, and the per-vertex RMS distances atlas-ED,
atlas-ES and ED-ES (mm), with the atlas's mean edge length.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.study.cohort import cohort_statistics, make_synthetic_cohort  # noqa: E402


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=138)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    start = time.perf_counter()
    cohort = make_synthetic_cohort(args.subjects)
    table = (
        f"`cohort_statistics(make_synthetic_cohort({args.subjects}))`: {args.subjects} subjects, "
        f"seed 0, {cohort.n_vertices} vertices; lengths in mm, volumes in ml.\n\n"
        + cohort_statistics(cohort).to_markdown()
        + "\n"
    )
    print(table, f"({time.perf_counter() - start:.1f} s)")
    if args.publish:
        publish(
            "cohort_statistics", table, "python benchmarks/bench_cohort_statistics.py --publish"
        )


if __name__ == "__main__":
    main()
