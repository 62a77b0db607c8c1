"""What each setting of label-series tracking does to the motion and to the peak test.

    python benchmarks/bench_tracking_variants.py --work symladders-output/bench_cycle_routes
    python benchmarks/bench_tracking_variants.py --publish   # docs/generated/tracking_variants.md

Reads the mild cohort with landmarks of ``bench_cycle_routes.py`` (run it first, same
``--work``: the label series and the corresponded ED meshes) and tracks it again with
each variant of :class:`~ladders.study.tracking.TrackingSettings` (all with
``refine_ed``), in ``WORK/variants/<variant>/tracked`` (each resumes):

1. the ED mesh as given is frame 0, no detour test, frames meshed with
   ``mask_sigma = 0.5`` (the settings before this benchmark);
2. the same with the detour test (``max_detour = 2`` mm);
3. and the ED mesh moved onto frame 0's surface first (``project_ed``);
4. and the frames meshed with ``mask_sigma = 1.0``;
5. ``mask_sigma = 1.5`` (the defaults).

Per variant, against the truth (the model's motion in the volume): the error at ES of
the tracked vertices, normal and along the wall, and at the last frame; the error of
each vertex's peak inward motion against the true frames' (RMS, mean, and its SD
across subjects in the planted region); the peak test (40 subjects, no transport,
5,000 permutations, FWER 5 %) by the maximum statistic and with TFCE, over every vertex
and without the apical cap (AHA segment 17): power, Dice and the max-t threshold (95 %
of the permutation maximum of ``|t|``); and where that maximum falls: the share of
2,000 permutations of the groups whose largest ``|t|`` over the vertices is in the cap.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_cycle_routes import _apical_cap, _cycles, _tracked, _tracking_error  # noqa: E402
from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import detection_power, dice, vertexwise_test  # noqa: E402
from ladders.study.imaging import MeshingSettings  # noqa: E402
from ladders.study.meshes.mesh_io import read_mesh  # noqa: E402
from ladders.study.sequences import CycleMotion, compare_cycles, curve_peaks  # noqa: E402
from ladders.study.tracking import TrackingSettings, track_cohort  # noqa: E402

VARIANTS = {
    "1. ED as given, no detour test, mask_sigma 0.5": dict(
        project_ed=False, max_detour=None, meshing=MeshingSettings(mask_sigma=0.5)
    ),
    "2. + detour test (2 mm)": dict(project_ed=False, meshing=MeshingSettings(mask_sigma=0.5)),
    "3. + ED onto frame 0's surface": dict(meshing=MeshingSettings(mask_sigma=0.5)),
    "4. + mask_sigma 1.0": dict(meshing=MeshingSettings(mask_sigma=1.0)),
    "5. mask_sigma 1.5 (defaults)": dict(),
}


def _folder(label: str) -> str:
    return label.split(".")[0]


def track_variant(work: Path, label: str, jobs: int) -> None:
    """Track the route's subjects with a variant (resumes)."""
    route = work / "hypokinesia_mild_landmarks"
    root = work / "variants" / _folder(label)
    root.mkdir(parents=True, exist_ok=True)
    for name in ("cohort", "corresponded"):
        if not (root / name).exists():
            os.symlink((route / name).resolve(), root / name)
    settings = TrackingSettings(refine_ed=True, estimate_planes="never", **VARIANTS[label])
    track_cohort(route / "corresponded", route / "cohort" / "images", root / "tracked", 1,
                 settings, jobs=jobs, progress=False)  # fmt: skip


def _tests(motion, patients, region, tested, permutations):
    tests = compare_cycles(motion, patients, permutations, np.random.default_rng(0), tfce=True,
                           vertices=tested, summaries=("peak",))  # fmt: skip
    found = tests.peak.p_fwer < 0.05
    enhanced = tests.peak_tfce.p_fwer_enhanced < 0.05
    reg = region & (np.ones_like(region) if tested is None else tested)
    return (detection_power(found[reg], reg[reg]), dice(found, reg),
            float(np.quantile(tests.peak.max_null, 0.95)),
            detection_power(enhanced[reg], reg[reg]), dice(enhanced, reg))  # fmt: skip


def _cap_share(peaks, patients, cap, permutations: int) -> float:
    """Share of the permutation maxima of ``|t|`` over the vertices that fall in the cap."""
    rng = np.random.default_rng(1)
    inside = 0
    for _ in range(permutations):  # the t map of each permutation of the groups
        t = vertexwise_test(peaks, rng.permutation(patients), 1, rng).statistic
        inside += bool(cap[np.argmax(np.abs(t))])
    return inside / permutations


def rows(work: Path, permutations: int, jobs: int) -> list[tuple]:
    c = _cycles("hypokinesia_mild", 40, 25)
    region = c.data.region.affected
    out = []
    truth_peaks = None
    for label in (None, *VARIANTS):
        root = work / "hypokinesia_mild_landmarks"
        if label is not None:
            track_variant(work, label, jobs)
            root = work / "variants" / _folder(label)
        atlas, faces = read_mesh(root / "cohort" / "atlas.vtk")
        cap = _apical_cap(atlas, faces)
        names, frames, matrices = _tracked(root, c)
        index = [c.names.index(n) for n in names]
        patients = np.asarray(c.patients)[index]
        if label is None:
            frames, err = c.frames[index], None
        else:
            err = _tracking_error(c, names, frames, matrices, faces)
        motion = CycleMotion(tuple(names), frames - frames[:, :1], atlas, faces)
        peaks = curve_peaks(motion.normal())[0]
        if truth_peaks is None:
            truth_peaks = peaks
        e = peaks - truth_peaks
        peak_error = (float(np.sqrt((e**2).mean())), float(e.mean()),
                      float(e[:, region].std(axis=0, ddof=1).mean()))  # fmt: skip
        every = _tests(motion, patients, region, None, permutations)
        no_cap = _tests(motion, patients, region, ~cap, permutations)
        share = _cap_share(peaks, patients, cap, min(permutations, 2000))
        out.append((label or "true frames", err, peak_error, every, no_cap, share, cap.mean()))
        print(out[-1], flush=True)
    return out


def _table(rows, permutations) -> str:
    lines = [
        "| tracking | ES error normal / along the wall (mm) | last-frame error (mm) | peak error "
        "RMS / mean / SD in the region (mm) | max-t: power / Dice / threshold | TFCE: power / "
        "Dice | without segment 17, max-t: power / Dice / threshold | without segment 17, "
        "TFCE: power / Dice | permutation maxima in segment 17 |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for label, err, pe, every, no_cap, share, _ in rows:
        es = "truth" if err is None else f"{err[0]:.2f} / {err[1]:.2f}"
        last = "truth" if err is None else f"{err[2]:.2f}"
        peak = "truth" if err is None else f"{pe[0]:.2f} / {pe[1]:+.2f} / {pe[2]:.2f}"
        lines.append(
            f"| {label} | {es} | {last} | {peak} | {every[0]:.2f} / {every[1]:.2f} / "
            f"{every[2]:.2f} | {every[3]:.2f} / {every[4]:.2f} | {no_cap[0]:.2f} / "
            f"{no_cap[1]:.2f} / {no_cap[2]:.2f} | {no_cap[3]:.2f} / {no_cap[4]:.2f} | {share:.2f} |"
        )
    note = (
        "The mild whole-cycle hypokinesia of the route benchmark (40 subjects, 25 frames, "
        "label series of 1.5 x 1.5 x 8 mm, correspondence with landmarks), tracked by "
        "projection with refine_ed under each variant; peak test without transport, "
        f"{permutations:,} permutations, FWER 5 %; segment 17 is the apical cap of the "
        "atlas (AHA, from its landmarks), and power and Dice without it are over the planted "
        "region outside it. The last column: the share of the maxima of abs(t) over the "
        "vertices, under 2,000 permutations of the groups, that fall in segment 17 (which "
        f"holds {100 * rows[0][6]:.0f} % of the atlas's vertices)."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("symladders-output/bench_cycle_routes"))
    parser.add_argument("--permutations", type=int, default=5000)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    if not (args.work / "hypokinesia_mild_landmarks" / "corresponded").is_dir():
        sys.exit(f"{args.work}: run benchmarks/bench_cycle_routes.py --work {args.work} first")
    table = _table(rows(args.work, args.permutations, args.jobs), args.permutations)
    print("\n" + table)
    if args.publish:
        publish("tracking_variants", table,
                "python benchmarks/bench_tracking_variants.py --publish")  # fmt: skip


if __name__ == "__main__":
    main()
