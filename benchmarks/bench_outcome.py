"""Survival predicted from transported motion: the cross-validated C-index of every transport.

    python benchmarks/bench_outcome.py --work symladders-output/bench_population
    python benchmarks/bench_outcome.py --work WORK --publish   # docs/generated/outcome_cindex.md

Reads the study of ``bench_population.py`` on the meshes in correspondence with the
default hypokinesia (its ``studies`` stage must have run). An outcome is simulated
from the regional motion the generator knows: each subject's true normal motion
``(ES - ED) . n`` averaged over the planted region, standardised, gives the log-hazard
``risk = beta z`` (less inward motion, a higher hazard), and
:func:`ladders.statistics.simulate_survival` draws exponential event times with 30 %
censoring. Every motion of the study (each transport, and the motion without
transport) then predicts the outcome from the first five PCA scores of its
displacements by Cox regression (:func:`ladders.statistics.cross_validated_c_index_from_motion`:
PCA and Cox fitted inside each of 5 folds; the C-index of the pooled out-of-fold
predictions with a bootstrap interval), beside a baseline of the ejection fraction of
each subject's own meshes, as Dawes et al. (Radiology 2017) and 4Dsurvival (Bello et
al. 2019) report. Repeated over several outcome draws; the table gives the mean and
the range of the C-index over the draws, and the fraction of draws where the motion
beats the baseline (its paired bootstrap interval above 0).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import cross_validated_c_index_from_motion, simulate_survival  # noqa: E402
from ladders.study.population import load_transported_motion, make_two_group_cohort  # noqa: E402
from ladders.study.wall_motion import outward_vertex_normals  # noqa: E402


def _label(motion) -> str:
    return motion.label + ("" if motion.alpha2 is None else f", alpha^2 = {motion.alpha2:g}")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("symladders-output/bench_population"))
    parser.add_argument("--draws", type=int, default=10)
    parser.add_argument("--beta", type=float, default=1.0, help="log-hazard per SD of the motion")
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    data = make_two_group_cohort(n_subjects=40, seed=0)
    motions = load_transported_motion(
        args.work / "studies" / "corresponded" / "hypokinesia" / "lddmm"
    )
    subjects = list(motions[0].subjects)
    by_name = {s.name: s for s in data.cohort.subjects}
    normals = outward_vertex_normals(data.cohort.atlas, data.cohort.faces)
    affected = data.region.affected
    regional = np.array([
        np.einsum("kd,kd->k", by_name[s].es - by_name[s].ed, normals)[affected].mean()
        for s in subjects
    ])  # fmt: skip
    z = (regional - regional.mean()) / regional.std()
    ejection = 1.0 - np.asarray(motions[0].volume_ratio, dtype=float)
    start = time.perf_counter()
    results = {_label(m): [] for m in motions}
    for draw in range(args.draws):
        rng = np.random.default_rng(draw)
        t, event = simulate_survival(args.beta * z, rng, censoring=0.3)
        for m in motions:
            r = cross_validated_c_index_from_motion(
                m.displacement, t, event, n_components=5, rng=np.random.default_rng(100 + draw),
                baseline=ejection[:, None], n_bootstrap=500,
            )  # fmt: skip
            results[_label(m)].append((r.c_index, r.baseline_c_index, r.difference_ci[0] > 0))
        print(f"draw {draw + 1}/{args.draws}", flush=True)
    lines = ["| motion | C-index, mean [range] over the draws | ejection fraction alone | "
             "draws where the motion beats it |", "|---|---|---|---|"]  # fmt: skip
    for label, rows in results.items():
        c = np.array([r[0] for r in rows])
        b = np.array([r[1] for r in rows])
        wins = sum(r[2] for r in rows)
        lines.append(f"| {label} | {c.mean():.2f} [{c.min():.2f}, {c.max():.2f}] | "
                     f"{b.mean():.2f} [{b.min():.2f}, {b.max():.2f}] | {wins} of {len(rows)} |")  # fmt: skip
    note = (
        f"40 subjects (20 with the default hypokinesia), meshes in correspondence, "
        f"`alpha^2 = 1`; outcome simulated with log-hazard {args.beta:g} per standard deviation "
        f"of the true regional normal motion, 30 % censoring, {args.draws} draws; Cox on 5 PCA "
        f"scores, 5 folds, 500 bootstrap resamples ({time.perf_counter() - start:.0f} s)."
    )
    table = note + "\n\n" + "\n".join(lines) + "\n"
    print(table)
    if args.publish:
        publish("outcome_cindex", table, "python benchmarks/bench_outcome.py --publish")


if __name__ == "__main__":
    main()
