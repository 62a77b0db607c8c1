"""``symladders cohort``: the synthetic cohort in groups with planted effects, to a folder.

A thin wrapper of :func:`~ladders.study.population.make_two_group_cohort` and
:func:`~ladders.study.population.write_two_group_cohort`: the meshes in the layout
``symladders study --meshes`` reads, ``groups.csv`` (subject, group) and
``planted_region.json`` (the abnormality and its affected atlas vertices) next to
them. With ``--group`` (any number of groups, each with its own abnormality),
``--anatomy`` (a group's anatomy changed, its motion relative to it kept) or a covariate
option (``--imbalance``, ``--age-effect``, ``--sex-effect``, ``--body-size-sd``,
``--design``), it wraps :func:`~ladders.study.population.make_covariate_cohort` and
:func:`~ladders.study.population.write_covariate_cohort` instead, which also write
``design.csv`` (subject, group, age, sex, body_size) for ``symladders analyze --design``.
With ``--cycle N`` it writes the cohort through the whole cycle instead, with every
subject's 4-D label or cine series (:mod:`.cohort_cycle_cli`).
"""

from __future__ import annotations

import argparse

from .cli_types import DefaultsFormatter, UsageError, positive_int
from .cohort_cycle_cli import ED_ES_DEFAULTS, add_cycle_arguments, run_cycle_cohort
from .common_arguments import MESH_FORMATS, add_no_progress, add_output, add_seed
from .covariate_arguments import covariate_data, print_covariate_cohort, several_groups

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


def _group(text: str) -> tuple:
    """``NAME`` or ``NAME=KIND[@SEGMENTS[@MAGNITUDE]]`` -> (name, kind or None, segments, magnitude)."""
    from ..cohort.planted_effect import EFFECT_KINDS

    name, _, effect = text.partition("=")
    if not name.strip() or "," in name or name != name.strip():
        raise argparse.ArgumentTypeError(
            f"expected NAME[=KIND[@SEGMENTS[@MAGNITUDE]]], got {text!r}"
        )
    if not effect:
        return name, None, None, None
    parts = effect.split("@")
    if parts[0] not in EFFECT_KINDS or len(parts) > 3:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected NAME=KIND[@SEGMENTS[@MAGNITUDE]] with KIND one of "
            f"{', '.join(EFFECT_KINDS)}"
        )
    segments = _segments(parts[1]) if len(parts) > 1 else None
    magnitude = _nonnegative(parts[2]) if len(parts) > 2 else None
    return name, parts[0], segments, magnitude


_ANATOMY_KEYS = ("scale", "sphericity", "bulge")


def _anatomy(text: str) -> tuple:
    """``NAME=key:value,...`` with keys scale, sphericity, bulge -> (name, {key: value})."""
    name, _, spec = text.partition("=")
    fields = {}
    try:
        for item in spec.split(","):
            key, _, value = item.partition(":")
            if key.strip() not in _ANATOMY_KEYS:
                raise ValueError
            fields[key.strip()] = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected NAME=KEY:VALUE[,KEY:VALUE...] with keys {', '.join(_ANATOMY_KEYS)}, "
            f"got {text!r}"
        ) from None
    if not name.strip():
        raise argparse.ArgumentTypeError(f"expected a group NAME before '=', got {text!r}")
    return name.strip(), fields


def add_cohort_parser(sub) -> None:
    """Register the ``cohort`` subcommand on an argparse subparsers object."""
    from ..cohort.planted_effect import DEFAULT_MAGNITUDE, EFFECT_KINDS

    p = sub.add_parser(
        "cohort",
        help="write the synthetic cohort in groups with planted motion abnormalities",
        description=(
            "Write the built-in synthetic left-ventricle cohort as meshes, its subjects split "
            "into patients and controls, with a regional motion abnormality planted in the "
            "patients' end-systolic shapes: OUTPUT holds atlas.<ext>, <name>_ed.<ext>, "
            "<name>_es.<ext>, groups.csv and planted_region.json (the truth for 'symladders "
            "analyze --truth'). Kinds: "
            + "; ".join(f"{k}: {v}" for k, v in EFFECT_KINDS.items())
            + ". Realism knobs, all off by default: --noise, --remesh, --pose. Several groups, "
            "anatomy shifts and covariates (age, sex, body size acting on the shapes): --group, "
            "--anatomy, --imbalance, ...; they also write design.csv."
        ),
        formatter_class=DefaultsFormatter,
    )
    add_output(p, "symladders-output/cohort", "folder to write")
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
        "hypokinesia/radial/longitudinal, degrees of rotation for twist, the delay of the "
        "end-systole as a fraction of the cycle for delay (default "
        + ", ".join(f"{k} {v:g}" for k, v in DEFAULT_MAGNITUDE.items())
        + ")",
    )
    p.add_argument("--noise", type=_nonnegative, default=0.0,
                   help="segmentation noise: RMS of a smooth normal displacement of every "
                        "ED and ES mesh, in mm")  # fmt: skip
    p.add_argument("--noise-length", type=_nonnegative, default=ED_ES_DEFAULTS["noise_length"],
                   help="correlation length of that noise, in mm")  # fmt: skip
    p.add_argument("--remesh", type=_nonnegative, default=None, metavar="FACTOR",
                   help="give every subject mesh another triangulation with FACTOR times the "
                        "atlas's faces (the meshes then need 'symladders correspond')")  # fmt: skip
    p.add_argument("--pose", action="store_true",
                   help="move each subject by a random rigid motion (up to 30 degrees, 20 mm)")  # fmt: skip
    p.add_argument("--landmarks", action="store_true",
                   help="also write landmarks.csv: apex, base-plane centre and septal point of "
                        "the atlas and of every subject's ED (posed with it; with --cycle, in "
                        "the coordinates of the ED mesh and of the images), for 'symladders "
                        "correspond --landmarks' and 'symladders atlas'")  # fmt: skip
    g = p.add_argument_group(
        "several groups, anatomy and covariates",
        "any of these writes design.csv too; the subjects are split evenly between the groups",
    )
    g.add_argument("--group", type=_group, action="append", default=None,
                   metavar="NAME[=KIND[@SEGMENTS[@MAGNITUDE]]]",
                   help="a group and its abnormality, repeated once per group in order (the "
                        "first is the reference), e.g. --group controls --group "
                        "lad=hypokinesia@7,8,13,14 --group rca=radial@3,4,9,10@0.6 "
                        "(default: controls and patients with --effect)")  # fmt: skip
    g.add_argument("--anatomy", type=_anatomy, action="append", default=None,
                   metavar="NAME=KEY:VALUE,...",
                   help="change a group's end-diastolic anatomy, its motion relative to it "
                        "kept: scale (every length), sphericity (the base radius), bulge "
                        "(added), e.g. --anatomy patients=scale:1.15,sphericity:1.1")  # fmt: skip
    g.add_argument("--imbalance", type=_fraction, default=None,
                   help="how much the other groups' age, body size and sex differ from the "
                        "first group's (0-1; 1: two SD of age and body size; default 0)")  # fmt: skip
    g.add_argument("--age-effect", type=_nonnegative, default=None,
                   help="relative reduction of the contraction per SD of age (default 0.1)")  # fmt: skip
    g.add_argument("--sex-effect", type=float, default=None,
                   help="relative reduction of the males' contraction (default 0)")  # fmt: skip
    g.add_argument("--body-size-sd", type=_nonnegative, default=None,
                   help="SD of the body size, a length factor of mean 1 (default 0.08)")  # fmt: skip
    g.add_argument("--outcome-effect", type=_nonnegative, default=None, metavar="BETA",
                   help="also a survival outcome (design.csv columns time and event, 30 %% "
                        "censored): log hazard ratio BETA per SD of each subject's normal "
                        "motion ED-ES over the planted region (a weaker contraction, a higher "
                        "hazard); default: none")  # fmt: skip
    g.add_argument("--design", action="store_true",
                   help="write design.csv with the default covariates even without the options above")  # fmt: skip
    p.add_argument("--vertices", type=positive_int, default=1009, help="vertices per mesh")
    add_seed(p)
    add_no_progress(p)
    p.add_argument("--ext", choices=MESH_FORMATS,
                   default=ED_ES_DEFAULTS["ext"],
                   help="mesh format")  # fmt: skip
    add_cycle_arguments(p)
    p.set_defaults(run=run_cohort_command, output_is_file=False)


def _check_image_options(args) -> None:
    """``--images labels`` without ``--cycle``: the options that only shape meshes are refused."""
    for flag, value in (("--remesh", args.remesh), ("--pose", args.pose),
                        ("--landmarks", args.landmarks)):  # fmt: skip
        if value:
            raise UsageError(f"symladders cohort: error: {flag}: not with --images labels (the "
                             "images are meshed by 'symladders run'; the landmarks come from the "
                             "right ventricle's label)")  # fmt: skip


def _write_images(data, args):
    """The cohort as label images with subjects.csv and study.toml (``--images labels``)."""
    from pathlib import Path

    from ..population.image_cohort import write_image_cohort

    voxel = args.voxel or (1.5, 1.5)
    return write_image_cohort(data, Path(args.output), spacing=voxel[0], thickness=voxel[1])


def _print_images(folder) -> None:
    print(f"label images: {folder / 'images'} (1 blood pool, 3 right ventricle); subjects: "
          f"{folder / 'subjects.csv'}; settings: {folder / 'study.toml'}; truth: "
          f"{folder / 'planted_region.json'}")  # fmt: skip
    print(f"next: symladders run {folder / 'study.toml'}")


def run_cohort_command(args) -> int:
    """Write the two-group cohort (or the cohort in several groups) from parsed arguments."""
    from pathlib import Path

    from ..cohort.planted_effect import MotionAbnormality
    from ..errors import CohortError
    from ..population import make_two_group_cohort, write_covariate_cohort, write_two_group_cohort

    try:
        abnormality = (
            None
            if args.effect == "none"
            else MotionAbnormality(args.effect, args.segments, args.magnitude)
        )
    except CohortError as exc:
        raise UsageError(f"symladders cohort: error: {exc}") from None
    if args.cycle is not None:
        return run_cycle_cohort(args, abnormality)
    if args.images == "cine" or args.tagging:
        raise UsageError("symladders cohort: error: --images cine and --tagging: only with --cycle")
    if args.images == "labels":
        _check_image_options(args)
    if several_groups(args):
        data, groups = covariate_data(args, abnormality)
        if args.images == "labels":
            folder = _write_images(data, args)
        else:
            folder = write_covariate_cohort(
                data, Path(args.output), ext=args.ext, remesh_factor=args.remesh or None,
                pose=args.pose, landmarks=args.landmarks,
            )  # fmt: skip
        print_covariate_cohort(data, groups, folder, f"{data.cohort.n_vertices} vertices")
        if args.images == "labels":
            _print_images(folder)
        else:
            print(f"groups: {folder / 'groups.csv'}; design: {folder / 'design.csv'}; "
                  f"truth: {folder / 'planted_region.json'}")  # fmt: skip
        return 0
    data = make_two_group_cohort(
        args.subjects, args.patients, abnormality, args.vertices, args.seed, args.noise,
        args.noise_length,
    )  # fmt: skip
    if args.images == "labels":
        folder = _write_images(data, args)
        print(f"symladders cohort: {len(data.cohort)} subjects ({int(data.labels.sum())} "
              f"patients) as label images, in {folder}")  # fmt: skip
        _print_images(folder)
        return 0
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
