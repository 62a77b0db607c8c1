"""Group tests through cine images: the whole-cycle cohorts tracked by image registration.

    python benchmarks/bench_cycle_cine.py --work symladders-output/bench_cycle_cine \
        [--cohorts twist hypokinesia_mild] [--images tagged plain] [--jobs 2] [--publish]

The route a user runs from cine series (``symladders cohort --cycle 25 --images cine
[--tagging]``, then ``symladders track MESHES IMAGES --cine``), with the library's
functions: the whole-cycle cohort (:func:`~ladders.study.population.make_two_group_cycles`,
seed 0, 20 patients against 20 controls, 25 frames) written as short-axis cine series
of 1.5 x 1.5 x 8 mm (:func:`~ladders.study.population.write_cycle_cohort`, its default
noise), with the tagging grid (:class:`~ladders.study.imaging.TagGrid` defaults) or
without; each subject's ED mesh in the atlas's correspondence (the cohort's
``<subject>_ed``, so that the rows measure the tracking, not the ED correspondence)
moved through every frame by :func:`~ladders.study.tracking.track_cohort` with the
defaults of :class:`~ladders.study.tracking.CineTrackingSettings` (every frame
registered to ED). Cohorts: a whole-cycle twist (5 degrees about the long axis in
segments 7, 8, 13, 14) and the hypokinesia at a fifth of the motion (mild).

Measured per cohort and images, beside the same tests on the true frames:

* tracking: the error at ES of every vertex against its true place (the ED mesh is the
  true one), split along the true surface's normal and along the wall; the twist error
  (apex minus base rotation about the long axis, degrees), mean over subjects;
* four tests per vertex (FWER 5 %): Hotelling's ``T^2`` on the displacement from
  ED to ES (:func:`~ladders.statistics.vertexwise_test`); the peak test of the rotation
  about the long axis through the cycle (the circumferential motion a twist changes,
  free of the error along the long axis; :func:`~ladders.study.sequences.compare_cycles`
  with ``measure="rotation"``, the axis from the atlas's landmarks, as
  ``symladders cycle-analyze --measure rotation``); and the peak test of the normal
  motion through the cycle (``compare_cycles``'s default), by the maximum statistic
  and with TFCE (``--tfce``). Power and Dice against the
  planted region at FWER 5 %, and each test's null FWER from random 10-against-10
  splits of the controls, with a binomial interval. No transport (the ED meshes are in
  the atlas's correspondence and pose).

With ``--transport`` the table is ``cycle_cine_transport``: every tracked subject's frames
also carried to the atlas by the pole ladder with residuals (``alpha^2 = 100``,
:func:`~ladders.study.sequences.run_cycle_study`, as ``symladders cycle-study``), the
normal peak's tests (max-t and TFCE) with and without that transport.

With ``--fwhm 10`` the table is ``cycle_cine_smoothed``: the normal peak's tests (max-t
and TFCE) on the raw maps and on every map smoothed on the atlas by the heat kernel of
that full width at half maximum (``compare_cycles(..., fwhm=10)``), with the region's
group difference and effect size of both.

Each stage resumes (the series, the tracked meshes and the table's rows are kept under
``--work``).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_cine_tracking import split_error, twist  # noqa: E402
from bench_cycle_study import null_splits  # noqa: E402
from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import binomial_interval, detection_power, dice, vertexwise_test  # noqa: E402
from ladders.study.cohort.planted_effect import MotionAbnormality  # noqa: E402
from ladders.study.imaging import TagGrid  # noqa: E402
from ladders.study.meshes.mesh_io import read_mesh  # noqa: E402
from ladders.study.population import (  # noqa: E402
    CYCLE_ABNORMALITY,
    make_two_group_cycles,
    write_cycle_cohort,
)
from ladders.study.preparation.synthetic_landmarks import synthetic_landmarks  # noqa: E402
from ladders.study.sequences import (  # noqa: E402
    CycleMotion,
    compare_cycles,
    curve_peaks,
    load_cycle_motion,
    read_tracked_frames,
    run_cycle_study,
)
from ladders.study.tracking import CineTrackingSettings, track_cohort  # noqa: E402

COHORTS = {"twist": MotionAbnormality("twist", transition_height=0.1),
           "hypokinesia_mild": replace(CYCLE_ABNORMALITY, magnitude=0.2)}  # fmt: skip
IMAGES = {"tagged": TagGrid(), "plain": None}
#: The pole ladder's residual weight of ``--transport`` (that of ``bench_cycle_routes``).
ALPHA2 = 100.0


#: The summary these tables report: the peak (the other summaries are not computed).
PEAK = ("peak",)


def _cycles(name, n, n_frames):
    return make_two_group_cycles(n_subjects=n, abnormality=COHORTS[name], n_frames=n_frames)


def run_route(work: Path, name: str, images: str, n: int, n_frames: int, jobs: int,
              transport: bool = False) -> dict:  # fmt: skip
    """Write the cine series, track every subject and, with ``transport``, carry the
    tracked frames to the atlas (each stage resumes); seconds."""
    c = _cycles(name, n, n_frames)
    root = work / f"{name}_{images}"
    seconds = {}
    start = time.perf_counter()
    if not (root / "cohort" / "cycle.json").is_file():
        write_cycle_cohort(c, root / "cohort", "cine", 1.5, 8.0, tagging=IMAGES[images])
    seconds["render"] = time.perf_counter() - start
    start = time.perf_counter()
    outcome = track_cohort(root / "cohort", root / "cohort" / "images", root / "tracked", 1,
                           CineTrackingSettings(), jobs=jobs, progress=False)  # fmt: skip
    seconds["track"] = time.perf_counter() - start
    if outcome.failed:
        print(f"  {name} {images}: failed {outcome.failed}", flush=True)
    print(f"  {name} {images}: render {seconds['render']:.0f} s, track "
          f"{seconds['track']:.0f} s", flush=True)  # fmt: skip
    if transport:
        atlas, faces = read_mesh(root / "cohort" / "atlas.vtk")
        start = time.perf_counter()
        run_cycle_study(atlas, faces, read_tracked_frames(root / "tracked"),
                        root / "cycle_study", alpha2=ALPHA2, jobs=jobs)  # fmt: skip
        seconds["cycle_study"] = time.perf_counter() - start
        print(f"  {name} {images}: cycle study {seconds['cycle_study']:.0f} s", flush=True)
    return seconds


def _tracked(root: Path, c, folder: str = "tracked"):
    """Names and frames ``(n, T, k, 3)`` of the subjects tracked into ``root / folder``."""
    sequences = read_tracked_frames(root / folder)
    names = [s for s in c.names if s in sequences]
    return names, np.stack([[read_mesh(p)[0] for p in sequences[s]] for s in names])


def _errors(c, names, frames) -> tuple[float, float, float]:
    """Mean ES error along the normal and along the wall (mm), mean twist error (deg)."""
    es = int(np.argmax(c.fractions))
    normal, tangential, twists = [], [], []
    for name, tracked in zip(names, frames):
        i = c.names.index(name)
        truth = c.frames[i]
        a, b = split_error(tracked[es], truth[es], c.faces)
        params, _ = c.motion_of(i)
        normal.append(a)
        tangential.append(b)
        twists.append(
            abs(twist(params, truth[0], tracked[es]) - twist(params, truth[0], truth[es]))
        )
    return float(np.mean(normal)), float(np.mean(tangential)), float(np.mean(twists))


#: The tests' version, part of a cached row's key.
TESTS = "displacement, rotation peak, normal peak, normal peak TFCE"


def _tests(motion: CycleMotion, labels, es: int, permutations: int, rng, axis):
    """Significant vertices of the ES displacement, peak rotation, normal peak and normal
    peak with TFCE tests."""
    displacement = motion.displacement[:, es] - motion.displacement[:, 0]
    rotation = compare_cycles(motion, labels, permutations, rng, measure="rotation", axis=axis,
                              summaries=PEAK)  # fmt: skip
    normal = compare_cycles(motion, labels, permutations, rng, tfce=True, summaries=PEAK)
    return (
        vertexwise_test(displacement, labels, permutations, rng).p_fwer < 0.05,
        rotation.peak.p_fwer < 0.05,
        normal.peak.p_fwer < 0.05,
        normal.peak_tfce.p_fwer_enhanced < 0.05,
    )


#: The smoothing rows' tests (``--fwhm``), part of their cached rows' key.
TESTS_SMOOTHED = "normal peak, normal peak TFCE, both on maps smoothed by fwhm"


def _tests_smoothed(motion: CycleMotion, labels, es, permutations: int, rng, axis, fwhm):
    """Significant vertices of the normal peak and its TFCE, on the raw maps and on the
    maps smoothed by ``fwhm`` (mm)."""
    raw = compare_cycles(motion, labels, permutations, rng, tfce=True, summaries=PEAK)
    smooth = compare_cycles(motion, labels, permutations, rng, tfce=True, fwhm=fwhm,
                            summaries=PEAK)  # fmt: skip
    return tuple(t for r in (raw, smooth)
                 for t in (r.peak.p_fwer < 0.05, r.peak_tfce.p_fwer_enhanced < 0.05))  # fmt: skip


#: The transport rows' tests (``--transport``), part of their cached rows' key.
TESTS_TRANSPORT = "normal peak, normal peak TFCE"


def _tests_normal(motion: CycleMotion, labels, permutations: int, rng):
    """Significant vertices of the normal peak and of its TFCE."""
    normal = compare_cycles(motion, labels, permutations, rng, tfce=True, summaries=PEAK)
    return normal.peak.p_fwer < 0.05, normal.peak_tfce.p_fwer_enhanced < 0.05


def _scores(motion, c, permutations, repetitions, rng, fwhm=None, transport=False):
    es = int(np.argmax(c.fractions))
    labels = np.array([c.patients[c.names.index(s)] for s in motion.subjects])
    region = c.data.region.affected
    axis = synthetic_landmarks(c.data.cohort.atlas)

    def tests(m, split, count):
        if transport:
            return _tests_normal(m, split, count, rng)
        if fwhm is None:
            return _tests(m, split, es, count, rng, axis)
        return _tests_smoothed(m, split, es, count, rng, axis, fwhm)

    found = tests(motion, labels, permutations)
    hits = np.zeros(len(found), dtype=int)
    for sub, split in null_splits(motion, np.flatnonzero(~labels), rng, repetitions):
        found_null = tests(sub, split, min(permutations, 500))
        hits += [bool(f.any()) for f in found_null]
    out = []
    for f, h in zip(found, hits):
        out.append((detection_power(f[region], region[region]), dice(f, region),
                    h / repetitions, *binomial_interval(int(h), repetitions)))  # fmt: skip
    return out


def _peak_effect(motion: CycleMotion, c, fwhm=None) -> tuple[float, float]:
    """Over the planted region: the mean group difference of the peak inward motion
    (patients minus controls, mm) and its mean effect size (over the pooled SD); with
    ``fwhm``, of the maps smoothed first."""
    peaks = curve_peaks(motion.curves(fwhm=fwhm))[0][:, c.data.region.affected]
    labels = np.array([c.patients[c.names.index(s)] for s in motion.subjects])
    difference, pooled = group_difference(peaks, labels)
    return float(difference.mean()), float((difference / pooled).mean())


def group_difference(values, labels) -> tuple[np.ndarray, np.ndarray]:
    """Per column of ``values`` ``(n, k)``: the first group's mean minus the second's, and
    the pooled within-group SD."""
    a, b = values[labels], values[~labels]
    pooled = np.sqrt((a.var(axis=0, ddof=1) + b.var(axis=0, ddof=1)) / 2)
    return a.mean(axis=0) - b.mean(axis=0), pooled


def _fingerprint(folder: Path) -> str:
    """Names, sizes and times of the tracked meshes: a row is recomputed when they change."""
    files = sorted(f for f in folder.rglob("*") if f.is_file())
    text = "".join(
        f"{f.relative_to(folder)}:{f.stat().st_size}:{f.stat().st_mtime_ns};" for f in files
    )
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def rows(work: Path, cohorts, images, n, n_frames, permutations, repetitions, seed=0,
         fwhm=None, transport=False) -> list:  # fmt: skip
    """The table's rows; each (cohort, motion) with its own random stream, kept in
    ``WORK/rows.json`` as it finishes and reused while its inputs are the same. With
    ``fwhm``: the normal peak's tests on raw and smoothed maps; with ``transport``: the
    normal peak's tests, the tracked frames also transported by the pole ladder."""
    tests = TESTS if fwhm is None else f"{TESTS_SMOOTHED} = {fwhm:g}"
    tests = TESTS_TRANSPORT if transport else tests
    cache_path = work / "rows.json"
    cache = json.loads(cache_path.read_text()) if cache_path.is_file() else {}
    work.mkdir(parents=True, exist_ok=True)
    out = []
    for name in cohorts:
        c = _cycles(name, n, n_frames)
        atlas = c.data.cohort.atlas
        motions = [("true frames (meshes in correspondence)", None,
                    CycleMotion(c.names, c.frames - c.frames[:, :1], atlas, c.faces), "truth")]  # fmt: skip
        for kind in images:
            root = work / f"{name}_{kind}"
            if (root / "tracked").is_dir():
                names, frames = _tracked(root, c)
                errors = _errors(c, names, frames)
                motions.append((f"{kind} cine, tracked", errors,
                                CycleMotion(tuple(names), frames - frames[:, :1], atlas, c.faces),
                                _fingerprint(root / "tracked")))  # fmt: skip
                if transport and (root / "cycle_study" / "cycle_study.json").is_file():
                    # already on the atlas: the study's transported frames
                    motions.append((f"{kind} cine, tracked, pole ladder alpha^2 = {ALPHA2:g}",
                                    errors, load_cycle_motion(root / "cycle_study"),
                                    _fingerprint(root / "cycle_study")))  # fmt: skip
        for label, errors, motion, source in motions:
            key = f"{name}|{label}|{n}|{n_frames}|{permutations}|{repetitions}|{seed}|{source}|{tests}"
            if key not in cache:
                index = [tuple(COHORTS).index(name), 1 + list(IMAGES).index(label.split()[0])
                         if errors is not None else 0]  # fmt: skip
                if transport:  # the transported row a stream of its own
                    index.append(int("pole ladder" in label))
                rng = np.random.default_rng([seed, *index])
                scores = _scores(motion, c, permutations, repetitions, rng, fwhm, transport)
                cache[key] = [name, label, len(motion.subjects), errors, *scores]
                cache_path.write_text(json.dumps(cache, indent=1))
            effects = [_peak_effect(motion, c)]
            if fwhm is not None:
                effects.append(_peak_effect(motion, c, fwhm))
            out.append((*cache[key], *effects))
            print(out[-1], flush=True)
    return out


def _errors_cell(err) -> str:
    return "truth" if err is None else f"{err[0]:.2f} / {err[1]:.2f}, {err[2]:.2f}"


def _note(n_frames, permutations, repetitions) -> str:
    return (
        f"Synthetic subjects through {n_frames} frames (ES at 35 %), short-axis cine series of "
        "1.5 x 1.5 x 8 mm with the cohort writer's noise, tagged (lines 7 mm apart) or not; "
        "each subject's true ED mesh (in the atlas's correspondence) tracked with the "
        "default cine settings (every frame registered to ED, the metric sampling the voxels "
        f"within {CineTrackingSettings().mask_distance:g} mm of the ED mesh). Twist: 5 "
        "degrees about the "
        "long axis in segments 7, 8, 13, 14; hypokinesia_mild: a fifth of the motion in the "
        f"same segments. {permutations:,} permutations, FWER 5 %; null: {repetitions} random "
        "10-against-10 splits of the controls (500 permutations each). No transport."
    )


def _markdown(rows, tests: list[str], effect: str, note: str) -> str:
    """The note and the table: a column per test (power / Dice, null FWER [95 % CI]) and
    the region's effect (group difference, effect size; raw, then smoothed if given)."""
    head = ["cohort", "motion", "subjects", "ES error normal / along the wall (mm), twist "
            "error (deg)", *tests, effect]  # fmt: skip
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, label, n, err, *scores in rows:
        cells = [f"{p:.2f} / {d:.2f}, {r:.2f} [{lo:.2f}, {hi:.2f}]"
                 for p, d, r, lo, hi in scores[:len(tests)]]  # fmt: skip
        cells.append("; ".join(f"{a:.2f}, {b:.2f}" for a, b in scores[len(tests) :]))
        lines.append(f"| {name} | {label} | {n} | {_errors_cell(err)} | " + " | ".join(cells)
                     + " |")  # fmt: skip
    return note + "\n\n" + "\n".join(lines) + "\n"


def _table_smoothed(rows, n_frames, permutations, repetitions, fwhm) -> str:
    tests = ["normal peak (t): power / Dice, null FWER [95 % CI]", "normal peak with TFCE",
             f"maps smoothed {fwhm:g} mm FWHM: normal peak (t)",
             "maps smoothed, normal peak with TFCE"]  # fmt: skip
    note = _note(n_frames, permutations, repetitions) + (
        f" Smoothed: every subject's normal-motion map at every frame smoothed on the atlas "
        f"by the heat kernel of {fwhm:g} mm full width at half maximum before the tests "
        f"(`cycle-analyze --fwhm {fwhm:g}`); the raw and smoothed tests of a row share its "
        "random stream."
    )
    return _markdown(rows, tests, "normal peak in the planted region: group difference (mm), "
                     "effect size, raw; smoothed", note)  # fmt: skip


def _table_transport(rows, n_frames, permutations, repetitions) -> str:
    tests = ["normal peak (t): power / Dice, null FWER [95 % CI]",
             "normal peak with TFCE: power / Dice, null FWER [95 % CI]"]  # fmt: skip
    note = _note(n_frames, permutations, repetitions).replace("No transport.", (
        f"Rows 'pole ladder': every tracked frame's deformation from the subject's ED carried "
        f"to the atlas by the pole ladder with residuals, alpha^2 = {ALPHA2:g} "
        "(`symladders cycle-study`); the other rows untransported (the ED meshes are in the "
        "atlas's correspondence and pose)."))  # fmt: skip
    return _markdown(rows, tests, EFFECT, note)


#: The last column of the tables without smoothing.
EFFECT = "normal peak in the planted region: group difference (mm), effect size"


def _table(rows, n_frames, permutations, repetitions) -> str:
    tests = ["ES displacement (Hotelling): power / Dice, null FWER [95 % CI]",
             "peak rotation about the long axis (t): power / Dice, null FWER",
             "normal peak (t): power / Dice, null FWER",
             "normal peak with TFCE: power / Dice, null FWER"]  # fmt: skip
    return _markdown(rows, tests, EFFECT, _note(n_frames, permutations, repetitions))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("symladders-output/bench_cycle_cine"))
    parser.add_argument("--cohorts", nargs="+", choices=tuple(COHORTS), default=["twist"])
    parser.add_argument("--images", nargs="+", choices=tuple(IMAGES), default=list(IMAGES))
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--quick", action="store_true", help="12 subjects, 10 frames")
    parser.add_argument("--no-run", action="store_true", help="only the tests of what is tracked")
    parser.add_argument("--fwhm", type=float, default=None,
                        help="instead: the normal peak's tests on raw maps and on maps smoothed "
                             "by this FWHM (mm), published as cycle_cine_smoothed")  # fmt: skip
    parser.add_argument("--transport", action="store_true",
                        help="instead: the normal peak's tests with the tracked frames also "
                             "transported by the pole ladder, published as "
                             "cycle_cine_transport")  # fmt: skip
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    n, n_frames = (12, 10) if args.quick else (40, 25)
    work = args.work / "quick" if args.quick else args.work  # its own cohort
    permutations, repetitions = (500, 10) if args.quick else (5000, 100)
    if not args.no_run:
        for name in args.cohorts:
            for kind in args.images:
                run_route(work, name, kind, n, n_frames, args.jobs, args.transport)
    found = rows(work, args.cohorts, args.images, n, n_frames, permutations, repetitions,
                 fwhm=args.fwhm, transport=args.transport)  # fmt: skip
    if args.transport:
        table = _table_transport(found, n_frames, permutations, repetitions)
    elif args.fwhm is None:
        table = _table(found, n_frames, permutations, repetitions)
    else:
        table = _table_smoothed(found, n_frames, permutations, repetitions, args.fwhm)
    missing = [f"{name} through {kind} cine" for name in args.cohorts for kind in args.images
               if not (work / f"{name}_{kind}" / "tracked").is_dir()]  # fmt: skip
    if missing:
        text = f"Not run: {', '.join(missing)}."
        table = (table.replace("Rows 'pole ladder'", f"{text} Rows 'pole ladder'", 1)
                 if args.transport else table.replace("No transport.", f"No transport. {text}", 1))  # fmt: skip
    print("\n" + table)
    if args.publish:
        # the stages resume: a run with --no-run publishes what the full command computes
        command = "python benchmarks/bench_cycle_cine.py --cohorts "
        command += " ".join(args.cohorts) + " --images " + " ".join(args.images)
        if args.fwhm is not None:
            command += f" --fwhm {args.fwhm:g}"
        command += " --transport" * args.transport
        name = "cycle_cine_transport" if args.transport else (
            "cycle_cine" if args.fwhm is None else "cycle_cine_smoothed")  # fmt: skip
        publish(name, table, command + " --publish")


if __name__ == "__main__":
    main()
