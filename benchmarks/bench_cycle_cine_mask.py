"""The cine route's sampling mask against the mild hypokinesia: tracking error and power.

    python benchmarks/bench_cycle_cine_mask.py --work symladders-output/bench_cycle_cine \
        [--images tagged] [--masks 10 6 4] [--jobs 2] [--publish]

The cine series of ``bench_cycle_cine.py`` (the whole-cycle mild hypokinesia, 20
patients against 20 controls, 25 frames, short-axis stacks of 1.5 x 1.5 x 8 mm; the
same ``--work`` folder, rendered there when absent) tracked again with the metric
sampling the voxels within each distance of the ED mesh
(``CineTrackingSettings.mask_distance``, ``symladders track --cine --mask-distance``;
10 mm is the default), everything else at its default. Per distance, against the
truth: the ES error along the normal and along the wall, the twist error; the SD over
the subjects of the tracked peak inward motion minus the true one (mean over the
vertices) and that difference's mean over the planted region per group; the normal
peak's tests of ``cycle_cine`` (max-t and TFCE, power and Dice, null FWER over 100
random 10-against-10 splits of the controls, 5,000 permutations), the region's group
difference and effect size. Each stage resumes (tracked meshes and rows kept under ``--work``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_cycle_cine as cine  # noqa: E402
from generated_tables import machine, publish  # noqa: E402

from ladders.study.population import write_cycle_cohort  # noqa: E402
from ladders.study.sequences import CycleMotion, curve_peaks  # noqa: E402
from ladders.study.tracking import CineTrackingSettings, track_cohort  # noqa: E402

COHORT = "hypokinesia_mild"
DEFAULT = CineTrackingSettings().mask_distance


def _folder(root: Path, mask: float) -> Path:
    return root / ("tracked" if mask == DEFAULT else f"tracked_mask{mask:g}")


def track(work: Path, kind: str, mask: float, n: int, n_frames: int, jobs: int) -> None:
    """Render (when absent, as ``bench_cycle_cine`` does) and track with ``mask``."""
    root = work / f"{COHORT}_{kind}"
    if not (root / "cohort" / "cycle.json").is_file():
        write_cycle_cohort(cine._cycles(COHORT, n, n_frames), root / "cohort", "cine", 1.5, 8.0,
                           tagging=cine.IMAGES[kind])  # fmt: skip
    outcome = track_cohort(root / "cohort", root / "cohort" / "images", _folder(root, mask), 1,
                           CineTrackingSettings(mask_distance=mask), jobs=jobs, progress=False)  # fmt: skip
    if outcome.failed:
        print(f"  {kind}, mask {mask:g} mm: failed {outcome.failed}", flush=True)


def _peak_errors(c, names, frames, region, labels) -> tuple[float, float, float]:
    rows_of = [c.names.index(s) for s in names]
    tracked = CycleMotion(tuple(names), frames - frames[:, :1], c.data.cohort.atlas, c.faces)
    truth = CycleMotion(tuple(names), c.frames[rows_of] - c.frames[rows_of, :1],
                        c.data.cohort.atlas, c.faces)  # fmt: skip
    error = curve_peaks(tracked.curves())[0] - curve_peaks(truth.curves())[0]
    return (float(error.std(axis=0, ddof=1).mean()), float(error[labels][:, region].mean()),
            float(error[~labels][:, region].mean()))  # fmt: skip


def rows(work: Path, images, masks, n, n_frames, permutations, repetitions) -> list:
    cache_path = work / "rows_mask.json"
    cache = json.loads(cache_path.read_text()) if cache_path.is_file() else {}
    c = cine._cycles(COHORT, n, n_frames)
    region = c.data.region.affected
    out = []
    for i, kind in enumerate(images):
        root = work / f"{COHORT}_{kind}"
        for mask in masks:
            folder = _folder(root, mask)
            if not folder.is_dir():
                continue
            names, frames = cine._tracked(root, c, folder.name)
            labels = np.array([c.patients[c.names.index(s)] for s in names])
            motion = CycleMotion(tuple(names), frames - frames[:, :1], c.data.cohort.atlas,
                                 c.faces)  # fmt: skip
            key = f"{kind}|{mask:g}|{n}|{n_frames}|{permutations}|{repetitions}|{cine._fingerprint(folder)}"
            if key not in cache:
                rng = np.random.default_rng([7, i, int(round(10 * mask))])
                cache[key] = cine._scores(motion, c, permutations, repetitions, rng, transport=True)
                cache_path.write_text(json.dumps(cache, indent=1))
            out.append((kind, mask, cine._errors(c, names, frames),
                        _peak_errors(c, names, frames, region, labels), *cache[key],
                        cine._peak_effect(motion, c)))  # fmt: skip
            print(out[-1], flush=True)
    return out


def _table(rows, permutations, repetitions) -> str:
    lines = [
        "| images | mask distance (mm) | ES error normal / along the wall (mm), twist error "
        "(deg) | tracked minus true peak: SD over the subjects (mm) | region: tracked minus "
        "true peak, patients / controls (mm) | normal peak (t): power / Dice, null FWER "
        "[95 % CI] | normal peak with TFCE: power / Dice, null FWER [95 % CI] | region: group "
        "difference (mm), effect size |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for kind, mask, err, (sd, pat, con), peak, tfce, effect in rows:
        tests = [f"{p:.2f} / {d:.2f}, {r:.2f} [{lo:.2f}, {hi:.2f}]" for p, d, r, lo, hi in
                 (peak, tfce)]  # fmt: skip
        default = " (default)" if mask == DEFAULT else ""
        lines.append(
            f"| {kind} cine | {mask:g}{default} | {err[0]:.2f} / {err[1]:.2f}, {err[2]:.2f} | "
            f"{sd:.2f} | {pat:+.2f} / {con:+.2f} | {' | '.join(tests)} | {effect[0]:.2f}, "
            f"{effect[1]:.2f} |"
        )
    note = (
        "The whole-cycle mild hypokinesia (a fifth of the motion in segments 7, 8, 13, 14), 20 "
        "patients against 20 controls, 25 frames, short-axis cine series of 1.5 x 1.5 x 8 mm "
        "(`cycle_cine`'s); each subject's true ED mesh tracked with the default cine settings "
        "but the metric's mask (every frame registered to ED), no transport. Normal peak "
        f"tests, {permutations:,} permutations, FWER 5 %; null: {repetitions} random "
        "10-against-10 splits of the controls (500 permutations each)."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("symladders-output/bench_cycle_cine"))
    parser.add_argument("--images", nargs="+", choices=tuple(cine.IMAGES), default=["tagged"])
    parser.add_argument("--masks", nargs="+", type=float, default=[DEFAULT, 6.0, 4.0])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    n, n_frames, permutations, repetitions = 40, 25, 5000, 100
    for kind in args.images:
        for mask in args.masks:
            track(args.work, kind, mask, n, n_frames, args.jobs)  # resumes per subject
    table = _table(rows(args.work, args.images, args.masks, n, n_frames, permutations,
                        repetitions), permutations, repetitions)  # fmt: skip
    print("\n" + table)
    if args.publish:
        command = ("python benchmarks/bench_cycle_cine_mask.py --images " + " ".join(args.images)
                   + " --masks " + " ".join(f"{m:g}" for m in args.masks) + " --publish")  # fmt: skip
        publish("cycle_cine_mask", table, command)


if __name__ == "__main__":
    main()
