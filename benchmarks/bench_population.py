"""Which transport finds a planted motion abnormality: power, Dice, AUC, false positives.

    python benchmarks/bench_population.py                  # studies (resumed), then the analysis
    python benchmarks/bench_population.py --stage studies  # only the studies
    python benchmarks/bench_population.py --quick          # 16 subjects, alpha^2 = 1 only

Cohorts (``make_two_group_cohort``, seed 0, 40 subjects, 20 patients, 1,009 vertices):

* ``hypokinesia``: the default abnormality (radial contraction and longitudinal
  shortening halved in AHA segments 7, 8, 13, 14), which a surface shows;
* ``hypokinesia_mild``: the same with a fifth of the motion removed (a weaker effect,
  where the transports' powers differ);
* ``twist``: 5 degrees of extra rotation about the long axis in the same segments,
  tangential to the wall, which a surface without material landmarks does not show;
* ``null``: the same subjects without any abnormality (both groups from one distribution).

Arms: ``corresponded`` (the meshes in vertex correspondence, as generated) and three
through segmentations, every mesh re-triangulated (as many faces as the atlas) and
brought back into correspondence by ``correspond_cohort`` with its defaults (the
input's own turn about the long axis kept, end-systole by normal projection):
``segmentations`` (each subject moved by a random rigid motion of up to 30 degrees,
with the landmark table: what segmentations in scanner coordinates with an RV label
give), ``segmentations_unposed`` (in the atlas's frame, no landmarks) and
``segmentations_nolandmarks`` (posed, no landmarks: the twist of each pose about the
long axis is then left). The studies are listed in :data:`PLAN` (LDDMM at ``alpha^2``
in 0.01, 1, 100 on the meshes in correspondence, SVF and the twist at 1, the
segmentation arms at 1, the mild hypokinesia through the posed segmentations too); the segmentation arms are scored on their 40 subjects and on
the first 20 (``<cohort>_20``); the analysis
scores every transport and the motion without transport against the planted
region (:func:`ladders.study.population.score_transports`) with 10,000 permutations,
and measures the family-wise false-positive rate on the null cohort (200 random
splits, 1,000 permutations each). Tables: ``docs/generated/population_*.md``.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.study import StudyConfig, read_cohort, run_study  # noqa: E402
from ladders.study.cohort import MotionAbnormality  # noqa: E402
from ladders.study.population import (  # noqa: E402
    load_transported_motion,
    make_two_group_cohort,
    read_scores_csv,
    score_transports,
    scores_csv,
    scores_markdown,
    write_two_group_cohort,
)
from ladders.study.population.analysis_outputs import plot_transport_scores  # noqa: E402

DOCS_IMAGES = Path(__file__).resolve().parents[1] / "docs" / "images"
COHORTS = {
    "hypokinesia": MotionAbnormality(),
    "hypokinesia_mild": MotionAbnormality(magnitude=0.2),
    "twist": MotionAbnormality("twist"),
    "null": None,
}
ARMS = ("corresponded", "segmentations", "segmentations_unposed", "segmentations_nolandmarks")
#: Segmentation arms: (posed, landmark table used).
SEGMENTATION_ARMS = {
    "segmentations": (True, True),
    "segmentations_unposed": (False, False),
    "segmentations_nolandmarks": (True, False),
}
#: The studies: (arm, cohort, deformation, alpha^2, subjects). The alpha^2 sweep runs with
#: LDDMM on the meshes in correspondence; SVF and the twist at alpha^2 = 1; the
#: segmentations arm (whose correspondence costs most) on the first 20 subjects.
PLAN = (
    ("corresponded", "hypokinesia", "lddmm", (0.01, 1.0, 100.0), 40),
    ("corresponded", "null", "lddmm", (0.01, 1.0, 100.0), 40),
    ("corresponded", "hypokinesia", "svf", (1.0,), 40),
    ("corresponded", "hypokinesia_mild", "lddmm", (0.01, 1.0, 100.0), 40),
    ("corresponded", "hypokinesia_mild", "svf", (1.0,), 40),
    ("corresponded", "null", "svf", (1.0,), 40),
    ("corresponded", "twist", "lddmm", (1.0,), 40),
    ("segmentations", "hypokinesia", "lddmm", (1.0,), 40),
    ("segmentations", "null", "lddmm", (1.0,), 40),
    ("segmentations", "hypokinesia_mild", "lddmm", (1.0,), 40),
    ("segmentations", "twist", "lddmm", (1.0,), 20),
    ("segmentations_unposed", "hypokinesia", "lddmm", (1.0,), 40),
    ("segmentations_unposed", "null", "lddmm", (1.0,), 40),
    ("segmentations_nolandmarks", "hypokinesia", "lddmm", (1.0,), 40),
)


def _cohort(name: str, n: int):
    return make_two_group_cohort(n_subjects=n, abnormality=COHORTS[name], seed=0)


def _subjects_and_atlas(arm: str, name: str, n: int, work: Path, jobs: int):
    data = _cohort(name, 40)
    if n < len(data.cohort):  # the first n subjects, with their groups
        data.cohort = data.cohort.head(n)
        data.groups = {s.name: data.groups[s.name] for s in data.cohort.subjects}
    if arm == "corresponded":
        return data.cohort, data
    from ladders.study.preparation import correspond_cohort

    posed, landmarks = SEGMENTATION_ARMS[arm]
    raw = work / "segmentations" / f"{name}_{'posed' if posed else 'unposed'}"
    if not (raw / "landmarks.csv").is_file():
        write_two_group_cohort(data, raw, remesh_factor=1.0, pose=posed, landmarks=True)
    out = work / "corresponded" / arm / name
    start = time.perf_counter()
    correspond_cohort(raw / "atlas.vtk", raw, out, jobs=jobs,
                      landmarks=None if landmarks else False)  # fmt: skip
    print(f"  correspondence of {2 * n} meshes: {time.perf_counter() - start:.0f} s", flush=True)
    return read_cohort(out), data


def _plan(quick: bool, arms, cohorts, only_alpha2=None):
    for arm, name, deformation, alpha2, n in PLAN:
        if only_alpha2 is not None:
            alpha2 = tuple(a for a in alpha2 if a in only_alpha2)
        if arm in arms and name in cohorts and alpha2:
            yield (
                (arm, name, deformation, (1.0,), 16)
                if quick
                else (arm, name, deformation, alpha2, n)
            )


def run_studies(work: Path, jobs: int, plan) -> None:
    for arm, name, deformation, alpha2, n in plan:
        cohort, _ = _subjects_and_atlas(arm, name, n, work, jobs)
        config = StudyConfig.build(alpha2=alpha2, deformation=deformation)
        out = work / "studies" / arm / name / deformation
        start = time.perf_counter()
        outcome = run_study(config, cohort.atlas, cohort.faces, cohort.subjects, out,
                            jobs=jobs, progress=False, meshes=False)  # fmt: skip
        print(f"  {arm}/{name}/{deformation}: {len(outcome.computed)} pairs computed, "
              f"{len(outcome.failures)} failed, {time.perf_counter() - start:.0f} s",
              flush=True)  # fmt: skip


def _motions(work: Path, arm: str, name: str, subjects=None):
    """The motions of both deformations' studies (the motion without transport once)."""
    motions = []
    for deformation in ("lddmm", "svf"):
        folder = work / "studies" / arm / name / deformation
        if not folder.is_dir():
            continue
        for m in load_transported_motion(folder):
            if subjects is not None:
                m = m.subset(subjects)
            if m.method == "none" and any(x.method == "none" for x in motions):
                continue
            motions.append(m)
    return motions


def _note(data, labels, n_permutations: int, repetitions: int | None) -> str:
    return (
        f"{data.region.abnormality.describe()}; {len(labels)} subjects "
        f"({int(labels.sum())} patients); {int(data.region.affected.sum())} of "
        f"{data.region.weight.size} atlas vertices affected; {n_permutations:,} "
        "permutations; FWER under the null: "
        + (f"{repetitions} random splits of the same subjects without the abnormality."
           if repetitions else "not measured in this arm.")
    )  # fmt: skip


def republish(work: Path, n_permutations: int, repetitions: int) -> None:
    """Publish the tables again from the stored scores (``scores_<tag>.csv``), e.g. after a
    change of the table's layout, without scoring again."""
    for path in sorted(work.glob("scores_*.csv")):
        tag = path.stem.removeprefix("scores_")
        scores = read_scores_csv(path.read_text())
        keep = int(tag.rsplit("_", 1)[1]) if tag.rsplit("_", 1)[1].isdigit() else None
        arm = next(a for a in sorted(ARMS, key=len, reverse=True) if tag.startswith(a + "_"))
        name = tag.removeprefix(arm + "_").removesuffix("" if keep is None else f"_{keep}")
        data = _cohort(name, 40)
        subjects = list(_motions(work, arm, name)[0].subjects)[:keep]
        labels = np.array([data.groups[s] == "patients" for s in subjects])
        has_null = any(s.fwer is not None for s in scores)
        note = _note(data, labels, n_permutations, repetitions if has_null else None)
        publish(f"population_{tag}", f"{note}\n\n{scores_markdown(scores)}",
                "python benchmarks/bench_population.py")  # fmt: skip


def _score(work, arm, name, n_permutations, repetitions, keep=None):
    """Score one arm and cohort (its first ``keep`` subjects when given); publish the table."""
    motions = _motions(work, arm, name)
    if keep is not None:
        motions = [m.subset(list(m.subjects)[:keep]) for m in motions]
    data = _cohort(name, 40)
    subjects = list(motions[0].subjects)
    labels = np.array([data.groups[s] == "patients" for s in subjects])
    nulls = None
    if (work / "studies" / arm / "null").is_dir():
        nulls = _motions(work, arm, "null", subjects)
    start = time.perf_counter()
    scores, _ = score_transports(
        motions, labels, data.region.affected, np.random.default_rng(0), nulls,
        n_permutations, repetitions, 1000,
    )  # fmt: skip
    if arm != "corresponded":  # the same subjects' meshes in correspondence, alongside
        same = _motions(work, "corresponded", name, subjects)
        same = [m for m in same if m.alpha2 in (None, 1.0) and m.deformation == "lddmm"]
        extra, _ = score_transports(same, labels, data.region.affected,
                                    np.random.default_rng(0), None, n_permutations)  # fmt: skip
        for s in extra:
            scores.append(replace(s, label=f"{s.label} [meshes in correspondence]"))
    seconds = time.perf_counter() - start
    table = scores_markdown(scores)
    tag = f"{arm}_{name}" + ("" if keep is None else f"_{keep}")
    (work / f"scores_{tag}.csv").write_text(scores_csv(scores))
    plot_transport_scores(scores, work / f"scores_{tag}.png")
    plot_transport_scores(scores, DOCS_IMAGES / f"population_{tag}.png")
    print(f"\n{tag} ({len(labels)} subjects, {seconds:.0f} s):\n{table}", flush=True)
    note = _note(data, labels, n_permutations, repetitions if nulls else None)
    publish(f"population_{tag}", f"{note}\n\n{table}", "python benchmarks/bench_population.py")


def run_analysis(work: Path, arms, cohorts, n_permutations: int, repetitions: int):
    for arm in arms:
        for name in cohorts:
            if name == "null" or not (work / "studies" / arm / name).is_dir():
                continue
            _score(work, arm, name, n_permutations, repetitions)
            n = len(_motions(work, arm, name)[0].subjects)
            if arm != "corresponded" and n > 20:
                _score(work, arm, name, n_permutations, repetitions, keep=20)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stage", choices=("studies", "analysis", "all", "tables"),
                        default="all", help="'tables': publish again from the stored scores")  # fmt: skip
    parser.add_argument("--work", type=Path, default=Path("symladders-output/bench_population"))
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--arms", nargs="+", choices=ARMS, default=list(ARMS))
    parser.add_argument("--cohorts", nargs="+", choices=tuple(COHORTS), default=list(COHORTS))
    parser.add_argument("--alpha2", nargs="+", type=float, default=None,
                        help="run only these alpha^2 of the plan")  # fmt: skip
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    if args.stage in ("studies", "all"):
        run_studies(args.work, args.jobs, _plan(args.quick, args.arms, args.cohorts, args.alpha2))
    if args.stage == "tables":
        republish(args.work, 2000 if args.quick else 10000, 50 if args.quick else 200)
    if args.stage in ("analysis", "all"):
        run_analysis(args.work, args.arms, args.cohorts, 2000 if args.quick else 10000,
                     50 if args.quick else 200)  # fmt: skip


if __name__ == "__main__":
    main()
