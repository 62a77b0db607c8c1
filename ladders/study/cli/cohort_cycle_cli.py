"""``symladders cohort --cycle N``: the cohort through the whole cycle, as images.

A thin wrapper of :func:`~ladders.study.population.make_two_group_cycles` (or, with
several groups and covariates, :func:`~ladders.study.population.covariate_cycles` of the
cohort of :mod:`.covariate_arguments`) and :func:`~ladders.study.population.write_cycle_cohort`:
besides the ED/ES meshes, ``groups.csv``, ``planted_region.json`` (and ``design.csv``)
of ``symladders cohort``, every subject's 4-D label (or cine) series in ``images/`` and
its true frames in ``frames/``. With
``--landmarks``, ``landmarks.csv`` too: every subject's apex, base-plane centre and septal
point at ED (the cohort is not posed: the coordinates of its meshes and of its images'
world frame), for ``symladders correspond --landmarks``.
"""

from __future__ import annotations

import argparse

from .cli_types import UsageError
from .covariate_arguments import covariate_data, print_covariate_cohort, several_groups

__all__ = ["add_cycle_arguments", "run_cycle_cohort"]

#: Options of the ED/ES cohort that the whole-cycle cohort does not take.
_EXCLUSIVE = ("noise", "remesh", "pose")
#: The ring transitions of the cycle's abnormalities (half-width, fraction of the long axis):
#: wide enough for every subject's motion to stay invertible (:data:`CYCLE_ABNORMALITY`).
_TRANSITION = 0.1
#: Defaults of options of the ED-ES cohort (its parser's), refused with --cycle when changed.
ED_ES_DEFAULTS = {"noise_length": 10.0, "ext": "vtk"}


def _voxel(text: str) -> tuple[float, float]:
    try:
        in_plane, thickness = (float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected IN_PLANE,THICKNESS in mm (e.g. 1.5,8), got {text!r}"
        ) from None
    if not (0 < in_plane < 100 and 0 < thickness < 100):
        raise argparse.ArgumentTypeError(f"expected voxel sizes in (0, 100) mm, got {text!r}")
    return in_plane, thickness


def _frames(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a number of frames >= 3, got {text!r}"
        ) from None
    if n < 3:
        raise argparse.ArgumentTypeError(f"expected a number of frames >= 3, got {text!r}")
    return n


def add_cycle_arguments(p) -> None:
    """The ``--cycle`` group of ``symladders cohort``."""
    g = p.add_argument_group(
        "the whole cycle",
        "with --cycle, also every subject's 4-D series in images/ (frame 0 at ED) and its "
        "true frames in frames/<subject>/frame_<kk>.vtk; the planted abnormality acts "
        "through the whole cycle; --landmarks writes every subject's ED landmarks (no pose: "
        "the meshes' and the images' world coordinates)",
    )
    g.add_argument("--cycle", type=_frames, default=None, metavar="FRAMES",
                   help="frames per cycle (e.g. 25; ES at 35 %% of the cycle)")  # fmt: skip
    g.add_argument("--images", choices=("labels", "cine", "none"), default=None,
                   help="label images (1 blood pool, 2 myocardium, 3 right ventricle), with "
                        "subjects.csv and study.toml for 'symladders run'; with --cycle, label "
                        "series (the default) or cine intensities (default: labels with --cycle, "
                        "none without: meshes only)")  # fmt: skip
    g.add_argument("--voxel", type=_voxel, default=None, metavar="IN_PLANE,THICKNESS",
                   help="voxel size of the images, mm (default: 1.5,8, short-axis stacks, with "
                        "--cycle; 1.5,1.5 without)")  # fmt: skip
    g.add_argument("--tagging", nargs="?", const="2d", choices=("2d", "3d"), default=None,
                   help="with --images cine: tagging lines 7 mm apart, moving with the wall: "
                        "planes along the long axis (2d, the default) or, with 3d, also "
                        "across it (seen with a through-plane voxel finer than 7 mm)")  # fmt: skip


def _tag_grid(kind: str | None):
    """The :class:`~ladders.study.imaging.TagGrid` of ``--tagging [2d|3d]`` (None without)."""
    from ..imaging.cine import TagGrid

    return None if kind is None else TagGrid(axes=(0, 1, 2) if kind == "3d" else (0, 1))


def run_cycle_cohort(args, abnormality) -> int:
    """Write the whole-cycle cohort from parsed arguments."""
    from dataclasses import replace
    from pathlib import Path

    from ..errors import CohortError
    from ..population import covariate_cycles, make_two_group_cycles, write_cycle_cohort

    given = [o for o in _EXCLUSIVE if getattr(args, o, None) not in (None, False, 0.0)]
    given += [o for o, default in ED_ES_DEFAULTS.items() if getattr(args, o, default) != default]
    if given:
        raise UsageError(f"symladders cohort: error: --{given[0].replace('_', '-')}: not with "
                         "--cycle")  # fmt: skip
    args.images = args.images or "labels"
    args.voxel = args.voxel or (1.5, 8.0)
    if args.tagging and args.images != "cine":
        raise UsageError("symladders cohort: error: --tagging: only with --images cine")
    if abnormality is not None:  # transitions wide enough for the motion to stay invertible
        abnormality = replace(abnormality, transition_height=_TRANSITION)
    data, groups = None, None
    if several_groups(args):
        data, groups = covariate_data(args, abnormality, transition_height=_TRANSITION)
    try:
        if data is None:
            cycles = make_two_group_cycles(args.subjects, abnormality, args.cycle, 0.35,
                                           args.vertices, args.seed, args.patients)  # fmt: skip
        else:
            cycles = covariate_cycles(data, args.cycle, 0.35)
        folder = write_cycle_cohort(cycles, Path(args.output), args.images, *args.voxel,
                                    tagging=_tag_grid(args.tagging),
                                    landmarks=args.landmarks,
                                    progress=not args.no_progress)  # fmt: skip
    except CohortError as exc:
        raise UsageError(f"symladders cohort: error: {exc}") from None
    size = f"through {args.cycle} frames, {cycles.frames.shape[2]} vertices"
    if data is not None:
        print_covariate_cohort(data, groups, folder, size)
    else:
        n_patients = int(cycles.patients.sum())
        print(f"symladders cohort: {len(cycles.names)} subjects ({n_patients} patients, "
              f"{len(cycles.names) - n_patients} controls) {size}, in {folder}")  # fmt: skip
    if data is None and abnormality is not None:
        region = cycles.data.region
        print(f"planted: {abnormality.describe()}; {int(region.affected.sum())} of "
              f"{region.weight.size} atlas vertices affected")  # fmt: skip
    what = "no images" if args.images == "none" else f"{args.images}: {folder / 'images'}"
    if args.landmarks:
        what += f"; landmarks: {folder / 'landmarks.csv'}"
    what += f"; valve planes: {folder / 'valve_planes.csv'}"
    what += "" if data is None else f"; design: {folder / 'design.csv'}"
    print(f"{what}; true frames: {folder / 'frames'}; groups: {folder / 'groups.csv'}; "
          f"truth: {folder / 'planted_region.json'}, {folder / 'cycle.json'}")  # fmt: skip
    return 0
