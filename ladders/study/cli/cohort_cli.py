"""``symladders cohort``: the synthetic cohort in two groups with a planted abnormality, to a folder.

A thin wrapper of :func:`~ladders.study.population.make_two_group_cohort` and
:func:`~ladders.study.population.write_two_group_cohort`: the meshes in the layout
``symladders study --meshes`` reads, ``groups.csv`` (subject, group) and
``planted_region.json`` (the abnormality and its affected atlas vertices) next to
them.
"""

from __future__ import annotations

import argparse

from .cli_types import DefaultsFormatter, UsageError, nonnegative_int, output_folder, positive_int

__all__ = ["add_cohort_parser", "run_cohort_command"]


def _fraction(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a fraction in [0, 1], got {text!r}") from None
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"expected a fraction in [0, 1], got {text!r}")
    return value


def _nonnegative(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}") from None
    if not value >= 0.0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text!r}")
    return value


def _segments(text: str) -> tuple[int, ...]:
    try:
        values = tuple(int(t) for t in text.split(",") if t.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected AHA segment numbers 1..17 separated by commas, got {text!r}"
        ) from None
    if not values or any(not 1 <= v <= 17 for v in values):
        raise argparse.ArgumentTypeError(
            f"expected AHA segment numbers 1..17 separated by commas, got {text!r}"
        )
    return values


def add_cohort_parser(sub) -> None:
    """Register the ``cohort`` subcommand on an argparse subparsers object."""
    from ..cohort.planted_effect import DEFAULT_MAGNITUDE, EFFECT_KINDS

    p = sub.add_parser(
        "cohort",
        help="write the synthetic cohort in two groups with a planted motion abnormality",
        description=(
            "Write the built-in synthetic left-ventricle cohort as meshes, its subjects split "
            "into patients and controls, with a regional motion abnormality planted in the "
            "patients' end-systolic shapes: OUTPUT holds atlas.<ext>, <name>_ed.<ext>, "
            "<name>_es.<ext>, groups.csv and planted_region.json (the truth for 'symladders "
            "analyze --truth'). Kinds: "
            + "; ".join(f"{k}: {v}" for k, v in EFFECT_KINDS.items())
            + ". Realism knobs, all off by default: --noise, --remesh, --pose."
        ),
        formatter_class=DefaultsFormatter,
    )
    p.add_argument("--output", "-o", type=output_folder, default="symladders-output/cohort",
                   help="folder to write")  # fmt: skip
    p.add_argument("--subjects", type=positive_int, default=40, help="number of subjects")
    p.add_argument("--patients", type=_fraction, default=0.5,
                   help="fraction of the subjects in the patients' group")  # fmt: skip
    p.add_argument("--effect", choices=(*EFFECT_KINDS, "none"), default="hypokinesia",
                   help="kind of abnormality ('none': both groups from one distribution)")  # fmt: skip
    p.add_argument("--segments", type=_segments, default=(7, 8, 13, 14),
                   help="AHA segments affected, e.g. 7,8,13,14")  # fmt: skip
    p.add_argument(
        "--magnitude",
        type=_nonnegative,
        default=None,
        help="size of the abnormality: the fraction of the motion removed (0-1) for "
        "hypokinesia/radial/longitudinal, degrees of rotation for twist (default "
        + ", ".join(f"{k} {v:g}" for k, v in DEFAULT_MAGNITUDE.items())
        + ")",
    )
    p.add_argument("--noise", type=_nonnegative, default=0.0,
                   help="segmentation noise: RMS of a smooth normal displacement of every "
                        "ED and ES mesh, in mm")  # fmt: skip
    p.add_argument("--noise-length", type=_nonnegative, default=10.0,
                   help="correlation length of that noise, in mm")  # fmt: skip
    p.add_argument("--remesh", type=_nonnegative, default=None, metavar="FACTOR",
                   help="give every subject mesh another triangulation with FACTOR times the "
                        "atlas's faces (the meshes then need 'symladders correspond')")  # fmt: skip
    p.add_argument("--pose", action="store_true",
                   help="move each subject by a random rigid motion (up to 30 degrees, 20 mm)")  # fmt: skip
    p.add_argument("--landmarks", action="store_true",
                   help="also write landmarks.csv: apex, base-plane centre and septal point of "
                        "the atlas and of every subject (posed with it), for 'symladders "
                        "correspond' and 'symladders atlas'")  # fmt: skip
    p.add_argument("--vertices", type=positive_int, default=1009, help="vertices per mesh")
    p.add_argument("--seed", type=nonnegative_int, default=0, help="seed of every draw")
    p.add_argument("--ext", choices=("vtk", "vtu", "ply", "obj", "off", "stl"), default="vtk",
                   help="mesh format")  # fmt: skip
    p.set_defaults(run=run_cohort_command, output_is_file=False)


def run_cohort_command(args) -> int:
    """Write the two-group cohort from parsed arguments."""
    from pathlib import Path

    from ..cohort.planted_effect import MotionAbnormality
    from ..errors import CohortError
    from ..population import make_two_group_cohort, write_two_group_cohort

    try:
        abnormality = (
            None
            if args.effect == "none"
            else MotionAbnormality(args.effect, args.segments, args.magnitude)
        )
    except CohortError as exc:
        raise UsageError(f"symladders cohort: error: {exc}") from None
    data = make_two_group_cohort(
        args.subjects, args.patients, abnormality, args.vertices, args.seed, args.noise,
        args.noise_length,
    )  # fmt: skip
    folder = write_two_group_cohort(
        data,
        Path(args.output),
        ext=args.ext,
        remesh_factor=args.remesh or None,
        pose=args.pose,
        landmarks=args.landmarks,
    )
    n_patients = int(data.labels.sum())
    print(
        f"symladders cohort: {len(data.cohort)} subjects ({n_patients} patients, "
        f"{len(data.cohort) - n_patients} controls), {data.cohort.n_vertices} vertices, in {folder}"
    )
    if data.region is not None:
        print(
            f"planted: {abnormality.describe()}; {int(data.region.affected.sum())} of "
            f"{data.region.weight.size} atlas vertices affected"
        )
    print(f"groups: {folder / 'groups.csv'}; truth: {folder / 'planted_region.json'}")
    return 0
