"""Why the plain isotropic cine series is followed worse along the long axis, and the remedy.

    python benchmarks/bench_cine_isotropic.py [--rows N] [--publish]   # docs/generated/cine_isotropic.md

The plain isotropic series is followed worse along the long axis than the plain short-
axis stack (``cine_tag_planes``, ``cine_causes``). The same subject and settings, one
factor swapped at a time between the two acquisitions (the metric's samples, its mask,
the pyramid, the control grid, the images themselves: the short-axis frames
interpolated onto the isotropic grid), the base left out of the metric, each ES frame
registered to ED once from the identity and from the least-squares B-spline of the
truth (an oracle start), and the prediction of a tracking that moves the wall along
its normals only (the true motion's component along the ED normals: what a plain image
shows of a smooth wall); then the remedy, an affine stage before the B-spline
(``affine_stage``), on plain and tagged series, and on the plain series of the
cohort's next two subjects. Reported besides the errors: the mid-wall's motion along
the wall towards the base (the ED vertices 20 to 60 mm above the apex, the
displacement's component along the ED surface in the plane of the long axis), tracked
and true, and the metric near the wall at ES for the tracked map and the true one.
Each row is kept in ``--work`` as it is measured (a rerun resumes; ``--rows N``
measures at most ``N`` missing rows and stops).
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_cine_causes import (  # noqa: E402
    N_FRAMES,
    best_bspline,
    cylindrical_error,
    moved,
    wall_metric,
)
from bench_cine_tag_planes import ISOTROPIC, SHORT_AXIS  # noqa: E402
from bench_cine_tracking import GRIDS, SETTINGS, grid, split_error, twist  # noqa: E402
from generated_tables import machine, publish  # noqa: E402
from scipy.ndimage import map_coordinates  # noqa: E402

from ladders.study.cohort import cycle_fraction, make_synthetic_cohort, motion_forward  # noqa: E402
from ladders.study.imaging import TagGrid, render_cine, voxel_centres  # noqa: E402
from ladders.study.tracking import image_from_array, track_cine, wall_mask  # noqa: E402
from ladders.study.tracking.cine_images import _mask_image  # noqa: E402
from ladders.study.tracking.cine_registration import register_images  # noqa: E402
from ladders.study.wall_motion import outward_vertex_normals  # noqa: E402

#: The rows: (key, acquisition, images, what is changed, the change)
SA_STACK = SHORT_AXIS
ISO_ROWS = (
    ("sa", SA_STACK, "plain", "nothing (the settings above)", {}),
    ("iso", ISOTROPIC, "plain", "nothing (the settings above)", {}),
    ("iso_samples", ISOTROPIC, "plain", "as many samples as the stack's", {"samples": True}),
    ("iso_sa_mask", ISOTROPIC, "plain", "the stack's mask (nearest voxel)", {"mask": "sa"}),
    ("sa_no_mask", SA_STACK, "plain", "no mask (every voxel)", {"mask": "none"}),
    ("iso_no_mask", ISOTROPIC, "plain", "no mask (every voxel)", {"mask": "none"}),
    ("sa_one_level", SA_STACK, "plain", "one level (no pyramid)", {"one_level": True}),
    ("iso_one_level", ISOTROPIC, "plain", "one level (no pyramid)", {"one_level": True}),
    ("sa_cps40", SA_STACK, "plain", "control points 40 mm apart", {"spacing": 40.0}),
    ("iso_cps40", ISOTROPIC, "plain", "control points 40 mm apart", {"spacing": 40.0}),
    (
        "iso_sa_images",
        ISOTROPIC,
        "the stack's frames, interpolated",
        "the images",
        {"images": "sa"},
    ),
    ("sa_no_base", SA_STACK, "plain", "no sample above 60 mm (the base)", {"mask": "no_base"}),
    ("iso_no_base", ISOTROPIC, "plain", "no sample above 60 mm (the base)", {"mask": "no_base"}),
    ("sa_once", SA_STACK, "plain", "ES registered once, from the identity", {"start": "identity"}),
    (
        "iso_once",
        ISOTROPIC,
        "plain",
        "ES registered once, from the identity",
        {"start": "identity"},
    ),
    (
        "sa_oracle",
        SA_STACK,
        "plain",
        "ES registered once, from the truth's B-spline",
        {"start": "truth"},
    ),
    (
        "iso_oracle",
        ISOTROPIC,
        "plain",
        "ES registered once, from the truth's B-spline",
        {"start": "truth"},
    ),
    (
        "normal_flow",
        "any",
        "plain",
        "the true motion along the ED normals only (no tracking)",
        {"normal_flow": True},
    ),
    ("sa_affine", SA_STACK, "plain", "affine stage (`affine_stage=True`)", {"affine": True}),
    ("iso_affine", ISOTROPIC, "plain", "affine stage (`affine_stage=True`)", {"affine": True}),
    (
        "sa_s1",
        SA_STACK,
        "plain, the cohort's subject 2",
        "nothing (the settings above)",
        {"subject": 1},
    ),
    (
        "sa_s1_affine",
        SA_STACK,
        "plain, the cohort's subject 2",
        "affine stage (`affine_stage=True`)",
        {"subject": 1, "affine": True},
    ),
    (
        "iso_s1",
        ISOTROPIC,
        "plain, the cohort's subject 2",
        "nothing (the settings above)",
        {"subject": 1},
    ),
    (
        "iso_s1_affine",
        ISOTROPIC,
        "plain, the cohort's subject 2",
        "affine stage (`affine_stage=True`)",
        {"subject": 1, "affine": True},
    ),
    (
        "sa_s2",
        SA_STACK,
        "plain, the cohort's subject 3",
        "nothing (the settings above)",
        {"subject": 2},
    ),
    (
        "sa_s2_affine",
        SA_STACK,
        "plain, the cohort's subject 3",
        "affine stage (`affine_stage=True`)",
        {"subject": 2, "affine": True},
    ),
    (
        "iso_s2",
        ISOTROPIC,
        "plain, the cohort's subject 3",
        "nothing (the settings above)",
        {"subject": 2},
    ),
    (
        "iso_s2_affine",
        ISOTROPIC,
        "plain, the cohort's subject 3",
        "affine stage (`affine_stage=True`)",
        {"subject": 2, "affine": True},
    ),
    ("sa_tagged", SA_STACK, "tagged", "nothing (the settings above)", {}),
    (
        "sa_tagged_affine",
        SA_STACK,
        "tagged",
        "affine stage (`affine_stage=True`)",
        {"affine": True},
    ),
    ("iso_tagged", ISOTROPIC, "tagged", "nothing (the settings above)", {}),
    (
        "iso_tagged_affine",
        ISOTROPIC,
        "tagged",
        "affine stage (`affine_stage=True`)",
        {"affine": True},
    ),
)
MID_WALL = (20.0, 60.0)  # mm above the apex (ED): the mid-wall of the 80 mm ventricle
BASE_CUT = 60.0  # mm: "no sample above" the base's region


class _Subject:
    """The subject of ``cine_causes`` and its frames to ES, rendered once into ``work``."""

    def __init__(self, work: Path, index: int = 0):
        cohort = make_synthetic_cohort(index + 1, n_vertices=241, seed=0)
        self.faces = cohort.faces
        self.params = cohort.subjects[index].parameters
        self.ed = np.asarray(cohort.subjects[index].ed, float)
        self.index = index
        self.es = int(round(0.35 * N_FRAMES))
        self.fractions = cycle_fraction(np.arange(N_FRAMES) / N_FRAMES, self.es / N_FRAMES)
        self.truth = motion_forward(self.params, self.ed, self.fractions[self.es])
        n = outward_vertex_normals(self.ed, self.faces)
        along = np.array([0.0, 0.0, 1.0]) - n[:, 2:3] * n  # the long axis along the wall
        self.normals, self.meridian = n, along / np.linalg.norm(along, axis=1)[:, None]
        self.mid = (self.ed[:, 2] >= MID_WALL[0]) & (self.ed[:, 2] < MID_WALL[1])
        self.work = work

    def series(self, acquisition: str, tagged: bool) -> np.ndarray:
        kind = "tagged" if tagged else "plain"
        path = self.work / f"series_{self.index}_{acquisition.split()[0]}_{kind}.npy"
        if path.is_file():
            return np.load(path)
        affine, shape = grid(GRIDS[acquisition])
        rng = np.random.default_rng(100 + self.index)  # subject 0: the draws of cine_causes
        frames = np.stack([render_cine(self.params, affine, shape, f, rng, noise=0.02,
                                       tagging=TagGrid() if tagged else None, supersample=2)
                           for f in self.fractions[: self.es + 1]])  # fmt: skip
        self.work.mkdir(parents=True, exist_ok=True)
        np.save(path, frames)
        return frames

    def along_mid(self, points) -> float:
        """Mean motion of the mid-wall along the wall towards the base (mm)."""
        d = points - self.ed
        return float(np.einsum("ij,ij->i", d, self.meridian)[self.mid].mean())


def _stack_on_isotropic(subject: _Subject, tagged: bool) -> np.ndarray:
    """The short-axis frames linearly interpolated onto the isotropic grid."""
    a_sa, _ = grid(GRIDS[SA_STACK])
    a_iso, shape = grid(GRIDS[ISOTROPIC])
    index = (voxel_centres(a_iso, shape) - a_sa[:3, 3]) @ np.linalg.inv(a_sa[:3, :3]).T
    return np.stack([map_coordinates(frame, index.T, order=1, mode="nearest").reshape(shape)
                     for frame in subject.series(SA_STACK, tagged)])  # fmt: skip


def _mask(subject: _Subject, kind: str, affine, shape):
    ed = subject.ed
    if kind == "none":
        return None
    mask = wall_mask(shape, affine, ed, SETTINGS.mask_distance)
    if kind == "no_base":
        mask[voxel_centres(affine, shape)[:, 2].reshape(shape) > BASE_CUT] = 0
    elif kind == "sa":  # the stack's mask, each voxel taking its nearest stack voxel's
        a_sa, shape_sa = grid(GRIDS[SA_STACK])
        index = (voxel_centres(affine, shape) - a_sa[:3, 3]) @ np.linalg.inv(a_sa[:3, :3]).T
        sa = wall_mask(shape_sa, a_sa, ed, SETTINGS.mask_distance).astype(float)
        mask = map_coordinates(sa, index.T, order=0).reshape(shape).astype(np.uint8)
    return mask


def _isotropic_row(subject: _Subject, acquisition: str, images: str, change: dict) -> dict:
    ed, es, truth = subject.ed, subject.es, subject.truth
    out = {}
    if change.get("normal_flow"):
        n = subject.normals
        tracked = ed + np.einsum("ij,ij->i", truth - ed, n)[:, None] * n
        metric = None
    else:
        affine, shape = grid(GRIDS[acquisition])
        tagged = images == "tagged"
        if change.get("images") == "sa":
            series = _stack_on_isotropic(subject, tagged)
        else:
            series = subject.series(acquisition, tagged)
        settings = replace(SETTINGS, reference="ed", combine="forward",
                           affine_stage=bool(change.get("affine")))  # fmt: skip
        if change.get("samples"):  # the stack's count: its mask's voxels over this one's
            a_sa, shape_sa = grid(GRIDS[SA_STACK])
            ratio = (wall_mask(shape_sa, a_sa, ed, SETTINGS.mask_distance).sum()
                     / wall_mask(shape, affine, ed, SETTINGS.mask_distance).sum())  # fmt: skip
            settings = replace(settings, sampling_percentage=SETTINGS.sampling_percentage * ratio)
        if change.get("one_level"):
            settings = replace(settings, shrink_factors=(1,), smoothing_sigmas=(0.0,))
        if "spacing" in change:
            settings = replace(settings, control_point_spacing=change["spacing"])
        kind = change.get("mask", "wall")
        if kind == "none":
            settings = replace(settings, mask_distance=None)
        mask = _mask(subject, kind, affine, shape)
        voxels = voxel_centres(affine, shape)
        near = voxels[wall_mask(shape, affine, ed, SETTINGS.mask_distance).reshape(-1) > 0]
        points = np.concatenate([ed, near])
        if "start" in change:
            fixed = image_from_array(series[0], affine)
            initial = (best_bspline(series[0], affine, shape, subject.params, ed,
                                    subject.fractions[es])
                       if change["start"] == "truth" else None)  # fmt: skip
            transform = register_images(fixed, image_from_array(series[es], affine), settings,
                                        initial, None if mask is None else _mask_image(mask, fixed))  # fmt: skip
            fit = moved(transform, points)
        else:
            fit = track_cine(series, affine, points, settings, mask=mask)[es]
        tracked = fit[: len(ed)]
        metric = wall_metric(series[0], series[es], affine, near)
        out["metric"] = [metric(fit[len(ed) :]),
                         metric(motion_forward(subject.params, near, subject.fractions[es]))]  # fmt: skip
    out["normal"], out["along"] = split_error(tracked, truth, subject.faces)
    out["twist"] = abs(twist(subject.params, ed, tracked) - twist(subject.params, ed, truth))
    out["axial"], out["circumferential"] = cylindrical_error(tracked, truth, ed)
    out["mid"] = subject.along_mid(tracked)
    out["true_mid"] = subject.along_mid(truth)
    return out


def run_isotropic(work: Path, max_rows: int | None = None) -> list | None:
    """The rows, measured or read from ``work``; None when stopped early."""
    subjects = {0: _Subject(work)}
    path = work / "rows_isotropic.json"
    done = json.loads(path.read_text()) if path.is_file() else {}
    measured = 0
    for key, acquisition, images, _, change in ISO_ROWS:
        if key in done:
            continue
        if max_rows is not None and measured >= max_rows:
            return None
        index = change.get("subject", 0)
        if index not in subjects:
            subjects[index] = _Subject(work, index)
        done[key] = _isotropic_row(subjects[index], acquisition, images, change)
        measured += 1
        print(key, done[key], flush=True)
        work.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(done, indent=1))
    return [(row, done[row[0]]) for row in ISO_ROWS], subjects[0].along_mid(subjects[0].truth)


def _isotropic_table(rows, true_mid) -> str:
    lines = [
        "| acquisition | images | changed | normal / along the wall error (mm) | error along "
        "the long axis / circumferential (mm) | twist error (deg) | mid-wall's motion along "
        "the wall (mm) | metric near the wall: tracked / truth (x 1e-3) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for (_, acquisition, images, changed, _), r in rows:
        metric = r.get("metric")
        metric = "-" if metric is None else f"{1e3 * metric[0]:.2f} / {1e3 * metric[1]:.2f}"
        mid = f"{r['mid']:.2f}"
        if abs(r.get("true_mid", true_mid) - true_mid) > 1e-9:  # another subject: its own truth
            mid += f" (truth {r['true_mid']:.2f})"
        lines.append(f"| {acquisition} | {images} | {changed} | {r['normal']:.2f} / "
                     f"{r['along']:.2f} | {r['axial']:.2f} / {r['circumferential']:.2f} | "
                     f"{r['twist']:.2f} | {mid} | {metric} |")  # fmt: skip
    note = (
        f"The subject of `cine_causes` and the settings above (control points "
        f"{SETTINGS.control_point_spacing:g} mm apart, sampling {SETTINGS.sampling_percentage:g}, "
        f"{SETTINGS.iterations} iterations per level, shrink {SETTINGS.shrink_factors}, the "
        f"metric sampling the voxels within {SETTINGS.mask_distance:g} mm of the ED mesh), "
        f"tracked to ES, one factor changed per row. Errors at ES against the true motion, "
        f"means over the 241 vertices. Mid-wall: the ED vertices {MID_WALL[0]:g} to "
        f"{MID_WALL[1]:g} mm above the apex, their mean displacement along the ED surface "
        f"in the plane of the long axis (negative: towards the apex); the truth's is "
        f"{true_mid:.2f} mm. Metric: mean squared difference between ED and ES pulled back "
        "over the voxels within 4 mm of the ED mesh (of the row's grid and images), for the "
        "tracked map and the true one."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--publish",
        action="store_true",
        help="write docs/generated/cine_isotropic.md (default: print only)",
    )
    parser.add_argument(
        "--work",
        type=Path,
        default=Path("symladders-output/bench_cine_isotropic"),
        help="the frames and the rows measured, reused by a rerun "
        "(default: symladders-output/bench_cine_isotropic)",
    )
    parser.add_argument(
        "--rows",
        type=int,
        default=None,
        help="measure at most this many missing rows, then stop (default: all)",
    )
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    result = run_isotropic(args.work, args.rows)
    if result is None:
        print("stopped: rerun to measure the remaining rows")
        return
    table = _isotropic_table(*result)
    print("\n" + table)
    if args.publish:
        publish("cine_isotropic", table, "python benchmarks/bench_cine_isotropic.py --publish")


if __name__ == "__main__":
    main()
