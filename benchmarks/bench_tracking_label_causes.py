"""Why label-series tracking misses part of the motion along the wall: its parts, and
cohorts without the motions surfaces cannot see.

    python benchmarks/bench_tracking_label_causes.py --routes WORK_ROUTES \
        [--work DIR] [--jobs 2] [--publish]          # docs/generated/tracking_label_causes.md

The route of ``bench_cycle_routes.py`` (the mild whole-cycle hypokinesia, 40 subjects,
25 frames, short-axis label series of 1.5 x 1.5 x 8 mm, correspondence with the landmark
table, projection with ``refine_ed``) misses part of the motion along the wall at ES.
Two questions, each answered against the truth:

1. **Which part?** The error at ES of every tracked vertex against the true place of
   the material point it started from (as ``cycle_routes``), the part along the wall
   split in the subject's own frame into the part along the long axis and the part
   about it (circumferential); the twist of the tracked and of the true motion (apical
   minus basal rotation, degrees). Rows: the route's own tracked meshes (read from
   ``--routes``), and the same cohort tracked from each subject's true ED mesh (so the
   correspondence is out of the question).
2. **Is it the motion a surface cannot see?** The same subjects (same draws of every
   other parameter, same ED shapes) rendered and tracked again with the model's twist
   removed (``apex_rotation = base_rotation = 0``), then also with the radial
   contraction made uniform around and along the ventricle
   (``contraction_heterogeneity = contraction_gradient = 0``), from the true ED meshes.
   What is left is the error of tracking a motion that is affine along the wall
   (uniform shortening) plus the radial contraction.

Each stage resumes (the series and the tracked meshes are kept under ``--work``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_cine_tracking import twist  # noqa: E402
from bench_cycle_cine import _fingerprint  # noqa: E402
from bench_cycle_routes import COHORTS, _scores, _tracked  # noqa: E402
from generated_tables import machine, publish  # noqa: E402

from ladders.study.cohort import SyntheticLVModel, motion_forward  # noqa: E402
from ladders.study.meshes.mesh_io import read_mesh  # noqa: E402
from ladders.study.population import (  # noqa: E402
    cycle_valve_planes,
    make_two_group_cycles,
    write_cycle_cohort,
)
from ladders.study.sequences import CycleMotion, read_tracked_frames  # noqa: E402
from ladders.study.tracking import TrackingSettings, track_cohort  # noqa: E402
from ladders.study.wall_motion import outward_vertex_normals  # noqa: E402

COHORT = "hypokinesia_mild"
PERMUTATIONS, REPETITIONS = 5000, 100

#: Motion model of each cohort tracked from the true ED meshes: overrides of
#: SyntheticLVModel's ranges.
VARIANTS = {
    "the cohort's motion": {},
    "without twist": {"apex_rotation": (0.0, 0.0), "base_rotation": (0.0, 0.0)},
    "without twist, contraction uniform": {
        "apex_rotation": (0.0, 0.0),
        "base_rotation": (0.0, 0.0),
        "contraction_heterogeneity": (0.0, 0.0),
        "contraction_gradient": (0.0, 0.0),
    },
}


def _cycles(variant: str, n: int, n_frames: int):
    model = SyntheticLVModel(**VARIANTS[variant])
    return make_two_group_cycles(n_subjects=n, abnormality=COHORTS[COHORT], n_frames=n_frames,
                                 model=model)  # fmt: skip


def _folder(work: Path, variant: str) -> Path:
    return work / variant.replace("'", "").replace(",", "").replace(" ", "_")


def _track(meshes: Path, images: Path, out: Path, planes, jobs: int, label: str) -> float:
    start = time.perf_counter()
    settings = TrackingSettings(refine_ed=True, estimate_planes="never")  # planes given or none
    outcome = track_cohort(meshes, images, out, 1, settings, cut_planes=planes, jobs=jobs,
                           progress=False)  # fmt: skip
    seconds = time.perf_counter() - start
    if outcome.failed:
        print(f"  {label}: failed {outcome.failed}", flush=True)
    print(f"  {label}: track {seconds:.0f} s", flush=True)
    return seconds


def run_variant(work: Path, variant: str, n: int, n_frames: int, jobs: int) -> dict:
    """Render the label series (when absent) and track every subject from its true ED mesh,
    without and (the cohort's motion) with the true valve planes."""
    c = _cycles(variant, n, n_frames)
    root = _folder(work, variant)
    seconds = {}
    start = time.perf_counter()
    if not (root / "cohort" / "cycle.json").is_file():
        write_cycle_cohort(c, root / "cohort", "labels", 1.5, 8.0)
    seconds["render"] = time.perf_counter() - start
    images = root / "cohort" / "images"
    seconds["track"] = _track(root / "cohort", images, root / "tracked", None, jobs, variant)
    if not VARIANTS[variant]:
        seconds["track_planes"] = _track(root / "cohort", images, root / "tracked_planes",
                                         cycle_valve_planes(c), jobs, f"{variant}, valve planes")  # fmt: skip
    return seconds


def run_route(work: Path, routes: Path, n: int, n_frames: int, jobs: int) -> float:
    """The route's corresponded ED meshes tracked again with the true valve planes."""
    c = _cycles("the cohort's motion", n, n_frames)
    root = routes / f"{COHORT}_landmarks"
    return _track(root / "corresponded", root / "cohort" / "images", work / "route_planes",
                  cycle_valve_planes(c), jobs, "route, valve planes")  # fmt: skip


def errors(c, names, frames, matrices) -> dict:
    """Means over the subjects of the ES errors (mm) and twists (degrees).

    ``frames`` ``(n, T, k, 3)`` tracked, posed by ``matrices`` (the correspondence's
    similarity from the subject's own frame, apex at the origin and long axis ``+z``);
    the truth of a vertex is the model's motion of the material point it started from.
    """
    es, last = int(np.argmax(c.fractions)), len(c.fractions) - 1
    out = {k: [] for k in ("normal", "along_wall", "long_axis", "circumferential",
                           "twist_true", "twist_tracked", "last")}  # fmt: skip
    for name, tracked, m in zip(names, frames, matrices):
        params, abnormality = c.motion_of(name)
        inverse = np.linalg.inv(m)
        start = tracked[0] @ inverse[:3, :3].T + inverse[:3, 3]  # own frame
        own = {t: motion_forward(params, start, float(c.fractions[t]), abnormality)
               for t in (es, last)}  # fmt: skip
        truth = {t: x @ m[:3, :3].T + m[:3, 3] for t, x in own.items()}
        error = tracked[es] - truth[es]
        nu = outward_vertex_normals(truth[es], c.faces)
        across = np.einsum("kd,kd->k", error, nu)
        out["normal"].append(np.abs(across).mean())
        out["along_wall"].append(np.linalg.norm(error - across[:, None] * nu, axis=1).mean())
        rotation = m[:3, :3] / np.cbrt(np.linalg.det(m[:3, :3]))
        e = error @ rotation  # the error's components on the own frame's axes, mm
        theta = np.arctan2(start[:, 1], start[:, 0])
        out["long_axis"].append(np.abs(e[:, 2]).mean())
        out["circumferential"].append(
            np.abs(-e[:, 0] * np.sin(theta) + e[:, 1] * np.cos(theta)).mean()
        )
        tracked_own = tracked[es] @ inverse[:3, :3].T + inverse[:3, 3]
        out["twist_true"].append(twist(params, start, own[es]))
        out["twist_tracked"].append(twist(params, start, tracked_own))
        out["last"].append(np.linalg.norm(tracked[-1] - truth[last], axis=1).mean())
    return {k: float(np.mean(v)) for k, v in out.items()} | {"subjects": len(names)}


def _row(cache: dict, label: str, c, names, frames, matrices, folder: Path, index: int):
    """Errors and the peak test (max-t and TFCE, no transport) of a tracked folder, cached
    in ``cache`` under its label and the tracked meshes' fingerprint."""
    key = f"{label}|{_fingerprint(folder)}|{PERMUTATIONS}|{REPETITIONS}"
    if key not in cache:
        cache[key] = errors(c, names, frames, matrices)
        if "the cohort's motion" in label:  # the tests where the cohort is the route's
            motion = CycleMotion(tuple(names), frames - frames[:, :1], c.data.cohort.atlas,
                                 c.faces)  # fmt: skip
            rng = np.random.default_rng([0, index])
            power, _, null, tfce, _, tfce_null = _scores(motion, c, c.data.region.affected,
                                                         PERMUTATIONS, REPETITIONS, rng)  # fmt: skip
            cache[key] |= {"power": power, "null": list(null), "tfce": tfce,
                           "tfce_null": list(tfce_null)}  # fmt: skip
    print(label, cache[key], flush=True)
    return label, cache[key]


def rows(work: Path, routes: Path | None, n: int, n_frames: int) -> list[tuple[str, dict]]:
    cache_path = work / "rows.json"
    cache = json.loads(cache_path.read_text()) if cache_path.is_file() else {}
    found = []  # (label, cohort, names, frames, matrices, folder)
    if routes is not None:
        root = routes / f"{COHORT}_landmarks"
        c = _cycles("the cohort's motion", n, n_frames)
        label = "the route (ED corresponded with landmarks), the cohort's motion"
        for tracked, suffix in ((root / "tracked", ""), (work / "route_planes", ", valve planes")):
            if tracked.is_dir():
                found.append((label + suffix, c, *_tracked(root, c, tracked), tracked))
    for variant in VARIANTS:
        c = _cycles(variant, n, n_frames)
        for folder, suffix in (("tracked", ""), ("tracked_planes", ", valve planes")):
            root = _folder(work, variant) / folder
            if not root.is_dir():
                continue
            sequences = read_tracked_frames(root)
            names = [s for s in c.names if s in sequences]
            frames = np.stack([[read_mesh(p)[0] for p in sequences[s]] for s in names])
            found.append((f"true ED mesh, {variant}{suffix}", c, names, frames,
                          [np.eye(4)] * len(names), root))  # fmt: skip
    out = []
    for index, (label, c, names, frames, matrices, folder) in enumerate(found):
        out.append(_row(cache, label, c, names, frames, matrices, folder, index))
        cache_path.write_text(json.dumps(cache, indent=1))
    return out


def _power(power, null) -> str:
    if power is None:
        return "not tested"
    return f"{power:.2f}, {null[0]:.2f} [{null[1]:.2f}, {null[2]:.2f}]"


def _table(found, n_frames: int) -> str:
    lines = [
        "| tracked from, motion | subjects | ES error normal / along the wall (mm) | along the "
        "wall: along the long axis / circumferential (mm) | twist true / tracked (deg) | "
        "last-frame error (mm) | peak test, max-t: power, null FWER [95 % CI] | with TFCE |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for label, e in found:
        lines.append(
            f"| {label} | {e['subjects']} | {e['normal']:.2f} / {e['along_wall']:.2f} | "
            f"{e['long_axis']:.2f} / {e['circumferential']:.2f} | {e['twist_true']:.1f} / "
            f"{e['twist_tracked']:.1f} | {e['last']:.2f} | {_power(e.get('power'), e.get('null'))} "
            f"| {_power(e.get('tfce'), e.get('tfce_null'))} |"
        )
    note = (
        f"The mild whole-cycle hypokinesia (a fifth of the motion in segments 7, 8, 13, 14), "
        f"{n_frames} frames (ES at 35 %), short-axis label series of 1.5 x 1.5 x 8 mm, "
        "tracked by projection with refine_ed (the defaults of `symladders track "
        "--refine-ed`). Errors at ES against the true place of the material point each "
        "vertex started from, means over the vertices and the subjects; the part along the "
        "wall split in the subject's own frame. Twist: apical minus basal rotation about the "
        "long axis. 'Without twist': the model's apex and base rotations set to zero, every "
        "other parameter drawn as in the cohort; 'contraction uniform': also the radial "
        "contraction's variation around and along the ventricle set to zero. 'Valve "
        "planes': the true valve plane of every frame given (`--cut-planes "
        "cohort/valve_planes.csv`). Peak test of the normal motion without transport, on the "
        "rows of the cohort's motion "
        f"(`cycle-analyze`), {PERMUTATIONS:,} permutations, FWER 5 %, power over the planted "
        f"region; null: {REPETITIONS} random 10-against-10 splits of the controls."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path,
                        default=Path("symladders-output/bench_tracking_label_causes"))  # fmt: skip
    parser.add_argument("--routes", type=Path, default=None,
                        help="the --work folder of bench_cycle_routes.py (its tracked route)")  # fmt: skip
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--no-run", action="store_true", help="only the errors of what is tracked")
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    n, n_frames = 40, 25
    if not args.no_run:
        seconds = {v: run_variant(args.work, v, n, n_frames, args.jobs) for v in VARIANTS}
        if args.routes is not None:
            seconds["route_planes"] = run_route(args.work, args.routes, n, n_frames, args.jobs)
        (args.work / "seconds.json").write_text(json.dumps(seconds, indent=1))
    table = _table(rows(args.work, args.routes, n, n_frames), n_frames)
    print("\n" + table)
    if args.publish:
        publish("tracking_label_causes", table,
                "python benchmarks/bench_tracking_label_causes.py --routes WORK_ROUTES --publish")  # fmt: skip


if __name__ == "__main__":
    main()
