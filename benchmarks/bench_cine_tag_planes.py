"""What the cine route recovers along the long axis with tag planes across it.

    python benchmarks/bench_cine_tag_planes.py [--publish]   # docs/generated/cine_tag_planes.md

The tags of a short-axis tagged series (:class:`~ladders.study.imaging.TagGrid`'s
default, planes ``x = k s`` and ``y = k s``) contain the long axis: the shortening
along it leaves them in place, and ``cine_causes`` finds most of the tracked error
along the wall to be along the long axis. This benchmark tests that cause against the
truth by adding what would show that motion: tag planes across the long axis
(``TagGrid(axes=(0, 1, 2))``, 3-D tagging) and a through-plane voxel fine enough to
resolve them.

The subject, the frames, the noise and the settings are those of ``cine_causes``
(the first subject of ``bench_cine_tracking.py``, 25 frames, tracked to end-systole
with every frame registered to ED from its neighbour's fit, central differences),
rendered on the short-axis stack of 1.5 x 1.5 x 8 mm and on an isotropic grid of
1.5 mm, with the in-plane tags, with 3-D tags and (isotropic) without tags. Measured at
ES against the true motion: the error along the true surface's normal and along the
wall, the twist error, and the error along the long axis and about it.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_cine_causes import N_FRAMES, cylindrical_error  # noqa: E402
from bench_cine_tracking import GRIDS, SETTINGS, grid, split_error, twist  # noqa: E402
from generated_tables import publishing_main  # noqa: E402

from ladders.study.cohort import cycle_fraction, make_synthetic_cohort, motion_forward  # noqa: E402
from ladders.study.imaging import TagGrid, render_cine  # noqa: E402
from ladders.study.tracking import track_cine, wall_mask  # noqa: E402

SHORT_AXIS, ISOTROPIC = "short-axis 1.5 x 1.5 x 8 mm", "isotropic 1.5 mm"
CASES = (
    (SHORT_AXIS, "in-plane grid (default)", TagGrid()),
    (SHORT_AXIS, "3-D (also across the long axis)", TagGrid(axes=(0, 1, 2))),
    (ISOTROPIC, "none", None),
    (ISOTROPIC, "in-plane grid (default)", TagGrid()),
    (ISOTROPIC, "3-D (also across the long axis)", TagGrid(axes=(0, 1, 2))),
)


def run() -> list[tuple]:
    cohort = make_synthetic_cohort(1, n_vertices=241, seed=0)
    subject = cohort.subjects[0]
    params, ed = subject.parameters, np.asarray(subject.ed, float)
    es = int(round(0.35 * N_FRAMES))
    fractions = cycle_fraction(np.arange(N_FRAMES) / N_FRAMES, es / N_FRAMES)
    settings = replace(SETTINGS, reference="ed", combine="forward")
    truth = motion_forward(params, ed, fractions[es])
    rows = []
    for acquisition, tags, tagging in CASES:
        affine, shape = grid(GRIDS[acquisition])
        rng = np.random.default_rng(100)  # the draws of cine_causes
        series = np.stack([render_cine(params, affine, shape, f, rng, noise=0.02,
                                       tagging=tagging, supersample=2)
                           for f in fractions[: es + 1]])  # fmt: skip
        mask = wall_mask(shape, affine, ed, settings.mask_distance)
        tracked = track_cine(series, affine, ed, settings, mask=mask)[es]
        rows.append((
            acquisition, tags, *split_error(tracked, truth, cohort.faces),
            abs(twist(params, ed, tracked) - twist(params, ed, truth)),
            *cylindrical_error(tracked, truth, ed),
        ))  # fmt: skip
        print(rows[-1], flush=True)
    return rows


def _table(rows) -> str:
    lines = [
        "| acquisition | tagging | normal / along the wall error (mm) | twist error (deg) | "
        "error along the long axis / circumferential (mm) |",
        "|---|---|---|---|---|",
    ]
    for acquisition, tags, normal, along, twist_error, axial, circ in rows:
        lines.append(f"| {acquisition} | {tags} | {normal:.2f} / {along:.2f} | "
                     f"{twist_error:.2f} | {axial:.2f} / {circ:.2f} |")  # fmt: skip
    note = (
        f"The subject of `cine_causes`, {N_FRAMES} frames, noise 0.02, tracked to ES (every "
        f"frame registered to ED from its neighbour's fit); control points "
        f"{SETTINGS.control_point_spacing:g} mm apart, sampling "
        f"{SETTINGS.sampling_percentage:g}, {SETTINGS.iterations} iterations per level, the "
        f"metric sampling the voxels within {SETTINGS.mask_distance:g} mm of the ED mesh; tag "
        "planes 7 mm apart. Errors at ES against the true motion, means over the 241 "
        "vertices."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    publishing_main("cine_tag_planes", __doc__, lambda: _table(run()), argv)


if __name__ == "__main__":
    main()
