"""How much of one step's motion a cine registration recovers: the cause of the cine route's error.

    python benchmarks/bench_cine_steps.py [--publish]    # docs/generated/cine_steps.md

The first subject of ``bench_cine_tracking.py`` (241 vertices), rendered as in that
benchmark on the short-axis stack of 1.5 x 1.5 x 8 mm (25 frames, noise 0.02, with and
without tagging). ED (frame 0) is registered to frame 1 (one step of the chain) and to
frame 3 by :func:`~ladders.study.tracking.cine_tracking.register_frames` with the
benchmark's settings and with one setting changed at a time (more iterations, ten
times as many sampled voxels, ITK's Gaussian derivative for the image gradient instead
of central differences), and the ED vertices are moved by the transform.

Reported: the mean true motion of the vertices, the mean error of the moved vertices,
and the recovered fraction ``<moved - ed, true - ed> / |true - ed|^2`` over all vertices
(1: the whole motion; 0: none), and the time of the registration.
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_cine_tracking import GRIDS, SETTINGS, grid  # noqa: E402
from generated_tables import publishing_main  # noqa: E402

from ladders.study.cohort import cycle_fraction, make_synthetic_cohort, motion_forward  # noqa: E402
from ladders.study.imaging import TagGrid, render_cine  # noqa: E402
from ladders.study.tracking.cine_tracking import register_frames  # noqa: E402

N_FRAMES = 25
VARIANTS = {
    "benchmark's settings": SETTINGS,
    "iterations 100": replace(SETTINGS, iterations=100),
    "sampling 0.5": replace(SETTINGS, sampling_percentage=0.5),
    "ITK's Gaussian image gradient": replace(SETTINGS, image_gradient="gaussian"),
}


def run() -> list[tuple]:
    subject = make_synthetic_cohort(1, n_vertices=241, seed=0).subjects[0]
    params, ed = subject.parameters, np.asarray(subject.ed, float)
    es = int(round(0.35 * N_FRAMES))
    fractions = cycle_fraction(np.arange(N_FRAMES) / N_FRAMES, es / N_FRAMES)
    affine, shape = grid(GRIDS["short-axis 1.5 x 1.5 x 8 mm"])
    rng = np.random.default_rng(100)
    rows = []
    for tagging in (TagGrid(), None):
        frames = [render_cine(params, affine, shape, f, rng, noise=0.02, tagging=tagging,
                              supersample=2) for f in fractions[:4]]  # fmt: skip
        for name, settings in VARIANTS.items():
            for target in (1, 3):
                truth = motion_forward(params, ed, float(fractions[target]))
                start = time.perf_counter()
                transform = register_frames(frames[0], frames[target], affine, settings)
                seconds = time.perf_counter() - start
                moved = np.array([transform.TransformPoint(tuple(p)) for p in ed])
                true, got = truth - ed, moved - ed
                rows.append((
                    "yes" if tagging else "no", name, target,
                    float(np.linalg.norm(true, axis=1).mean()),
                    float(np.linalg.norm(moved - truth, axis=1).mean()),
                    float((got * true).sum() / (true * true).sum()), seconds,
                ))  # fmt: skip
                print(rows[-1], flush=True)
    return rows


def _table(rows) -> str:
    lines = [
        "| tagging | settings | frames 0 to | true motion (mm) | error (mm) | recovered "
        "fraction | seconds |",
        "|---|---|---|---|---|---|---|",
    ]
    for tag, name, target, motion, error, fraction, seconds in rows:
        lines.append(f"| {tag} | {name} | {target} | {motion:.2f} | {error:.2f} | "
                     f"{fraction:.2f} | {seconds:.1f} |")  # fmt: skip
    note = (
        f"One synthetic subject, short-axis stack of 1.5 x 1.5 x 8 mm, {N_FRAMES} frames of "
        f"the cycle; the benchmark's settings: control points {SETTINGS.control_point_spacing:g}"
        f" mm apart, {SETTINGS.iterations} iterations per level, shrink "
        f"{SETTINGS.shrink_factors}, sampling {SETTINGS.sampling_percentage:g}."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    publishing_main("cine_steps", __doc__, lambda: _table(run()), argv)


if __name__ == "__main__":
    main()
