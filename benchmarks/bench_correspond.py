"""Correspondence benchmarks: one varifold registration, the memory of a large pair, a cohort.

    python benchmarks/bench_correspond.py              # all three parts
    python benchmarks/bench_correspond.py --quick      # 5 subjects instead of the default 40 meshes

1. A varifold registration of the 1,009-vertex atlas onto a 5,000-face remeshed
   subject (target: at most 10 s on 2 cores): time, iterations, distances.
2. One evaluation of the varifold distance between two 20,000-face meshes, in a
   subprocess, numpy and numba backends: peak resident memory (target < 1 GB).
3. Correspondence of the default cohort (20 subjects, 40 meshes), each mesh
   remeshed to about 2,000 faces and moved rigidly, one subject in metres
   (target: at most 5 minutes): wall time, iterations, quality.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

MEMORY_CHILD = """
import resource, sys, time
import numpy as np
import trimesh
from manifolds.data_terms import VarifoldDistance
m = trimesh.creation.icosphere(5)  # 20,480 faces
v, f = 30.0 * np.array(m.vertices), np.array(m.faces)
term = VarifoldDistance(v, f, f, 5.0, backend=sys.argv[1])
t0 = time.perf_counter()
value, grad = term.value_and_gradient(v * 1.01)
dt = time.perf_counter() - t0
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(f"{len(f)} faces, backend {sys.argv[1]}: {dt:.1f} s, peak RSS {peak:.0f} MB, D = {value:.6g}")
"""


def single_registration() -> None:
    from ladders.study.preparation import CorrespondenceSettings, correspond_mesh, remesh
    from ladders.study.preparation.alignment import SimilarityTransform
    from ladders.study.synthetic_lv import make_synthetic_cohort

    cohort = make_synthetic_cohort(1, seed=0)
    v, f = remesh(cohort.subjects[0].ed, cohort.faces, 5000)
    settings = CorrespondenceSettings()
    correspond_mesh(
        cohort.atlas,
        cohort.faces,
        v[:, :],
        f,
        settings.replace(registration=settings.registration.replace(max_iter=2)),
        transform=SimilarityTransform.identity(),
    )  # fmt: skip  (compiles the kernels)
    t0 = time.perf_counter()
    out = correspond_mesh(cohort.atlas, cohort.faces, v, f, settings,
                          transform=SimilarityTransform.identity())  # fmt: skip
    dt = time.perf_counter() - t0
    q = out.quality
    print(
        f"1. atlas {len(cohort.atlas)} vertices onto {len(f)} faces: {dt:.1f} s, "
        f"{q['n_iter']} iterations, converged {q['converged']}, varifold distance "
        f"{q['distance_before']:.4g} -> {q['distance_after']:.4g} mm^2, mean surface distance "
        f"{q['mean_surface_distance']:.3f} mm, Hausdorff {q['hausdorff']:.2f} mm"
    )


def memory() -> None:
    for backend in ("numba", "numpy"):
        proc = subprocess.run([sys.executable, "-c", MEMORY_CHILD, backend],
                              capture_output=True, text=True, check=True)  # fmt: skip
        print("2.", proc.stdout.strip())


def cohort_correspondence(n_subjects: int, jobs: int) -> None:
    from ladders.study.mesh_io import write_mesh
    from ladders.study.preparation import correspond_cohort, random_rigid_transform, remesh
    from ladders.study.synthetic_lv import make_synthetic_cohort

    cohort = make_synthetic_cohort(n_subjects, seed=0)
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "segmentations"
        src.mkdir()
        for i, s in enumerate(cohort.subjects):
            motion, factor = random_rigid_transform(rng, 180.0, 50.0), (1e-3 if i == 0 else 1.0)
            for phase, v in (("ed", s.ed), ("es", s.es)):
                rv, rf = remesh(v, cohort.faces, 2000)
                write_mesh(src / f"{s.name}_{phase}.ply", motion.apply(rv) * factor, rf)
        write_mesh(Path(tmp) / "atlas.vtk", cohort.atlas, cohort.faces)
        t0 = time.perf_counter()
        out = correspond_cohort(Path(tmp) / "atlas.vtk", src, Path(tmp) / "out", jobs=jobs,
                                units="auto")  # fmt: skip
        dt = time.perf_counter() - t0
        rows = [r for r in out.records if r["status"] == "ok"]
        iters = [r[p]["n_iter"] for r in rows for p in ("ed", "es")]
        msd = [r[p]["mean_surface_distance"] for r in rows for p in ("ed", "es")]
        haus = [r[p]["hausdorff"] for r in rows for p in ("ed", "es")]
        conv = np.mean([r[p]["converged"] for r in rows for p in ("ed", "es")])
        print(
            f"3. {2 * n_subjects} meshes, {jobs} jobs: {dt:.0f} s; {len(out.failed)} failed; "
            f"iterations mean {np.mean(iters):.0f} max {max(iters)}; converged {conv:.0%}; "
            f"mean surface distance mean {np.mean(msd):.3f} max {max(msd):.3f} mm; "
            f"Hausdorff max {max(haus):.2f} mm"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="5 subjects in part 3")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--parts", default="123")
    args = parser.parse_args()
    if "1" in args.parts:
        single_registration()
    if "2" in args.parts:
        memory()
    if "3" in args.parts:
        cohort_correspondence(5 if args.quick else 20, args.jobs)


if __name__ == "__main__":
    main()
