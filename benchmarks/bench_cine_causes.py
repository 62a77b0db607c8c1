"""Why the cine route misses the motion along the wall: the B-spline, the metric or the optimiser.

    python benchmarks/bench_cine_causes.py [--publish]    # docs/generated/cine_causes.md

The first subject of ``bench_cine_tracking.py`` on its short-axis stack of
1.5 x 1.5 x 8 mm (25 frames, noise 0.02, with and without tagging, the benchmark's
settings), tracked to end-systole (ES) with every frame registered to ED (the forward
chain of ``reference="ed"``). Three questions, each answered against the truth:

1. **Can the B-spline hold the true motion?** The cubic B-spline on the tracking's
   control grid (``identity_bspline``) is fitted by weighted least squares to the true displacement
   (``motion_forward``) at the voxel centres of a grid of every second voxel in-plane
   and every slice, voxels within 15 mm of the ED mesh weighted 1 and the others 0.01.
   Its error at the ED vertices, split along the true ES normals and across them, and
   its twist error, are the representation's floor.
2. **Does the metric prefer the truth?** The mean squared difference between the ED
   frame and the ES frame pulled back by a map, over the voxels the tracking's metric
   samples (within ``mask_distance`` of the ED mesh; linear interpolation): for the identity, the true motion and the tracked one
   (every such voxel centre tracked as a point), and the best B-spline of question 1.
3. **What the tracking reached:** the same errors for the tracked vertices, and their
   error along the long axis (through the slices) and about it (circumferential).

A fit whose metric is higher than the truth's, with a representation floor far below
its error, points at the optimisation, not at the transform model or the metric. Each
tracking runs with the default image gradient of the metric's derivative (central
differences) and with ITK's Gaussian derivative (``image_gradient="gaussian"``, sigma
the largest voxel spacing, 8 mm here), the setting of the earlier tracking. A third
series renders the same subject without tags and with its radial contraction made
uniform about the long axis (``contraction_heterogeneity=0``: the same ED shape), to
separate what turns the plain images' tracked section about the axis.
"""

from __future__ import annotations

import dataclasses
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.ndimage import map_coordinates
from scipy.spatial import cKDTree

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_cine_tracking import GRIDS, SETTINGS, grid, split_error, twist  # noqa: E402
from generated_tables import publishing_main  # noqa: E402

from ladders.study.cohort import cycle_fraction, make_synthetic_cohort, motion_forward  # noqa: E402
from ladders.study.imaging import (  # noqa: E402
    TagGrid,
    render_cine,
    voxel_centres,  # noqa: E402
)
from ladders.study.tracking import identity_bspline, image_from_array, track_cine, wall_mask  # noqa: E402

N_FRAMES = 25


def best_bspline(frame, affine, shape, params, ed, f):
    """Least-squares B-spline of the true motion on the tracking's control grid.

    Sampled at voxel centres about 3 mm apart (every second voxel of 1.5 mm, every
    slice of 8 mm). Returns the ``SimpleITK.BSplineTransform``."""
    import SimpleITK as sitk

    transform = identity_bspline(image_from_array(frame, affine), SETTINGS.control_point_spacing)
    n_params = transform.GetNumberOfParameters()
    step = np.maximum(1, np.round(3.0 / np.abs(np.diag(affine)[:3]))).astype(int)
    sample = [int(shape[i] // step[i]) for i in range(3)]
    sample_affine = affine @ np.diag([*step, 1.0])  # the grid is axis-aligned
    spacing = np.diag(sample_affine)[:3].tolist()
    origin = affine[:3, 3].tolist()
    basis = []
    for k in range(n_params // 3):  # the x-coefficients' basis; y and z share it
        p = np.zeros(n_params)
        p[k] = 1.0
        transform.SetParameters(tuple(p))
        field = sitk.TransformToDisplacementField(
            transform, sitk.sitkVectorFloat64, sample, origin, spacing, [1, 0, 0, 0, 1, 0, 0, 0, 1]
        )
        basis.append(sitk.GetArrayFromImage(field)[..., 0].transpose(2, 1, 0).reshape(-1))
    b = np.stack(basis, 1)
    x = voxel_centres(sample_affine, sample)
    y = motion_forward(params, x, f)
    w = np.where(cKDTree(ed).query(x)[0] < 15.0, 1.0, 0.01)
    coef = [np.linalg.lstsq(b * w[:, None], (y - x)[:, d] * w, rcond=None)[0] for d in range(3)]
    transform.SetParameters(tuple(np.concatenate(coef)))
    return transform


def moved(transform, points) -> np.ndarray:
    """``points`` (k, 3) moved by a SimpleITK transform."""
    return np.array([transform.TransformPoint(tuple(map(float, p))) for p in points])


def _best_bspline(frame, affine, shape, params, ed, f, near):
    """The ED vertices and the points ``near`` moved by :func:`best_bspline`."""
    transform = best_bspline(frame, affine, shape, params, ed, f)
    return moved(transform, ed), moved(transform, near)


def wall_metric(ed_frame, frame, affine, near):
    """The metric near the wall: ``mapped`` (the points ``near`` moved to ``frame``) -> the
    mean squared difference between ``ed_frame`` at ``near`` and ``frame`` at ``mapped``
    (linear interpolation)."""
    inverse = np.linalg.inv(affine[:3, :3])
    ed_values = map_coordinates(ed_frame, ((near - affine[:3, 3]) @ inverse.T).T, order=1)

    def metric(mapped) -> float:
        j = (mapped - affine[:3, 3]) @ inverse.T
        values = map_coordinates(frame, j.T, order=1, mode="nearest")
        return float(np.mean((values - ed_values) ** 2))

    return metric


def cylindrical_error(moved, truth, ed) -> tuple[float, float]:
    """Mean error along the long axis (z) and about it (circumferential), mm."""
    error = moved - truth
    theta = np.arctan2(ed[:, 1], ed[:, 0])
    circumferential = -error[:, 0] * np.sin(theta) + error[:, 1] * np.cos(theta)
    return float(np.abs(error[:, 2]).mean()), float(np.abs(circumferential).mean())


def run() -> list[tuple]:
    cohort = make_synthetic_cohort(1, n_vertices=241, seed=0)
    subject = cohort.subjects[0]
    params, ed = subject.parameters, np.asarray(subject.ed, float)
    es = int(round(0.35 * N_FRAMES))
    fractions = cycle_fraction(np.arange(N_FRAMES) / N_FRAMES, es / N_FRAMES)
    affine, shape = grid(GRIDS["short-axis 1.5 x 1.5 x 8 mm"])
    voxels = voxel_centres(affine, shape)
    settings = replace(SETTINGS, reference="ed", combine="forward")
    near = voxels[cKDTree(ed).query(voxels)[0] < settings.mask_distance]  # the metric's voxels
    uniform = dataclasses.replace(params, contraction_heterogeneity=0.0)  # same ED shape
    cases = (("yes", TagGrid(), params, ("central_difference", "gaussian")),
             ("no", None, params, ("central_difference", "gaussian")),
             ("no, contraction uniform about the axis", None, uniform, ("central_difference",)))  # fmt: skip
    rows = []
    for name, tagging, p, gradients in cases:
        rng = np.random.default_rng(100)  # the draws of bench_cine_tracking's first subject
        series = np.stack([render_cine(p, affine, shape, f, rng, noise=0.02,
                                       tagging=tagging, supersample=2)
                           for f in fractions[: es + 1]])  # fmt: skip
        metric = wall_metric(series[0], series[es], affine, near)

        truth_es = motion_forward(p, ed, fractions[es])
        points = np.concatenate([ed, near])
        mask = wall_mask(shape, affine, ed, settings.mask_distance)  # the mesh's, as tracked
        best, best_near = _best_bspline(series[0], affine, shape, p, ed, fractions[es], near)
        truth_twist = twist(p, ed, truth_es)
        for gradient in gradients:
            tracked = track_cine(series, affine, points, replace(settings, image_gradient=gradient),
                                 mask=mask)[es]  # fmt: skip
            fit_ed, fit_near = tracked[: len(ed)], tracked[len(ed) :]
            rows.append((
                name, gradient.replace("_", " "),
                *split_error(fit_ed, truth_es, cohort.faces), abs(twist(p, ed, fit_ed) - truth_twist),
                *cylindrical_error(fit_ed, truth_es, ed),
                *split_error(best, truth_es, cohort.faces), abs(twist(p, ed, best) - truth_twist),
                metric(near), metric(motion_forward(p, near, fractions[es])),
                metric(best_near), metric(fit_near),
            ))  # fmt: skip
            print(rows[-1], flush=True)
    return rows


def _table(rows) -> str:
    lines = [
        "| tagging | image gradient | tracked: normal / tangential error (mm), twist error "
        "(deg) | tracked: error along the long axis / circumferential (mm) | best B-spline "
        "of the truth: normal / tangential (mm), twist error (deg) | metric near the wall: "
        "identity / truth / best B-spline / tracked (x 1e-3) |",
        "|---|---|---|---|---|---|",
    ]
    for tag, gradient, fn, ft, fw, fz, fc, bn, bt, bw, mi, mt, mb, mf in rows:
        lines.append(
            f"| {tag} | {gradient} | {fn:.2f} / {ft:.2f}, {fw:.2f} | {fz:.2f} / {fc:.2f} | {bn:.2f} / {bt:.2f}, {bw:.2f} | "
            f"{1e3 * mi:.2f} / {1e3 * mt:.2f} / {1e3 * mb:.2f} / {1e3 * mf:.2f} |"
        )
    note = (
        f"One synthetic subject, short-axis stack of 1.5 x 1.5 x 8 mm, {N_FRAMES} frames, "
        f"at ES; control points {SETTINGS.control_point_spacing:g} mm apart, sampling "
        f"{SETTINGS.sampling_percentage:g}, every frame registered to ED from its neighbour's "
        "fit. Metric: mean squared intensity difference between ED and ES pulled back, over "
        f"the voxels within {SETTINGS.mask_distance:g} mm of the ED mesh (those the tracking's "
        "metric samples)."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    publishing_main("cine_causes", __doc__, lambda: _table(run()), argv)


if __name__ == "__main__":
    main()
