"""Speed of the heat-kernel smoothing of per-vertex maps: the dense kernel and the sparse exponential.

    python benchmarks/bench_surface_smoothing.py [--publish]   # docs/generated/surface_smoothing.md

:class:`ladders.statistics.SurfaceSmoother` on the default atlas (1,009 vertices) and on
icospheres of 2,562 and 10,242 vertices (radius 30 mm), at 10 and 20 mm FWHM: the
seconds to build it and to smooth 1,000 maps (what ``compare_cycles(..., fwhm=...)``
smooths for 40 subjects of 25 frames), with the dense kernel (the default up to 4,000
vertices) and with SciPy's ``expm_multiply`` (``dense_max=0``), best of 3; the largest
difference between the two (both exact to round-off). Printed with the CPU.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import SurfaceSmoother  # noqa: E402
from ladders.study.cohort import make_synthetic_cohort  # noqa: E402

MAPS = 1000


def _best(call, repeats: int = 3) -> tuple[float, object]:
    best, out = np.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        out = call()
        best = min(best, time.perf_counter() - start)
    return best, out


def rows() -> list[tuple]:
    atlas = make_synthetic_cohort(n_subjects=1, seed=0)
    meshes = [("default atlas", atlas.atlas, atlas.faces)]
    for sub in (4, 5):
        sphere = trimesh.creation.icosphere(subdivisions=sub, radius=30.0)
        meshes.append(("icosphere", sphere.vertices, sphere.faces))
    rng = np.random.default_rng(0)
    out = []
    for label, v, f in meshes:
        x = rng.standard_normal((MAPS, len(v)))
        for fwhm in (10.0, 20.0):
            results = {}
            for how, dense_max in (("dense kernel", 4000), ("expm_multiply", 0)):
                if how == "dense kernel" and len(v) > 4000:
                    continue
                build, smoother = _best(
                    lambda d=dense_max, v=v, f=f, w=fwhm: SurfaceSmoother(v, f, w, dense_max=d)
                )
                apply, y = _best(lambda s=smoother, x=x: s(x))
                results[how] = y
                out.append((label, len(v), fwhm, how, build, apply))
                print(out[-1], flush=True)
            if len(results) == 2:
                gap = float(np.abs(results["dense kernel"] - results["expm_multiply"]).max())
                out[-1] = (*out[-1], gap)
    return out


def _table(rows) -> str:
    lines = [
        "| mesh | vertices | FWHM (mm) | how | build (s) | 1,000 maps (s) | largest difference "
        "dense - sparse |",
        "|---|---|---|---|---|---|---|",
    ]
    for label, k, fwhm, how, build, apply, *gap in rows:
        g = f"{gap[0]:.1e}" if gap else ""
        lines.append(f"| {label} | {k:,} | {fwhm:g} | {how} | {build:.3f} | {apply:.3f} | {g} |")
    note = (
        f"`SurfaceSmoother(vertices, faces, fwhm, dense_max=...)` built, then applied to "
        f"{MAPS:,} random maps at once; best of 3. The dense kernel is the default up to "
        "4,000 vertices."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    table = _table(rows())
    print("\n" + table)
    if args.publish:
        publish(
            "surface_smoothing", table, "python benchmarks/bench_surface_smoothing.py --publish"
        )


if __name__ == "__main__":
    main()
