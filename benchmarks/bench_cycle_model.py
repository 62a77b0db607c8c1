"""The cycle's tests against planted effects, and the covariates' confound through the cycle.

    python benchmarks/bench_cycle_model.py power [--quick] [--publish]        # cycle_model_power
    python benchmarks/bench_cycle_model.py confounding [--quick] [--publish]  # cycle_model_confounding

Cohorts of the synthetic ventricle through 25 frames (ES at 35 %), 1,009 vertices, 20
controls against 20 patients, each repetition a new draw. The motion is the true
frames' (the meshes in correspondence, no tracking and no transport: the inference is
the same for a transported motion) with a tracking-like error added to every frame but
ED: per subject and vertex 0.35 mm per coordinate fixed over the frames (as the
label-series tracking's error of the peak, ``cycle_power`` in docs/population.md,
most of it the same at every frame) and 0.1 mm drawn again at each frame.

``power``: the patients carry one effect in segments 7, 8, 13 and 14 (ring transitions
of half-width 0.1): a hypokinesia of 30 % of the motion, a contraction delayed
by a tenth of the cycle (the amplitude unchanged) or a twist of 5 degrees. Every
summary of :func:`~ladders.study.sequences.compare_cycles` is tested (the model
``group``, Freedman-Lane permutations, FWER 5 %): per frame (over vertices and frames),
peak, time to peak and the trajectory (Pillai's trace on each vertex's first
principal components: the rule's ``d``, and ``d = 1``, what the 90 % rule alone gives
here), each by the maximum statistic and with TFCE. The twist is tested on the
rotation about the long axis and on the normal motion. Power and Dice are against the
planted region (weight >= 0.5; the transitions beyond it are partly affected too); the
null family-wise error is the fraction of cohorts without an effect where a test finds
any vertex, with its exact (Clopper-Pearson) 95 % interval.

``confounding``: the patients are older and larger than the controls (``imbalance``
1: two standard deviations of age and body size; age reduces the contraction by 0.15
per standard deviation, body size scales every length), with no effect (null) or the
hypokinesia; the models ``group`` (unadjusted) and ``group + age + body_size``
(adjusted), maximum statistic.
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

from ladders.statistics import binomial_interval, design_matrix, detection_power, dice  # noqa: E402
from ladders.study.cohort.planted_effect import MotionAbnormality  # noqa: E402
from ladders.study.population import (  # noqa: E402
    Covariates,
    covariate_cycles,
    make_covariate_cohort,
    make_two_group_cycles,
)
from ladders.study.preparation.synthetic_landmarks import synthetic_landmarks  # noqa: E402
from ladders.study.sequences import (  # noqa: E402
    CycleMotion,
    cycle_model,
    cycle_responses,
    trajectory_components,
)

N_SUBJECTS, N_FRAMES, FIXED_MM, FRAME_MM = 40, 25, 0.35, 0.1
EFFECTS = {
    "hypokinesia 0.3": MotionAbnormality("hypokinesia", magnitude=0.3, transition_height=0.1),
    "delay 0.1": MotionAbnormality("delay", magnitude=0.1, transition_height=0.1),
    "twist 5 deg": MotionAbnormality("twist", magnitude=5.0, transition_height=0.1),
}
CONTRAST = "group[patients] - group[controls]"
NAMES = {"per_frame": "per frame", "peak": "peak", "time_to_peak": "time to peak",
         "trajectory": "trajectory", "trajectory_d1": "trajectory, d = 1"}  # fmt: skip


def noisy_motion(frames, names, atlas, faces, rng) -> CycleMotion:
    """The true frames' motion with the tracking-like error of the module."""
    d = frames - frames[:, :1]
    n, n_frames, k, _ = d.shape
    error = rng.normal(size=(n, 1, k, 3)) * FIXED_MM + rng.normal(size=d.shape) * FRAME_MM
    error[:, 0] = 0.0
    return CycleMotion(tuple(names), d + error, atlas, faces)


def _design(names, patients):
    table = {"subject": list(names), "group": ["patients" if p else "controls" for p in patients]}
    return design_matrix(table, "group")


def _found(motion, patients, measure, axis, permutations, rng) -> tuple[dict, int, float]:
    """``{(summary, tfce): found (k,)}``, the rule's d and the variance the first component
    holds."""
    responses = cycle_responses(motion, measure, axis)
    design = _design(motion.subjects, patients)
    tests = cycle_model(responses, design, CONTRAST, permutations, rng, tfce=True)
    out = {(s, e): tests.detected(s, tfce=e) for s in tests.tests() for e in (False, True)}
    one = replace(responses, trajectory=trajectory_components(
        responses.curves[..., responses.tested], n_components=1))  # fmt: skip
    single = cycle_model(one, design, CONTRAST, permutations, rng, tfce=True,
                         summaries=("trajectory",))  # fmt: skip
    for e in (False, True):
        out[("trajectory_d1", e)] = single.detected("trajectory", tfce=e)
    return out, tests.components, one.trajectory.explained


def _cohort(seed, abnormality):
    c = make_two_group_cycles(N_SUBJECTS, abnormality, N_FRAMES, seed=seed, check=False)
    motion = noisy_motion(c.frames, c.names, c.data.cohort.atlas, c.faces,
                          np.random.default_rng([seed, 7]))  # fmt: skip
    return c, motion


def power(args) -> str:
    rng = np.random.default_rng(0)
    start = time.perf_counter()
    scores, nulls, components = {}, {}, []
    for label, abnormality in EFFECTS.items():
        measures = ("rotation", "normal") if abnormality.kind == "twist" else ("normal",)
        for r in range(args.effects):
            c, motion = _cohort(2000 + r, abnormality)
            axis = synthetic_landmarks(c.data.cohort.atlas)
            region = c.data.region.affected
            for measure in measures:
                found, d, explained = _found(motion, c.patients, measure, axis,
                                             args.permutations, rng)  # fmt: skip
                components.append((d, explained))
                for key, f in found.items():
                    scores.setdefault((label, measure, key), []).append(
                        (detection_power(f, region), dice(f, region))
                    )
            print(f"{label} {r + 1}/{args.effects} ({time.perf_counter() - start:.0f} s)",
                  flush=True)  # fmt: skip
    for r in range(args.null):
        c, motion = _cohort(1000 + r, None)
        axis = synthetic_landmarks(c.data.cohort.atlas)
        for measure in ("normal", "rotation"):
            found, d, explained = _found(motion, c.patients, measure, axis, args.permutations,
                                         rng)  # fmt: skip
            components.append((d, explained))
            for key, f in found.items():
                nulls.setdefault((measure, key), []).append(bool(f.any()))
        if (r + 1) % 10 == 0:
            print(f"null {r + 1}/{args.null} ({time.perf_counter() - start:.0f} s)", flush=True)
    seconds = time.perf_counter() - start
    ds = np.array([d for d, _ in components])
    columns = [(label, m) for label, a in EFFECTS.items()
               for m in (("rotation", "normal") if a.kind == "twist" else ("normal",))]  # fmt: skip
    head = (
        "| test | "
        + " | ".join(
            f"{label}{' (' + m + ')' if 'twist' in label else ''}: power / Dice"
            for label, m in columns
        )
        + " | null FWER, normal [95 % CI] | null FWER, rotation [95 % CI] |"
    )
    lines = [head, "|---|" + "---|" * (len(columns) + 2)]
    for summary in NAMES:
        for enhanced in (False, True):
            key = (summary, enhanced)
            cells = [f"{NAMES[summary]}{', TFCE' if enhanced else ''}"]
            for label, m in columns:
                p = np.mean(scores[(label, m, key)], axis=0)
                cells.append(f"{p[0]:.2f} / {p[1]:.2f}")
            for m in ("normal", "rotation"):
                hits = nulls[(m, key)]
                low, high = binomial_interval(sum(hits), len(hits))
                cells.append(f"{np.mean(hits):.2f} [{low:.2f}, {high:.2f}]")
            lines.append("| " + " | ".join(cells) + " |")
    note = (
        f"{args.effects} cohorts per effect and {args.null} without one, {N_SUBJECTS} subjects "
        f"(20 patients), {N_FRAMES} frames, 1,009 vertices; the true frames with a "
        f"tracking-like error ({FIXED_MM} mm per coordinate fixed per subject and vertex, "
        f"{FRAME_MM} mm per frame); {args.permutations:,} permutations per test; the "
        f"trajectory's rule (the fewest components holding 90 % of the variance, at least 2) "
        f"gave d = {int(np.median(ds))} in {int((ds == np.median(ds)).sum())} of {ds.size} "
        f"analyses, the first component alone holding "
        f"{100 * min(e for _, e in components):.0f}-{100 * max(e for _, e in components):.0f} % "
        f"of the variance ({seconds:.0f} s)."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def confounding(args) -> str:
    rng = np.random.default_rng(0)
    covariates = Covariates(imbalance=1.0, age_effect=0.15)
    models = {"unadjusted (group)": "group", "adjusted (group + age + body size)":
              "group + age + body_size"}  # fmt: skip
    effect = EFFECTS["hypokinesia 0.3"]
    start = time.perf_counter()
    hits, power_ = {}, {}
    for label, abnormality, count in (("null", None, args.null), ("effect", effect, args.effects)):
        for r in range(count):
            seed = (3000 if abnormality is None else 4000) + r
            data = make_covariate_cohort(20, (("controls", None), ("patients", abnormality)),
                                         covariates, seed=seed)  # fmt: skip
            cycles = covariate_cycles(data, N_FRAMES)
            motion = noisy_motion(cycles.frames, cycles.names, data.cohort.atlas,
                                  data.cohort.faces, np.random.default_rng([seed, 7]))  # fmt: skip
            responses = cycle_responses(motion)
            table = data.design_table()
            for model, formula in models.items():
                design = design_matrix(table, formula, subjects=list(cycles.names))
                tests = cycle_model(responses, design, CONTRAST, args.permutations, rng)
                for summary in tests.tests():
                    found = tests.detected(summary)
                    if abnormality is None:
                        hits.setdefault((model, summary), []).append(bool(found.any()))
                    else:
                        region = data.regions["patients"].affected
                        power_.setdefault((model, summary), []).append(
                            (detection_power(found, region), dice(found, region))
                        )
            print(f"{label} {r + 1}/{count} ({time.perf_counter() - start:.0f} s)", flush=True)
    seconds = time.perf_counter() - start
    lines = ["| model | test | null FWER [95 % CI] | hypokinesia 0.3: power / Dice |",
             "|---|---|---|---|"]  # fmt: skip
    for (model, summary), h in hits.items():
        low, high = binomial_interval(sum(h), len(h))
        p = np.mean(power_[(model, summary)], axis=0)
        lines.append(f"| {model} | {NAMES[summary]} | {np.mean(h):.2f} [{low:.2f}, {high:.2f}] | "
                     f"{p[0]:.2f} / {p[1]:.2f} |")  # fmt: skip
    note = (
        f"{args.null} cohorts without an effect and {args.effects} with the hypokinesia (30 % "
        f"of the motion), "
        f"20 controls against 20 patients older and larger by two standard deviations (age "
        f"reduces the contraction by 0.15 per standard deviation); the true frames through "
        f"{N_FRAMES} frames with the tracking-like error; {args.permutations:,} Freedman-Lane "
        f"permutations per test, maximum statistic ({seconds:.0f} s)."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("stage", choices=("power", "confounding"))
    parser.add_argument("--quick", action="store_true", help="3 cohorts per effect, 10 null")
    parser.add_argument("--effects", type=int, default=10, help="cohorts per effect")
    parser.add_argument("--null", type=int, default=100, help="cohorts without an effect")
    parser.add_argument("--permutations", type=int, default=1000)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    if args.quick:
        args.effects, args.null = 3, 10
    print(machine(), flush=True)
    table = power(args) if args.stage == "power" else confounding(args)
    print(table)
    if args.publish:
        name = f"cycle_model_{args.stage}"
        publish(name, table, f"python benchmarks/bench_cycle_model.py {args.stage} --publish")


if __name__ == "__main__":
    main()
