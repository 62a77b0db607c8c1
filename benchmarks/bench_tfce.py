"""Speed of threshold-free cluster enhancement: 10,000 maps on the 1,009-vertex atlas.

    python benchmarks/bench_tfce.py [--quick] [--publish]

Times :func:`ladders.statistics.tfce.tfce_enhancer` (``H = 2``, ``E = 1``, one fixed
step ``dh = max |observed| / 100``) on 10,000 random maps over the atlas of the
default synthetic cohort (1,009 vertices, 2,982 edges), as a permutation test
would call it: chunks of 1,000 maps. The maps are white noise and noise smoothed by
neighbour averaging (large clusters), scaled to unit standard deviation, the
observed map to a peak of 5 (``dh = 0.05``). Each timing is the best of three
runs; the target is at most 60 s for 10,000 maps on 2 cores. MNE-Python's TFCE
(``mne.stats.cluster_level._find_clusters``, the same sum) is timed on a few maps
when it is installed. ``--quick`` times 1,000 maps once; ``--publish`` writes
``docs/generated/tfce_speed.md``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.statistics.tfce import mesh_adjacency, tfce_enhancer, tfce_step  # noqa: E402
from ladders.study.cohort.synthetic_lv import make_synthetic_cohort  # noqa: E402

TARGET_S = 60.0
CHUNK = 1000


def noise_maps(adjacency, m: int, iterations: int, seed: int = 0) -> np.ndarray:
    """``m`` maps of white noise smoothed ``iterations`` times, unit standard deviation."""
    x = np.random.default_rng(seed).standard_normal((adjacency.shape[0], m))
    mean = sp.diags(1.0 / np.asarray(adjacency.sum(axis=1)).ravel()) @ adjacency
    for _ in range(iterations):
        x = 0.5 * x + 0.5 * (mean @ x)
    x = x.T
    return x / x.std(axis=1, keepdims=True)


def time_enhancer(enhance, maps: np.ndarray, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        for i in range(0, maps.shape[0], CHUNK):
            enhance(maps[i : i + CHUNK])
        best = min(best, time.perf_counter() - start)
    return best


def time_mne(faces, maps: np.ndarray, step: float) -> float | None:
    """Seconds per map of MNE's TFCE (counts, ``E = 1``), or None without MNE."""
    try:
        import mne
        from mne.stats.cluster_level import _find_clusters
    except ImportError:
        return None
    adjacency = mne.spatial_tris_adjacency(faces, verbose=False)
    threshold = {"start": 0.0, "step": step, "h_power": 2.0, "e_power": 1.0}
    start = time.perf_counter()
    for x in maps:
        _find_clusters(x, threshold, tail=1, adjacency=adjacency)
    return (time.perf_counter() - start) / len(maps)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1,000 maps, timed once")
    parser.add_argument("--publish", action="store_true", help="write docs/generated/tfce_speed.md")
    args = parser.parse_args(argv)
    if args.quick and args.publish:
        parser.error("--publish needs the full measurement (without --quick)")
    n_maps, repeats = (1000, 1) if args.quick else (10000, 3)

    cohort = make_synthetic_cohort(n_subjects=0)
    k = cohort.atlas.shape[0]
    adjacency = mesh_adjacency(cohort.faces, k)
    observed = noise_maps(adjacency, 1, 10, seed=1)[0]
    observed *= 5.0 / np.abs(observed).max()
    step = tfce_step(observed, n_steps=100, two_sided=True)
    print(machine())
    print(f"mesh: {k} vertices, {adjacency.nnz // 2} edges; step {step:.3g}; {n_maps} maps")

    rows = ["| maps | sides | time per map | time for 10,000 maps | target |",
            "|---|---|---|---|---|"]  # fmt: skip
    for label, iterations in (("white noise", 0), ("smoothed noise (10 averagings)", 10)):
        maps = noise_maps(adjacency, n_maps, iterations)
        for two_sided in (False, True):
            enhance = tfce_enhancer(adjacency, 2.0, 1.0, step=step, two_sided=two_sided)
            enhance(maps[:2])  # compile (or load the cache)
            seconds = time_enhancer(enhance, maps, repeats)
            per_map = seconds / n_maps
            total = per_map * 10000
            met = "met" if total <= TARGET_S else "NOT met"
            sides = "two-sided" if two_sided else "one-sided"
            print(f"{label}, {sides}: {1e3 * per_map:.3f} ms per map, "
                  f"{total:.2f} s for 10,000 maps; target <= {TARGET_S:g} s: {met}")  # fmt: skip
            rows.append(f"| {label} | {sides} | {1e3 * per_map:.3f} ms | {total:.2f} s | "
                        f"<= {TARGET_S:g} s: {met} |")  # fmt: skip
    mne_seconds = time_mne(cohort.faces, noise_maps(adjacency, 20, 10), step)
    if mne_seconds is not None:
        print(f"MNE _find_clusters (smoothed noise, one-sided): {1e3 * mne_seconds:.1f} ms per map, "
              f"{mne_seconds * 10000:.0f} s for 10,000 maps (extrapolated from 20)")  # fmt: skip
        rows.append(f"| MNE-Python `_find_clusters`, smoothed noise | one-sided | "
                    f"{1e3 * mne_seconds:.1f} ms | {mne_seconds * 10000:.0f} s (20 maps) | |")  # fmt: skip
    if args.publish:
        table = (f"{k:,}-vertex atlas ({adjacency.nnz // 2:,} edges), `H = 2`, `E = 1`, fixed step "
                 f"{step:.3g}, chunks of {CHUNK:,} maps, best of {repeats}.\n\n" + "\n".join(rows))  # fmt: skip
        publish("tfce_speed", table, "python benchmarks/bench_tfce.py --publish")


if __name__ == "__main__":
    main()
