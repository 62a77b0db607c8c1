"""What sets the power of the mild hypokinesia's peak test through each route.

    python benchmarks/bench_cycle_power.py --routes WORK_ROUTES --cine WORK_CINE [--publish]

Reads what ``bench_cycle_routes.py --work WORK_ROUTES`` and ``bench_cycle_cine.py --work
WORK_CINE --cohorts hypokinesia_mild`` tracked (the label series with the landmark table,
and the tagged and plain cine series; a route not tracked is left out) and, on the same
40 subjects, the true frames. For each motion, with every map smoothed on the atlas
(``compare_cycles(..., fwhm=...)``: none, 10 and 20 mm) and over every vertex or
without the apical cap (AHA segment 17), the peak test of the normal motion
(:func:`~ladders.study.sequences.compare_cycles`, 5,000 permutations, one random stream
per cell):

* the threshold of the family-wise error at 5 %: the 95th percentile of the
  permutations' maximum ``|t|`` over the vertices tested;
* the mean ``|t|`` over the planted region, and the power (the region's fraction
  found);
* over the planted region, the peak's group difference (patients minus controls, mm),
  the pooled standard deviation within the groups (mm) and their ratio (the effect
  size), each the mean over the region's vertices;
* the peak's group difference over the vertices outside the region and within 5 mm of
  it: an effect blurred across the region's border by the tracking grows there;
* the standard deviation over the subjects of the tracked peak minus the true frames'
  peak at the same atlas vertex (mm, mean over the vertices): what the tracking adds to
  each subject's map; and that difference's mean over the region per group: a group
  difference the tracking shrinks without moving it across the border shows as an
  error of one group larger than the other's.

A second table keeps every tracked curve to its first ``K`` Fourier harmonics over the
periodic cycle before the peak is taken (``K`` = 2, 3, 5, 8; the first tracked frame is
subtracted again after the smoothing): if the tracking's error of a vertex changed
from frame to frame, smoothing in time would shrink it and lower the threshold; if
it is the same at every frame of a subject, neither moves.

The power at 20 against 20 with the maximum statistic is set by the region's ``t``
against the threshold; the tracking lowers the first (the group difference it loses,
the spread it adds) and raises the second (errors that differ from vertex to vertex
make the maximum over the vertices larger).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_cycle_cine as cine  # noqa: E402
import bench_cycle_routes as routes  # noqa: E402
from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import detection_power, vertexwise_test  # noqa: E402
from ladders.study.meshes.mesh_io import read_mesh  # noqa: E402
from ladders.study.sequences import CycleMotion, compare_cycles, curve_peaks  # noqa: E402

COHORT = "hypokinesia_mild"
FWHMS = (None, 10.0, 20.0)
#: Width of the band of atlas vertices around the planted region (mm).
BAND = 5.0
PERMUTATIONS = 5000


def _motions(routes_work: Path | None, cine_work: Path | None, n: int, n_frames: int):
    """(label, names, frames) of every route tracked, the true frames first."""
    c = routes._cycles(COHORT, n, n_frames)
    out = [("true frames (meshes in correspondence)", list(c.names), c.frames)]
    root = None if routes_work is None else routes_work / f"{COHORT}_landmarks"
    if root is not None and (root / "tracked").is_dir():
        names, frames, _ = routes._tracked(root, c)
        out.append(("label series with landmarks, tracked", names, frames))
    for kind in cine.IMAGES:
        root = None if cine_work is None else cine_work / f"{COHORT}_{kind}"
        if root is not None and (root / "tracked").is_dir():
            names, frames = cine._tracked(root, c)
            out.append((f"{kind} cine, tracked", names, frames))
    return c, out


def _region_effect(peaks, labels, region, band) -> tuple[float, float, float, float]:
    difference, pooled = cine.group_difference(peaks[:, region], labels)
    outside = cine.group_difference(peaks[:, band], labels)[0]
    return (float(difference.mean()), float(pooled.mean()), float((difference / pooled).mean()),
            float(outside.mean()))  # fmt: skip


def rows(routes_work, cine_work, n: int, n_frames: int) -> list[tuple]:
    c, motions = _motions(routes_work, cine_work, n, n_frames)
    atlas, faces = read_mesh(Path(routes_work) / f"{COHORT}_landmarks" / "cohort" / "atlas.vtk")
    cap = ~routes._apical_cap(atlas, faces)
    region = c.data.region.affected
    gap = cKDTree(atlas[region]).query(atlas)[0]
    band = ~region & (gap < BAND)
    out = []
    for m_index, (label, names, frames) in enumerate(motions):
        rows_of = [c.names.index(s) for s in names]
        labels = np.array([c.patients[i] for i in rows_of])
        motion = CycleMotion(tuple(names), frames - frames[:, :1], atlas, faces)
        truth = CycleMotion(tuple(names), c.frames[rows_of] - c.frames[rows_of, :1], atlas, faces)
        for f_index, fwhm in enumerate(FWHMS):
            peaks = curve_peaks(motion.curves(fwhm=fwhm))[0]
            error = peaks - curve_peaks(truth.curves(fwhm=fwhm))[0]
            added = error.std(axis=0, ddof=1).mean()
            # where the group difference goes: each group's error of the peak in the region
            bias = (float(error[labels][:, region].mean()), float(error[~labels][:, region].mean()))
            effect = _region_effect(peaks, labels, region, band)
            for t_index, tested in enumerate((None, cap)):
                rng = np.random.default_rng([m_index, f_index, t_index])
                tests = compare_cycles(motion, labels, PERMUTATIONS, rng, vertices=tested,
                                       fwhm=fwhm, summaries=("peak",))  # fmt: skip
                reg = region if tested is None else region & tested
                found = tests.peak.p_fwer < 0.05
                threshold = float(np.quantile(tests.peak.max_null, 0.95))
                mean_t = float(np.abs(tests.peak.statistic[reg]).mean())
                out.append((label, fwhm, tested is not None, threshold, mean_t,
                            detection_power(found[reg], reg[reg]), *effect,
                            *((None, None) if label.startswith("true") else (float(added), bias))))  # fmt: skip
                print(out[-1], flush=True)
    return out


#: Fourier harmonics kept by the second table's smoothing in time (None: not smoothed).
HARMONICS = (None, 2, 3, 5, 8)


def smooth_in_time(curves: np.ndarray, harmonics: int) -> np.ndarray:
    """Each curve ``(n, T, k)`` kept to its first ``harmonics`` Fourier harmonics over the
    periodic cycle, then moved so that its first frame is 0 again."""
    spectrum = np.fft.rfft(curves, axis=1)
    spectrum[:, harmonics + 1 :] = 0.0
    smooth = np.fft.irfft(spectrum, n=curves.shape[1], axis=1)
    return smooth - smooth[:, :1]


def time_rows(routes_work, cine_work, n: int, n_frames: int) -> list[tuple]:
    """Per tracked motion and :data:`HARMONICS`: the threshold, the region's mean ``|t|``, the
    power of the peak test and the SD of the tracked peak minus the true one."""
    c, motions = _motions(routes_work, cine_work, n, n_frames)
    atlas, faces = read_mesh(Path(routes_work) / f"{COHORT}_landmarks" / "cohort" / "atlas.vtk")
    region = c.data.region.affected
    out = []
    for m_index, (label, names, frames) in enumerate(motions[1:], start=1):
        rows_of = [c.names.index(s) for s in names]
        labels = np.array([c.patients[i] for i in rows_of])
        curves = CycleMotion(tuple(names), frames - frames[:, :1], atlas, faces).curves()
        truth = CycleMotion(tuple(names), c.frames[rows_of] - c.frames[rows_of, :1], atlas,
                            faces)  # fmt: skip
        true_peaks = curve_peaks(truth.curves())[0]
        for h_index, harmonics in enumerate(HARMONICS):
            kept = curves if harmonics is None else smooth_in_time(curves, harmonics)
            peaks = curve_peaks(kept)[0]
            test = vertexwise_test(peaks, labels, PERMUTATIONS,
                                   np.random.default_rng([m_index, h_index]))  # fmt: skip
            found = test.p_fwer < 0.05
            out.append((label, harmonics, float(np.quantile(test.max_null, 0.95)),
                        float(np.abs(test.statistic[region]).mean()),
                        detection_power(found[region], region[region]),
                        float((peaks - true_peaks).std(axis=0, ddof=1).mean())))  # fmt: skip
            print(out[-1], flush=True)
    return out


def _time_table(rows) -> str:
    lines = [
        "| motion | curves kept to (Fourier harmonics) | FWER threshold of the maximum |t| | "
        "mean |t| over the region | power | tracked minus true peak: SD over the subjects "
        "(mm) |",
        "|---|---|---|---|---|---|",
    ]
    for label, harmonics, threshold, mean_t, power, added in rows:
        kept = "all frames as tracked" if harmonics is None else f"{harmonics}"
        lines.append(f"| {label} | {kept} | {threshold:.2f} | {mean_t:.2f} | {power:.2f} | "
                     f"{added:.2f} |")  # fmt: skip
    note = (
        "The same tracked motions, every curve kept to its first harmonics over the "
        "periodic cycle before its peak is taken (maps not smoothed, every vertex tested; "
        f"peak test, {PERMUTATIONS:,} permutations, FWER 5 %)."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def _table(rows) -> str:
    lines = [
        "| motion | maps smoothed (FWHM) | vertices tested | FWER threshold of the maximum "
        "|t| | mean |t| over the region | power | region: group difference (mm) | region: "
        "SD within the groups (mm) | region: effect size | group difference within "
        f"{BAND:g} mm outside the region (mm) | tracked minus true peak: SD over the "
        "subjects (mm) | region: tracked minus true peak, patients / controls (mm) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for label, fwhm, no_cap, threshold, mean_t, power, diff, sd, size, outside, added, bias in rows:
        smoothed = "none" if fwhm is None else f"{fwhm:g} mm"
        tested = "without segment 17" if no_cap else "all"
        extra = "truth" if added is None else f"{added:.2f}"
        biased = "truth" if bias is None else f"{bias[0]:+.2f} / {bias[1]:+.2f}"
        lines.append(f"| {label} | {smoothed} | {tested} | {threshold:.2f} | {mean_t:.2f} | "
                     f"{power:.2f} | {diff:.2f} | {sd:.2f} | {size:.2f} | {outside:.2f} | "
                     f"{extra} | {biased} |")  # fmt: skip
    note = (
        "The whole-cycle mild hypokinesia (a fifth of the motion in segments 7, 8, 13, 14), "
        "20 patients against 20 controls, 25 frames, short-axis series of 1.5 x 1.5 x 8 mm; "
        "the routes of `cycle_routes` (label series, correspondence with the landmark "
        "table, no transport) and `cycle_cine` (the true ED mesh tracked through cine). "
        f"Peak test of the normal motion, {PERMUTATIONS:,} permutations, FWER 5 %. Region "
        "columns: means over the planted region's vertices of the peak's group difference, "
        "pooled within-group SD and their ratio; the peak's group difference over the atlas "
        f"vertices outside the region and within {BAND:g} mm of it (a blur of the effect "
        "across the region's border shows there); the last column: the SD over the subjects "
        "of each tracked peak minus the true frames' peak at the same atlas vertex, mean "
        "over the vertices, and that difference's mean over the region's vertices and each "
        "group's subjects (positive: more inward motion tracked than true)."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--routes", type=Path, required=True,
                        help="the --work folder of bench_cycle_routes.py")  # fmt: skip
    parser.add_argument("--cine", type=Path, default=None,
                        help="the --work folder of bench_cycle_cine.py")  # fmt: skip
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    table = _table(rows(args.routes, args.cine, 40, 25))
    table += "\n" + _time_table(time_rows(args.routes, args.cine, 40, 25))
    print("\n" + table)
    if args.publish:
        publish("cycle_power", table, "python benchmarks/bench_cycle_power.py --routes "
                "WORK_ROUTES --cine WORK_CINE --publish")  # fmt: skip


if __name__ == "__main__":
    main()
