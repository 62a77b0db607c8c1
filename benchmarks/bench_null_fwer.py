"""The family-wise false-positive rate of every per-vertex test under the null, from segmentations.

    python benchmarks/bench_null_fwer.py --work symladders-output/bench_population
    python benchmarks/bench_null_fwer.py --publish        # docs/generated/population_null_fwer.md

Reads the null studies of ``bench_population.py`` (the same 40 subjects without any
abnormality, both groups from one distribution; its ``studies`` stage must have
run) and, for each arm (segmentations posed with landmarks, unposed without) and
each motion at ``alpha^2 = 1`` (and the motion without transport), splits the
subjects at random into 20 and 20, 200 times, and runs each per-vertex test
(displacement ``T^2``, area strain ``t``, normal wall motion ``t``) with 1,000
permutations: the fraction of splits with any vertex detected at FWER 5 %, with
its 95 % binomial (Clopper-Pearson) interval. A correct test's rate is 5 %, inside
the interval.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.study.population import load_transported_motion, null_false_positive_rate  # noqa: E402

ARMS = {
    "segmentations": "segmentations, posed, landmark table",
    "segmentations_unposed": "segmentations, unposed, no landmarks",
}
QUANTITIES = ("displacement", "strain", "wall_motion")


def _null_motions(work: Path, arm: str):
    folder = work / "studies" / arm / "null" / "lddmm"
    if not folder.is_dir():
        return []
    motions = load_transported_motion(folder)
    return [m for m in motions if m.alpha2 in (None, 1.0)]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("symladders-output/bench_population"))
    parser.add_argument("--repetitions", type=int, default=200)
    parser.add_argument("--permutations", type=int, default=1000)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    lines = [
        "| arm | motion | displacement T^2 | area strain t | normal wall motion t |",
        "|---|---|---|---|---|",
    ]
    start = time.perf_counter()
    for arm, label in ARMS.items():
        for motion in _null_motions(args.work, arm):
            cells = []
            for quantity in QUANTITIES:
                rate = null_false_positive_rate(
                    motion, len(motion.subjects) // 2, np.random.default_rng(0),
                    args.repetitions, args.permutations, quantity=quantity,
                )  # fmt: skip
                cells.append(f"{rate.rate:.3f} [{rate.low:.3f}, {rate.high:.3f}]")
            lines.append(f"| {label} | {motion.label} | " + " | ".join(cells) + " |")
            print(lines[-1], flush=True)
    if len(lines) == 2:
        raise SystemExit(f"no null study under {args.work}: run bench_population.py first")
    seconds = time.perf_counter() - start
    note = (
        f"{args.repetitions} random 20/20 splits of the 40 subjects without abnormality, "
        f"{args.permutations:,} permutations each; FWER at 5 % with its 95 % binomial interval "
        f"({seconds:.0f} s)."
    )
    table = note + "\n\n" + "\n".join(lines) + "\n"
    print(table)
    if args.publish:
        publish("population_null_fwer", table, "python benchmarks/bench_null_fwer.py --publish")


if __name__ == "__main__":
    main()
