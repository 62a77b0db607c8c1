"""The whole cycle through label series, against the truth: tracking error and group tests.

    python benchmarks/bench_cycle_routes.py --work symladders-output/bench_cycle_routes
    python benchmarks/bench_cycle_routes.py --publish     # docs/generated/cycle_routes.md
    python benchmarks/bench_cycle_routes.py --quick       # 12 subjects, 10 frames
    python benchmarks/bench_cycle_routes.py --landmarks with  # only the route with landmarks

The route a user runs from 4-D label images, with the library's functions (the commands
of ``docs/tutorial_cycle.md``): the whole-cycle cohort
(:func:`~ladders.study.population.make_two_group_cycles`, seed 0, 20 patients against
20 controls, 25 frames) written as short-axis label series of 1.5 x 1.5 x 8 mm
(:func:`~ladders.study.population.write_cycle_cohort`); the ED frame meshed
(:func:`~ladders.study.imaging.mesh_label_images`) and put in the atlas's
correspondence (:func:`~ladders.study.preparation.correspond_cohort`), without
landmarks (the surface fit alone fixes the turn about the long axis) and with the
cohort's landmark table (``symladders cohort --cycle 25 --landmarks``: apex, base-plane
centre and septal point of each ED, as a user gives them); the mesh
tracked through every frame (:func:`~ladders.study.tracking.track_cohort`, projection
with ``refine_ed``); the frames transported (:func:`~ladders.study.sequences.run_cycle_study`,
pole ladder with residuals, ``alpha^2 = 100``) or not. Cohorts: the whole-cycle
hypokinesia at a fifth of the motion (the mild effect) and at half of it.

Measured per cohort:

* tracking: the error at ES of every tracked vertex against the true position of the
  material point it started from (the model's motion in the volume applied to the
  tracked ED vertex), split along the true surface's normal and along the wall; the
  same at the last frame (drift); seconds per subject (meshing and tracking);
* the peak test (:func:`~ladders.study.sequences.compare_cycles`): power and Dice
  against the planted region, FWER 5 %, and its null FWER from random 10-against-10
  splits of the controls, with a binomial interval, by the maximum statistic and with
  threshold-free cluster enhancement on the atlas (``compare_cycles(..., tfce=True)``);
  beside the same tests on the true frames (the meshes in correspondence); each also
  without the atlas's apical cap (AHA segment 17, ``vertices=`` of ``compare_cycles``)
  for the motions without transport, and with every map smoothed on the atlas
  (``compare_cycles(..., fwhm=10)``) for the true frames and the routes with landmarks.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_cycle_study import null_splits  # noqa: E402
from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import binomial_interval, detection_power, dice  # noqa: E402
from ladders.study.cohort import motion_forward  # noqa: E402
from ladders.study.imaging import mesh_label_images  # noqa: E402
from ladders.study.meshes.mesh_io import read_mesh  # noqa: E402
from ladders.study.population import (  # noqa: E402
    CYCLE_ABNORMALITY,
    make_two_group_cycles,
    write_cycle_cohort,
)
from ladders.study.population.aha_model import aha_segments  # noqa: E402
from ladders.study.preparation import correspond_cohort  # noqa: E402
from ladders.study.preparation.synthetic_landmarks import synthetic_landmarks  # noqa: E402
from ladders.study.sequences import (  # noqa: E402
    CycleMotion,
    compare_cycles,
    load_cycle_motion,
    read_tracked_frames,
    run_cycle_study,
)
from ladders.study.tracking import TrackingSettings, track_cohort  # noqa: E402
from ladders.study.wall_motion import outward_vertex_normals  # noqa: E402

COHORTS = {"hypokinesia_mild": replace(CYCLE_ABNORMALITY, magnitude=0.2),
           "hypokinesia": CYCLE_ABNORMALITY}  # fmt: skip
ALPHA2 = 100.0
#: The smoothing of the analysed maps (``compare_cycles(..., fwhm=FWHM)``), set before any
#: run: about a fifth of the planted region's extent along the wall.
FWHM = 10.0


def _cycles(name, n, n_frames):
    return make_two_group_cycles(n_subjects=n, abnormality=COHORTS[name], n_frames=n_frames)


#: route folder suffix -> correspondence with the cohort's landmark table
ROUTES = {"": False, "_landmarks": True}


def run_route(work: Path, name: str, n: int, n_frames: int, jobs: int, landmarks: bool) -> dict:
    """Every stage of the label route (each resumes); the seconds of each."""
    c = _cycles(name, n, n_frames)
    root = work / (name + ("_landmarks" if landmarks else ""))
    table = root / "cohort" / "landmarks.csv" if landmarks else None
    seconds = {}
    start = time.perf_counter()
    if not (root / "cohort" / "cycle.json").is_file():
        write_cycle_cohort(c, root / "cohort", "labels", 1.5, 8.0, landmarks=landmarks)
    seconds["render"] = time.perf_counter() - start
    images = sorted((root / "cohort" / "images").glob("*.nii.gz"))
    es = int(np.argmax(c.fractions))
    for stage, call in (
        ("mesh", lambda: mesh_label_images(images, 1, root / "meshes", (0, es), jobs=jobs,
                                           progress=False)),
        ("correspond", lambda: correspond_cohort(root / "cohort" / "atlas.vtk", root / "meshes",
                                                 root / "corresponded", landmarks=table,
                                                 jobs=jobs)),
        ("track", lambda: track_cohort(root / "corresponded", root / "cohort" / "images",
                                       root / "tracked", 1,
                                       TrackingSettings(refine_ed=True, estimate_planes="never"),
                                       jobs=jobs, progress=False)),
    ):  # fmt: skip
        start = time.perf_counter()
        call()
        seconds[stage] = time.perf_counter() - start
        print(f"  {name}: {stage} {seconds[stage]:.0f} s", flush=True)
    atlas, faces = read_mesh(root / "cohort" / "atlas.vtk")
    sequences = read_tracked_frames(root / "tracked")
    start = time.perf_counter()
    run_cycle_study(atlas, faces, sequences, root / "cycle_study", alpha2=ALPHA2, jobs=jobs)
    seconds["cycle_study"] = time.perf_counter() - start
    print(f"  {name}: cycle study {seconds['cycle_study']:.0f} s", flush=True)
    return seconds


def _tracked(root: Path, c, tracked: Path | None = None):
    """Tracked frames ``(n, T, k, 3)`` in the atlas's frame and each subject's transform
    (from ``root / "tracked"``, or from ``tracked``)."""
    sequences = read_tracked_frames(root / "tracked" if tracked is None else tracked)
    names = [s for s in c.names if s in sequences]
    frames = np.stack([[read_mesh(p)[0] for p in sequences[s]] for s in names])
    matrices = []
    for s in names:
        record = json.loads((root / "corresponded" / "correspondence" / f"{s}.json").read_text())
        matrices.append(np.asarray(record["transform"]["matrix"]))
    return names, frames, matrices


def _tracking_error(c, names, frames, matrices, faces):
    """Mean normal and tangential error at ES and the mean error at the last frame, mm."""
    es = int(np.argmax(c.fractions))
    normal, tangential, last = [], [], []
    for name, tracked, m in zip(names, frames, matrices):
        i = c.names.index(name)
        params, abnormality = c.motion_of(i)
        inverse = np.linalg.inv(m)
        start = tracked[0] @ inverse[:3, :3].T + inverse[:3, 3]  # the subject's own frame

        truth = {}
        for t in (es, len(c.fractions) - 1):
            moved = motion_forward(params, start, float(c.fractions[t]), abnormality)
            truth[t] = moved @ m[:3, :3].T + m[:3, 3]
        error = tracked[es] - truth[es]
        nu = outward_vertex_normals(truth[es], faces)
        along = np.einsum("kd,kd->k", error, nu)
        normal.append(np.abs(along).mean())
        tangential.append(np.linalg.norm(error - along[:, None] * nu, axis=1).mean())
        last.append(np.linalg.norm(tracked[-1] - truth[len(c.fractions) - 1], axis=1).mean())
    return float(np.mean(normal)), float(np.mean(tangential)), float(np.mean(last))


def _null_rates(motion, controls, rng, repetitions: int, permutations: int, tested=None,
                fwhm=None):  # fmt: skip
    """Null FWER of the peak test, max-t and TFCE, on random halves of the controls."""
    hits = np.zeros(2, dtype=int)
    for sub, labels in null_splits(motion, controls, rng, repetitions):
        tests = compare_cycles(sub, labels, permutations, rng, tfce=True, vertices=tested,
                               fwhm=fwhm, summaries=("peak",))  # fmt: skip
        hits += [(tests.peak.p_fwer < 0.05).any(),
                 (tests.peak_tfce.p_fwer_enhanced < 0.05).any()]  # fmt: skip
    return [(h / repetitions, *binomial_interval(int(h), repetitions)) for h in hits]


def _apical_cap(atlas, faces) -> np.ndarray:
    """The atlas's AHA segment 17 (the apical cap), from its landmarks."""
    lm = synthetic_landmarks(atlas)
    return aha_segments(atlas, lm.apex, lm.base, lm.septum, faces) == 17


def _scores(motion, c, region, permutations, repetitions, rng, tested=None, fwhm=None):
    """Power and Dice (max-t, TFCE) over the region tested, and the null FWER of both."""
    patients = np.array([c.patients[c.names.index(s)] for s in motion.subjects])
    tests = compare_cycles(motion, patients, permutations, rng, tfce=True, vertices=tested,
                           fwhm=fwhm, summaries=("peak",))  # fmt: skip
    reg = region if tested is None else region & tested
    found = tests.peak.p_fwer < 0.05
    enhanced = tests.peak_tfce.p_fwer_enhanced < 0.05
    rates = _null_rates(motion, np.flatnonzero(~patients), rng, repetitions,
                        min(permutations, 500), tested, fwhm)  # fmt: skip
    return (detection_power(found[reg], reg[reg]), dice(found, reg), rates[0],
            detection_power(enhanced[reg], reg[reg]), dice(enhanced, reg), rates[1])  # fmt: skip


def rows(work: Path, n: int, n_frames: int, seconds: dict, permutations, repetitions, rng):
    out = []
    for name in COHORTS:
        c = _cycles(name, n, n_frames)
        motions = []
        for suffix, landmarks in ROUTES.items():
            root = work / (name + suffix)
            if not (root / "tracked").is_dir():
                continue
            atlas, faces = read_mesh(root / "cohort" / "atlas.vtk")
            names, frames, matrices = _tracked(root, c)
            error = _tracking_error(c, names, frames, matrices, faces)
            per_subject = {k: v / max(len(names), 1)
                           for k, v in seconds.get(name + suffix, {}).items()}  # fmt: skip
            if not motions:
                true = CycleMotion(c.names, c.frames - c.frames[:, :1], atlas, faces)
                motions.append(("true frames (meshes in correspondence), no transport", true,
                                None, {}))  # fmt: skip
            route = "label series " + ("with landmarks" if landmarks else "without landmarks")
            motions.append((f"{route}, tracked, no transport",
                            CycleMotion(tuple(names), frames - frames[:, :1], atlas, faces),
                            error, per_subject))  # fmt: skip
            if (root / "cycle_study" / "cycle_study.json").is_file():
                motions.append((f"{route}, tracked, pole ladder alpha^2 = {ALPHA2:g}",
                                load_cycle_motion(root / "cycle_study"), error, per_subject))  # fmt: skip
        region = c.data.region.affected
        for label, motion, err, per_subject in motions:
            masks = [None] if "pole ladder" in label else [None, ~_apical_cap(atlas, faces)]
            for tested in masks:
                scores = _scores(motion, c, region, permutations, repetitions, rng, tested)
                what = label if tested is None else f"{label}, without segment 17"
                out.append((name, what, len(motion.subjects), err, per_subject, *scores))
                print(out[-1], flush=True)
            if "without landmarks" in label:  # the turn about the axis, not the noise, rules
                continue
            # a stream of its own, so that the other rows keep theirs
            own = np.random.default_rng([int(FWHM), len(out)])
            scores = _scores(motion, c, region, permutations, repetitions, own, fwhm=FWHM)
            out.append((name, f"{label}, maps smoothed {FWHM:g} mm FWHM", len(motion.subjects),
                        err, per_subject, *scores))  # fmt: skip
            print(out[-1], flush=True)
    return out


def _table(rows, n_frames, permutations, repetitions, shared: bool = False) -> str:
    lines = [
        "| cohort | motion | subjects | ES error normal / along the wall (mm) | last-frame error "
        "(mm) | peak test: power / Dice | null FWER [95 % CI] | peak test with TFCE: power / "
        "Dice | TFCE null FWER [95 % CI] | s / subject: meshing ED-ES + correspondence, "
        "tracking, cycle study |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, label, n, err, sec, power, d, (rate, low, high), tp, td, tr in rows:
        e = "truth" if err is None else f"{err[0]:.2f} / {err[1]:.2f}"
        last = "truth" if err is None else f"{err[2]:.2f}"
        s = "" if err is None or not sec else (
            f"{sec.get('mesh', 0) + sec.get('correspond', 0):.0f}, {sec.get('track', 0):.0f}, "
            f"{sec.get('cycle_study', 0):.0f}")  # fmt: skip
        lines.append(f"| {name} | {label} | {n} | {e} | {last} | {power:.2f} / {d:.2f} | "
                     f"{rate:.2f} [{low:.2f}, {high:.2f}] | {tp:.2f} / {td:.2f} | "
                     f"{tr[0]:.2f} [{tr[1]:.2f}, {tr[2]:.2f}] | {s} |")  # fmt: skip
    sizes = {"hypokinesia_mild": "a fifth of the motion (mild)", "hypokinesia": "half the motion"}
    cohorts = " and ".join(sizes[c] for c in dict.fromkeys(r[0] for r in rows))
    note = (
        f"Synthetic subjects through {n_frames} frames (ES at 35 %), short-axis label series "
        "of 1.5 x 1.5 x 8 mm; tracking by projection with refine_ed; whole-cycle hypokinesia "
        f"of segments 7, 8, 13, 14 at {cohorts}. Correspondence of the ED meshes without "
        "landmarks (the surface fit alone turns each mesh about its long axis) or with the "
        f"cohort's landmark table (apex, base-plane centre, septal point). {permutations:,} "
        f"permutations, FWER 5 %; null: {repetitions} random splits of the controls. Rows "
        "'without segment 17' test every vertex but the atlas's apical cap (AHA, from its "
        "landmarks; `cycle-analyze --exclude-segments 17`), power and Dice over the planted "
        "region outside it. Rows 'maps smoothed': every subject's normal-motion map at every "
        f"frame smoothed on the atlas by the heat kernel of {FWHM:g} mm full width at half "
        f"maximum before the tests (`cycle-analyze --fwhm {FWHM:g}`). Seconds "
        "per subject: a stage's wall-clock time over the subjects, 2 subjects at a time on "
        "the 2 cores (throughput), from the run that computed the stage."
    )
    if shared:
        note += (" The stages of this run shared the cores with another job: their seconds "
                 "are upper bounds (`tracking_speed` has the tracking alone).")  # fmt: skip
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("symladders-output/bench_cycle_routes"))
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--cohorts", nargs="+", choices=tuple(COHORTS), default=list(COHORTS))
    parser.add_argument("--landmarks", choices=("with", "without", "both"), default="both",
                        help="correspondence with the cohort's landmark table, without, or both")  # fmt: skip
    parser.add_argument("--shared-cores", action="store_true",
                        help="say in the table that the stages ran beside another job")  # fmt: skip
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    n, n_frames = (12, 10) if args.quick else (40, 25)
    permutations, repetitions = (500, 10) if args.quick else (5000, 100)
    seconds_file = args.work / "seconds.json"
    seconds = json.loads(seconds_file.read_text()) if seconds_file.is_file() else {}
    routes = {"with": [True], "without": [False], "both": [False, True]}[args.landmarks]
    for name in args.cohorts:
        for landmarks in routes:
            now = run_route(args.work, name, n, n_frames, args.jobs, landmarks)
            key = name + ("_landmarks" if landmarks else "")
            if now.get("track", 0) > 1.0:  # this run computed these stages: keep their times
                # a stage reused from an earlier run takes well under half a second a subject
                computed = {k: v for k, v in now.items() if v > 0.5 * n}
                seconds[key] = {**seconds.get(key, {}), **computed}
                seconds_file.write_text(json.dumps(seconds, indent=1))
    table = _table(rows(args.work, n, n_frames, seconds, permutations, repetitions,
                        np.random.default_rng(0)), n_frames, permutations, repetitions,
                   args.shared_cores)  # fmt: skip
    print("\n" + table)
    if args.publish:
        command = "python benchmarks/bench_cycle_routes.py" + (
            " --shared-cores" if args.shared_cores else "")  # fmt: skip
        publish("cycle_routes", table, command + " --publish")


if __name__ == "__main__":
    main()
