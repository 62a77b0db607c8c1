"""Time of the linear model on the whole cycle: 200 subjects x 25 frames x 1,009 vertices.

    python benchmarks/bench_cycle_model_speed.py             # 5,000 permutations
    python benchmarks/bench_cycle_model_speed.py --quick     # 500, extrapolated
    python benchmarks/bench_cycle_model_speed.py --publish   # docs/generated/cycle_model_speed.md

A cohort of 200 subjects in two groups with age, sex and body size
(:func:`~ladders.study.population.make_covariate_cohort`, through 25 frames by
:func:`~ladders.study.population.covariate_cycles`, the true frames with the
tracking-like error of ``bench_cycle_model.py``) is tested with the model
``group + age + sex + body_size`` and the contrast of the two groups on every summary
of the cycle (:func:`~ladders.study.sequences.cycle_model`: per frame, peak, time to
peak, trajectory), 5,000 Freedman-Lane permutations, each with threshold-free cluster
enhancement (the per-frame maps on the spatio-temporal graph of 25,225 vertex-frames).
Timed: the responses (curves, peaks, each vertex's principal components) and each
summary's test (wall time; the process's CPU time beside it, the time its threads
ran, which a loaded machine does not inflate); not timed: drawing the cohort. Target:
at most 120 s in all on two cores. One row per CPU, with the 1-minute load average
when the run started (above the core count, other jobs shared the CPU). With
``--quick`` the times of the permutations are extrapolated from 500 (the responses
are not).
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_cycle_model import noisy_motion  # noqa: E402
from generated_tables import machine, publish_rows  # noqa: E402

from ladders.statistics import design_matrix  # noqa: E402
from ladders.study.population import covariate_cycles, make_covariate_cohort  # noqa: E402
from ladders.study.sequences import SUMMARIES, cycle_model, cycle_responses  # noqa: E402

PERMUTATIONS, TARGET_S = 5000, 120.0
HEADER = ["load", "subjects x frames x vertices", "permutations", "responses", "per frame",
          "peak", "time to peak", "trajectory", "total", "CPU time", "peak RSS",
          "target"]  # fmt: skip


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="500 permutations, extrapolated")
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    if args.quick and args.publish:
        parser.error("--publish needs the full measurement (without --quick)")
    permutations = 500 if args.quick else PERMUTATIONS
    scale = PERMUTATIONS / permutations
    print(machine(), flush=True)
    data = make_covariate_cohort(100, (("controls", None), ("patients", None)), seed=5)
    cycles = covariate_cycles(data, 25)
    motion = noisy_motion(cycles.frames, cycles.names, data.cohort.atlas, data.cohort.faces,
                          np.random.default_rng(5))  # fmt: skip
    design = design_matrix(data.design_table(), "group + age + sex + body_size",
                           subjects=list(cycles.names))  # fmt: skip
    shape = motion.displacement.shape
    load = os.getloadavg()[0]
    cpu = os.times()
    start = time.perf_counter()
    responses = cycle_responses(motion)
    seconds = {"responses": time.perf_counter() - start}
    rng = np.random.default_rng(0)
    for summary in SUMMARIES:
        begin = time.perf_counter()
        cycle_model(responses, design, "group[patients] - group[controls]", permutations, rng,
                    tfce=True, summaries=(summary,))  # fmt: skip
        seconds[summary] = (time.perf_counter() - begin) * scale
        print(f"{summary}: {seconds[summary]:.1f} s", flush=True)
    total = sum(seconds.values())
    end = os.times()
    cpu_seconds = (end.user + end.system - cpu.user - cpu.system) * scale
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    met = "met" if total <= TARGET_S else "NOT met"
    print(f"total {total:.1f} s for {PERMUTATIONS:,} permutations"
          + (" (extrapolated from 500)" if args.quick else "")
          + f" (CPU time {cpu_seconds:.0f} s), load {load:.2f}, peak RSS {rss:.0f} MB; "
          f"target <= {TARGET_S:g} s: {met}")  # fmt: skip
    if args.publish:
        row = {"load": f"{load:.2f}", "subjects x frames x vertices":
               f"{shape[0]} x {shape[1]} x {shape[2]:,}", "permutations": f"{PERMUTATIONS:,}",
               "responses": f"{seconds['responses']:.1f} s",
               "per frame": f"{seconds['per_frame']:.1f} s", "peak": f"{seconds['peak']:.1f} s",
               "time to peak": f"{seconds['time_to_peak']:.1f} s",
               "trajectory": f"{seconds['trajectory']:.1f} s", "total": f"{total:.0f} s",
               "CPU time": f"{cpu_seconds:.0f} s",
               "peak RSS": f"{rss:.0f} MB", "target": f"{TARGET_S:g} s: {met}"}  # fmt: skip
        publish_rows("cycle_model_speed", HEADER, row,
                     "python benchmarks/bench_cycle_model_speed.py --publish")  # fmt: skip


if __name__ == "__main__":
    main()
