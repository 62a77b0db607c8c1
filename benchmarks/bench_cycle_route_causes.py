"""Why the whole-cycle label route loses power: each step's error put on the truth, one at a time.

    python benchmarks/bench_cycle_route_causes.py --work symladders-output/bench_cycle_routes
    python benchmarks/bench_cycle_route_causes.py --work WORK_NO_PLANES WORK_PLANES --publish
                                                  # docs/generated/cycle_route_causes.md

Reads the folders of ``bench_cycle_routes.py`` (run it first, same ``--work``; several
folders: one row group each, e.g. the series tracked without and with the valve plane
of every frame estimated from the images) for the mild cohort with landmarks, and tests the peak inward motion per vertex (two groups,
maximum statistic and TFCE, FWER 5 %) on motions that add the route's errors to the
truth one at a time:

1. the true frames (the meshes in correspondence);
2. the true motion of the corresponded ED points: each subject's tracked ED vertices
   taken back to its own frame and moved by the model's motion through the cycle (the
   correspondence's error only);
3. the true peaks plus the tracking's own peak errors (tracked peaks minus those of 2),
   and the same errors given to other subjects (shuffled), which tells a random error
   from one tied to a subject's anatomy;
3a-3d. the true peaks plus a part of those errors: their smooth part (each subject's
   error map smoothed on the atlas by the heat kernel of 10 mm FWHM), the rest (the
   errors minus their smooth part), the errors in the apical cap (AHA segment 17) only,
   and those outside it: which part of the errors raises the threshold and which
   shrinks the region's difference;
4. the tracked frames (the route).

Per motion: power and Dice against the planted region, the 95 % quantile of the
permutation maximum of ``|t|`` (the threshold a vertex must pass), the group difference
of the mean peak in the planted region (controls minus patients, mm) and the mean
within-group standard deviation of the peak there (mm).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_cycle_routes import _apical_cap, _cycles, _tracked  # noqa: E402
from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import (  # noqa: E402
    SurfaceSmoother,
    detection_power,
    dice,
    glm_test,
    vertexwise_test,
)
from ladders.statistics.tfce import mesh_adjacency  # noqa: E402
from ladders.study.cohort import motion_forward  # noqa: E402
from ladders.study.meshes.mesh_io import read_mesh  # noqa: E402
from ladders.study.sequences import CycleMotion, curve_peaks  # noqa: E402


def _peaks(frames, atlas, faces, names):
    motion = CycleMotion(tuple(names), frames - frames[:, :1], atlas, faces)
    return curve_peaks(motion.normal())[0]


def _material_frames(c, names, tracked, matrices):
    """The model's motion of each subject's corresponded ED points, in the atlas's frame."""
    out = []
    for name, frames, m in zip(names, tracked, matrices):
        params, abnormality = c.motion_of(c.names.index(name))
        inverse = np.linalg.inv(m)
        start = frames[0] @ inverse[:3, :3].T + inverse[:3, 3]
        out.append([motion_forward(params, start, float(f), abnormality) @ m[:3, :3].T + m[:3, 3]
                    for f in c.fractions])  # fmt: skip
    return np.asarray(out)


#: The width of the smoothing that splits the tracking's errors in two parts (mm FWHM).
SPLIT_FWHM = 10.0


def tracking_of(root: Path) -> str:
    """How a route folder's series were tracked: with the valve planes estimated or not."""
    record = json.loads(next((root / "tracked").glob("*.json")).read_text())
    return ("valve planes estimated" if record.get("estimated_planes") else
            "no valve planes")  # fmt: skip


def rows(work: Path, permutations: int) -> list[tuple]:
    c = _cycles("hypokinesia_mild", 40, 25)
    root = work / "hypokinesia_mild_landmarks"
    tracking = tracking_of(root)
    atlas, faces = read_mesh(root / "cohort" / "atlas.vtk")
    names, tracked, matrices = _tracked(root, c)
    index = [c.names.index(n) for n in names]
    patients = np.asarray(c.patients)[index]
    region = c.data.region.affected
    truth = _peaks(c.frames[index], atlas, faces, names)
    material = _peaks(_material_frames(c, names, tracked, matrices), atlas, faces, names)
    route = _peaks(tracked, atlas, faces, names)
    error = route - material
    shuffled = error[np.random.default_rng(1).permutation(len(error))]
    smooth = SurfaceSmoother(atlas, faces, SPLIT_FWHM)(error[:, None])[:, 0]
    cap = _apical_cap(atlas, faces)
    motions = [
        ("1. true frames", truth),
        ("2. true motion of the corresponded ED points", material),
        ("3. true peaks + the tracking's peak errors", truth + error),
        ("3'. true peaks + the tracking's peak errors, shuffled between subjects",
         truth + shuffled),
        (f"3a. true peaks + the smooth part of those errors ({SPLIT_FWHM:g} mm FWHM)",
         truth + smooth),
        ("3b. true peaks + the rest of those errors (the errors minus their smooth part)",
         truth + error - smooth),
        ("3c. true peaks + those errors in the apical cap only", truth + error * cap),
        ("3d. true peaks + those errors outside the apical cap", truth + error * ~cap),
        ("4. tracked frames (the route)", route),
    ]  # fmt: skip
    design = np.c_[patients.astype(float), (~patients).astype(float)]
    contrast = np.array([[1.0, -1.0]])
    adjacency = mesh_adjacency(faces, len(atlas))
    out = []
    for label, peaks in motions:
        test = vertexwise_test(peaks, patients, permutations, np.random.default_rng(0))
        found = test.p_fwer < 0.05
        enhanced = glm_test(peaks, design, contrast, permutations, np.random.default_rng(0),
                            method="manly", tfce=adjacency).significant(0.05, enhanced=True)  # fmt: skip
        mean = peaks[:, region].mean(axis=1)
        spread = np.mean([peaks[g][:, region].std(axis=0, ddof=1).mean()
                          for g in (patients, ~patients)])  # fmt: skip
        out.append((tracking, label, detection_power(found, region), dice(found, region),
                    float(np.quantile(test.max_null, 0.95)), detection_power(enhanced, region),
                    dice(enhanced, region), mean[~patients].mean() - mean[patients].mean(),
                    spread))  # fmt: skip
        print(out[-1], flush=True)
    return out


def _table(rows, permutations) -> str:
    lines = [
        "| tracking | motion | max-t: power / Dice | threshold: 95 % of the permutation maximum of abs(t) "
        "| TFCE: power / Dice | region "
        "peak, controls - patients (mm) | within-group SD of the peak in the region (mm) |",
        "|---|---|---|---|---|---|---|",
    ]
    for tracking, label, p, d, q, tp, td, diff, sd in rows:
        lines.append(f"| {tracking} | {label} | {p:.2f} / {d:.2f} | {q:.2f} | {tp:.2f} / {td:.2f} | "
                     f"{diff:.2f} | {sd:.2f} |")  # fmt: skip
    note = (
        "The mild whole-cycle hypokinesia (40 subjects, 25 frames, label series of "
        "1.5 x 1.5 x 8 mm, correspondence with landmarks, tracking by projection with "
        "refine_ed, without the valve planes or with the valve plane of every frame "
        "estimated from the images (`symladders track`'s default), no transport); peak "
        f"test, {permutations:,} permutations, FWER 5 %. Apical cap: the atlas's AHA segment 17."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, nargs="+",
                        default=[Path("symladders-output/bench_cycle_routes")],
                        help="folders of bench_cycle_routes.py --work (one row group each)")  # fmt: skip
    parser.add_argument("--permutations", type=int, default=5000)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    table = _table([r for work in args.work for r in rows(work, args.permutations)],
                   args.permutations)  # fmt: skip
    print("\n" + table)
    if args.publish:
        publish("cycle_route_causes", table, "python benchmarks/bench_cycle_route_causes.py "
                "--work WORK_NO_PLANES WORK_PLANES --publish")  # fmt: skip


if __name__ == "__main__":
    main()
