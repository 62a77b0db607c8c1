"""Speed and memory of the per-vertex linear model at 1,000 to 20,000 subjects.

    python benchmarks/bench_glm_scale.py [--sizes 1000 5000 20000] [--permutations 10000]
                                         [--cases t t_tfce pillai pillai_tfce] [--publish]

Times :func:`ladders.statistics.glm_test` as ``symladders analyze --design`` runs it on one
motion (10,000 Freedman-Lane permutations, a design of 4 columns: intercept, group, age,
sex; the contrast on group; the family-wise error of the maximum statistic) for:

- ``t``: a scalar per vertex on the 1,009-vertex synthetic atlas;
- ``t_tfce``: the same with two-sided TFCE (``H = 2``, ``E = 1``) on an icosphere of 2,562
  vertices (7,680 edges);
- ``pillai``: the displacement vectors (Pillai's trace, ``d = 3``) on the atlas;
- ``pillai_tfce``: the displacement with TFCE on the icosphere.

The data are white noise smoothed on the mesh (five neighbour averagings) plus a group
effect on a patch, so that the observed map has a cluster and the permuted maps have
the clusters of smooth noise. Each case runs in its own process: the time is the wall
time of ``glm_test`` (the data made beforehand), the memory the peak resident set size
of that process (Python, the imports and the data included). The 1-minute load average
is recorded before each case (the machine's cores may be shared).

With ``--permutations P`` below 10,000 the times are extrapolated linearly in the
permutations from a run of ``P`` (the setup, measured separately, is added once) and
marked as such; ``--publish`` refuses that unless the 20,000-subject cases ran in full.
The targets at 20,000 subjects on 2 cores: at most 60 s for ``pillai`` and for
``t_tfce``, at most 4 GB of peak memory.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish_rows  # noqa: E402

PERMUTATIONS = 10000
TARGET_S, TARGET_GB = 60.0, 4.0
CASES = {  # name: (components, TFCE, label)
    "t": (1, False, "t, 1,009 vertices"),
    "t_tfce": (1, True, "t + TFCE, 2,562 vertices"),
    "pillai": (3, False, "Pillai (3-D), 1,009 vertices"),
    "pillai_tfce": (3, True, "Pillai (3-D) + TFCE, 2,562 vertices"),
}
TARGETS = ("pillai", "t_tfce")
CONTRAST = "group[patients] - group[controls]"


def mesh(tfce: bool) -> tuple[np.ndarray, np.ndarray]:
    """The vertices and faces: the synthetic atlas (1,009) or an icosphere (2,562)."""
    if tfce:
        import trimesh

        sphere = trimesh.creation.icosphere(subdivisions=4)
        return np.asarray(sphere.vertices), np.asarray(sphere.faces)
    from ladders.study.cohort.synthetic_lv import make_synthetic_cohort

    atlas = make_synthetic_cohort(1, seed=0)
    return atlas.atlas, atlas.faces


def make_data(n: int, dim: int, vertices, faces, rng: np.random.Generator):
    """The design table and smooth responses ``(n, k)`` or ``(n, k, 3)`` with a group effect."""
    from ladders.statistics import mesh_adjacency

    table = {
        "subject": [f"s{i:05d}" for i in range(n)],
        "group": ["patients" if i % 2 else "controls" for i in range(n)],
        "age": list(np.round(rng.normal(60.0, 10.0, n), 1)),
        "sex": list(rng.choice(["F", "M"], n)),
    }
    k = len(vertices)
    adjacency = mesh_adjacency(faces, k)
    average = adjacency + sp.identity(k, format="csr")
    average = sp.csr_matrix(average.multiply(1.0 / np.asarray(average.sum(axis=1))))
    data = np.empty((n, k, dim))
    for start in range(0, n, 1000):  # in blocks of subjects: the data are the memory's bulk
        block = rng.standard_normal((k, min(1000, n - start) * dim))
        for _ in range(5):
            block = average @ block
        data[start : start + 1000] = block.reshape(k, -1, dim).transpose(1, 0, 2)
    patch = np.linalg.norm(vertices - vertices[0], axis=1) < 0.3 * np.ptp(vertices, axis=0).max()
    data[1::2, patch] += 0.02 * np.std(data[:100])
    return table, (data[..., 0] if dim == 1 else data), adjacency


def _cpu_seconds() -> float:
    """User and system CPU time of this process (every thread), seconds."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def run_case(case: str, n: int, permutations: int) -> dict:
    """One case in this process: seconds of ``glm_test``, peak RSS, load before."""
    from ladders.statistics import design_matrix, glm_test

    dim, tfce, _ = CASES[case]
    load = os.getloadavg()[0]
    rng = np.random.default_rng(0)
    vertices, faces = mesh(tfce)
    table, data, adjacency = make_data(n, dim, vertices, faces, rng)
    design = design_matrix(table, "group + age + sex")
    data_gb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    glm_test(
        data[:50],
        design_matrix({c: v[:50] for c, v in table.items()}, "group + age + sex"),
        CONTRAST,
        20,
        np.random.default_rng(1),
        tfce=adjacency if tfce else None,
    )  # compile
    start = time.perf_counter()
    test = glm_test(data, design, CONTRAST, 1, np.random.default_rng(1),
                    tfce=adjacency if tfce else None)  # fmt: skip
    setup = time.perf_counter() - start
    start, cpu = time.perf_counter(), _cpu_seconds()
    test = glm_test(data, design, CONTRAST, permutations, np.random.default_rng(1),
                    tfce=adjacency if tfce else None)  # fmt: skip
    seconds, cpu = time.perf_counter() - start, _cpu_seconds() - cpu
    if permutations < PERMUTATIONS:
        seconds = setup + (seconds - setup) * PERMUTATIONS / permutations
        cpu *= PERMUTATIONS / permutations
    return {
        "case": case, "subjects": n, "vertices": len(vertices), "permutations": permutations,
        "seconds": seconds, "cpu": cpu, "setup": setup, "load": load,
        "data_gb": data_gb, "rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20,
        "p_min": float(test.p_fwer.min()),
    }  # fmt: skip


def measure(case: str, n: int, permutations: int) -> dict:
    """:func:`run_case` in a fresh process (its own peak memory)."""
    out = subprocess.run(
        [sys.executable, __file__, "--child", case, str(n), str(permutations)],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    return json.loads(out.stdout.strip().splitlines()[-1])


def cell(results: list[dict]) -> str:
    """``a / b / c s`` over the sizes (``~`` marks an extrapolation), the growth of the last
    step, and at the largest size the CPU time (every thread) and the peak RSS."""
    times = " / ".join(("~" if r["permutations"] < PERMUTATIONS else "") + f"{r['seconds']:.3g}"
                       for r in results)  # fmt: skip
    last, before = results[-1], results[-2] if len(results) > 1 else None
    growth = ""
    if before is not None:
        ratio = last["seconds"] / before["seconds"]
        growth = f" (x{ratio:.1f} for x{last['subjects'] / before['subjects']:g} subjects)"
    return f"{times} s{growth}; CPU {last['cpu']:.3g} s; {last['rss_gb']:.2f} GB"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 5000, 20000],
                        help="subjects (default: 1000 5000 20000)")  # fmt: skip
    parser.add_argument("--permutations", type=int, default=PERMUTATIONS,
                        help="permutations run at the largest size; fewer are extrapolated "
                             "to 10,000 (default: 10000)")  # fmt: skip
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES),
                        help="the cases (default: all four)")  # fmt: skip
    parser.add_argument(
        "--publish",
        action="store_true",
        help="write docs/generated/glm_scale.md (needs 10,000 permutations)",
    )
    parser.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        print(json.dumps(run_case(args.child[0], int(args.child[1]), int(args.child[2]))))
        return
    if args.publish and args.permutations < PERMUTATIONS:
        parser.error("--publish needs the full 10,000 permutations at every size")
    print(machine(), flush=True)
    results: dict[str, list[dict]] = {}
    for case in args.cases:
        for n in sorted(args.sizes):
            permutations = PERMUTATIONS if n < max(args.sizes) else args.permutations
            r = measure(case, n, permutations)
            note = "" if permutations == PERMUTATIONS else f" (extrapolated from {permutations})"
            print(f"{CASES[case][2]}, {n:,} subjects: {r['seconds']:.1f} s{note}, "
                  f"CPU {r['cpu']:.1f} s "
                  f"(setup {r['setup']:.1f} s), peak RSS {r['rss_gb']:.2f} GB "
                  f"({r['data_gb']:.2f} GB with the data made), "
                  f"load {r['load']:.2f}", flush=True)  # fmt: skip
            results.setdefault(case, []).append(r)
    largest = {case: rs[-1] for case, rs in results.items()}
    met = [f"{CASES[c][2].split(',')[0]}: {largest[c]['seconds']:.0f} s "
           + ("met" if largest[c]["seconds"] <= TARGET_S else "NOT met")
           for c in TARGETS if c in largest]  # fmt: skip
    peak = max(r["rss_gb"] for rs in results.values() for r in rs)
    met.append(f"memory {peak:.2f} GB " + ("met" if peak <= TARGET_GB else "NOT met"))
    loads = [r["load"] for rs in results.values() for r in rs]
    sizes = " / ".join(f"{n:,}" for n in sorted(args.sizes))
    header = ["load", *(f"{CASES[c][2]}: s at {sizes} subjects; CPU s, peak RSS at the last"
                        for c in results),
              f"targets at {max(args.sizes):,} subjects (60 s, 4 GB)"]  # fmt: skip
    row = {header[0]: f"{min(loads):.2f}-{max(loads):.2f}",
           **{h: cell(results[c]) for h, c in zip(header[1:], results)},
           header[-1]: "; ".join(met)}  # fmt: skip
    print("\n" + "\n".join(f"{h}: {row[h]}" for h in header))
    if args.publish:
        publish_rows("glm_scale", header, row, "python benchmarks/bench_glm_scale.py --publish")


if __name__ == "__main__":
    main()
