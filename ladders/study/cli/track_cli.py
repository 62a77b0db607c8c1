"""``symladders track``: corresponded ED meshes followed through their label series.

A thin wrapper of :func:`~ladders.study.tracking.track_cohort`. Exit status 1 when a
subject failed (the others are written, the reason is in ``tracking.csv`` and on
standard error), 2 on a usage error.
"""

from __future__ import annotations

import argparse
import os
import sys

from .cli_types import (
    DefaultsFormatter,
    UsageError,
    existing_folder,
    jobs_count,
    nonnegative_float,
    nonnegative_int,
    positive_float,
)
from .common_arguments import (
    add_batch_arguments,
    add_cut_planes,
    add_output,
    parallel_backend,
    read_cut_planes,
)

__all__ = ["add_track_parser", "run_track_command"]


def _series_names(images) -> dict:
    """``{name: frame count}`` of every name a cut-plane table may give a series by (its
    subject, its file or folder name, its path); a series that cannot be opened is left
    out (its tracking records why)."""
    from ..tracking.label_series import SeriesError, find_series, open_series

    names = {}
    for subject, source in find_series(images).items():
        if isinstance(source, str):
            continue
        try:
            n = open_series(source, labels=False).n_frames
        except SeriesError:
            continue
        names.update({subject: n, source.name: n, str(source): n})
    return names


def add_track_parser(sub) -> None:
    """Register the ``track`` subcommand on an argparse subparsers object."""
    p = sub.add_parser(
        "track",
        help="follow corresponded ED meshes through their label series (the whole cycle)",
        description=(
            "For every subject, follow its corresponded end-diastolic mesh <subject>_ed.<ext> "
            "(MESHES, the output of 'symladders correspond') through its label series in IMAGES "
            "(<subject>.nii.gz with the frames on the fourth axis, or a folder <subject>/ of 3-D "
            "frames numbered frame_00, frame_01, ...; the first is ED). Every frame is meshed as "
            "'symladders mesh' does and the mesh is moved from frame to frame onto it (affine "
            "fit and normal projection, or an LDDMM registration); every frame is also reached "
            "from ED directly and the two results are combined (less drift; --no-refine-ed: "
            "the chain alone). On thick slices a subject given no valve plane (--cut-planes) "
            "has the plane of every frame estimated from its images (--estimate-planes), "
            "written to OUTPUT/valve_planes.csv. "
            "The ED mesh is first moved along its normals onto ED's surface meshed like the "
            "other frames, so that the motion is measured between surfaces extracted alike. "
            "A cut plane for every frame of a subject (--cut-planes, e.g. the cohort's "
            "valve_planes.csv) also anchors the base's height in the projection's affine fits. "
            "OUTPUT holds <subject>/frame_<kk>.vtk (the atlas's faces), <subject>.json "
            "(provenance and per-frame quality) and tracking.csv. A failing subject is recorded "
            "with its reason and the others finish (exit 1); a rerun skips the subjects done "
            "with the same inputs and settings. With --cine, IMAGES holds cine intensity "
            "series instead and the mesh is moved by B-spline registrations between "
            "consecutive frames (SimpleITK), composed forward and backward through the cycle."
        ),
        formatter_class=DefaultsFormatter,
    )
    p.add_argument("meshes", type=existing_folder, metavar="MESHES",
                   help="folder of corresponded meshes (<subject>_ed.<ext>)")  # fmt: skip
    p.add_argument("images", type=existing_folder, metavar="IMAGES",
                   help="folder of label series (4-D NIfTI or folders of frames)")  # fmt: skip
    p.add_argument("--label", type=nonnegative_int, default=None,
                   help="the structure's label (required for label series)")  # fmt: skip
    p.add_argument("--myocardium-label", type=nonnegative_int, default=None, metavar="INT",
                   help="label series: the myocardium's label; every frame's epicardium (the "
                        "outer surface of --label and this label) is meshed and frame 0's "
                        "followed through them, written to <subject>/epicardium/ for "
                        "'symladders wall' (default: no epicardium)")  # fmt: skip
    p.add_argument("--epicardia", type=existing_folder, default=None, metavar="FOLDER",
                   help="with --cine: a folder of ED epicardia <subject>_ed.<ext> in the images' "
                        "world frame ('symladders mesh --myocardium-label' writes them in "
                        "OUTPUT/epicardium), each moved with its subject's endocardium "
                        "(default: no epicardium)")  # fmt: skip
    p.add_argument("--cine", action="store_true",
                   help="IMAGES are cine intensity series: track by image registration")  # fmt: skip
    p.add_argument("--control-point-spacing", type=positive_float, default=20.0, metavar="MM",
                   help="with --cine: spacing of the B-spline control points (mm)")  # fmt: skip
    p.add_argument("--iterations", type=nonnegative_int, default=30,
                   help="with --cine: optimiser iterations per resolution level")  # fmt: skip
    p.add_argument("--reference", choices=("ed", "consecutive"), default="ed",
                   help="with --cine: register every frame to ED, started from its neighbour's "
                        "fit (ed, default), or consecutive frames composed forward and backward "
                        "(consecutive, as UK Biobank)")  # fmt: skip
    p.add_argument("--mask-distance", type=nonnegative_float, default=None, metavar="MM",
                   help="with --cine and --reference ed: the metric samples the voxels within MM "
                        "of an ED vertex (default: CineTrackingSettings.mask_distance, 4 mm; "
                        "0: the whole image)")  # fmt: skip
    p.add_argument("--image-gradient", choices=("central_difference", "gaussian"),
                   default="central_difference",
                   help="with --cine: the moving image's gradient in the metric's derivative: "
                        "central differences (default) or ITK's Gaussian derivative, whose sigma "
                        "is the largest voxel spacing (the slice thickness of a short-axis stack)")  # fmt: skip
    p.add_argument("--affine-stage", action="store_true",
                   help="with --cine: fit an affine transform before each B-spline, which then "
                        "refines it; recovers the shortening along the long axis that plain "
                        "(untagged) images leave out, above all on isotropic grids (default: "
                        "the B-spline alone)")  # fmt: skip
    p.add_argument("--registration-jobs", type=jobs_count, default=1, metavar="N",
                   help="with --cine: registrations of a subject run N at a time (processes; the "
                        "same result whatever N; with --reference ed, the two halves of the "
                        "cycle: N = 2 at most); with --jobs subjects at a time, use at most "
                        "cores / jobs")  # fmt: skip
    add_output(p, "symladders-output/tracked", "folder of the tracked meshes")
    p.add_argument("--method", choices=("projection", "registration"), default="projection",
                   help="frame to frame: affine fit then normal projection, or LDDMM registration")  # fmt: skip
    p.add_argument("--refine-ed", action=argparse.BooleanOptionalAction, default=True,
                   help="also move ED onto every frame directly and combine (limits the drift; "
                        "--no-refine-ed: the chain alone, about half the time)")  # fmt: skip
    p.add_argument("--keep-ed", action="store_true",
                   help="frame 0 is the ED mesh as given, not moved along its normals onto ED's "
                        "surface meshed like the other frames (the difference between the two "
                        "extractions then enters every frame's motion)")  # fmt: skip
    p.add_argument("--crop-distance", type=positive_float, default=8.0,
                   help="ignore the parts of a frame's surface farther than this (mm) from the "
                        "mesh moved onto it (the lid at the valve plane); must exceed the motion "
                        "between two frames")  # fmt: skip
    p.add_argument("--vertices", type=nonnegative_int, default=2000,
                   help="target vertex count of each frame's surface (0: no decimation)")  # fmt: skip
    p.add_argument("--mask-sigma", type=nonnegative_float, default=1.5, metavar="VOXELS",
                   help="Gaussian smoothing of each frame's label before meshing (voxels of each "
                        "axis); more than 'symladders mesh' uses: on thick slices it lowers the "
                        "noise of the tracked motion")  # fmt: skip
    add_cut_planes(p)
    p.add_argument("--estimate-planes", choices=("auto", "always", "never"), default="always",
                   help="a subject without a plane in --cut-planes gets the valve plane of every "
                        "frame estimated from its images and its ED mesh's rim: always, auto on "
                        "thick slices only (the largest voxel spacing at least twice the "
                        "smallest), or never; written to OUTPUT/valve_planes.csv, which --cut-planes takes "
                        "back")  # fmt: skip
    add_batch_arguments(p)
    p.set_defaults(run=run_track_command, output_is_file=False)


def run_track_command(args) -> int:
    """Track the subjects from parsed arguments."""
    from ..imaging import MeshingSettings
    from ..tracking import CineTrackingSettings, SeriesError, TrackingSettings, track_cohort

    if args.label is None and not args.cine:
        raise UsageError("symladders track: error: --label: required for label series (or --cine)")
    if args.myocardium_label is not None and (args.cine or args.myocardium_label == args.label):
        raise UsageError("symladders track: error: --myocardium-label: for label series, a label "
                         "other than --label (with --cine, give --epicardia)")  # fmt: skip
    if args.epicardia is not None and not args.cine:
        raise UsageError("symladders track: error: --epicardia: with --cine only (label series "
                         "take --myocardium-label)")  # fmt: skip
    planes = args.cut_planes and read_cut_planes(
        args.cut_planes, "track", _series_names(args.images)
    )
    args.on_interrupt = f"the subjects done are kept in {args.output}; rerun the command to resume"
    try:
        if args.cine:
            settings = CineTrackingSettings(
                control_point_spacing=args.control_point_spacing,
                iterations=max(1, args.iterations),
                reference=args.reference,
                mask_distance=CineTrackingSettings.mask_distance
                if args.mask_distance is None
                else args.mask_distance or None,
                image_gradient=args.image_gradient,
                affine_stage=args.affine_stage,
                jobs=(os.cpu_count() or 1)
                if args.registration_jobs == -1
                else args.registration_jobs,
            )
        else:
            meshing = MeshingSettings(n_vertices=args.vertices or None, mask_sigma=args.mask_sigma)
            settings = TrackingSettings(
                method=args.method, refine_ed=args.refine_ed, crop_distance=args.crop_distance,
                project_ed=not args.keep_ed, meshing=meshing, estimate_planes=args.estimate_planes,
            )  # fmt: skip
        label = 0 if args.label is None else args.label
        with parallel_backend(args, "track"):
            outcome = track_cohort(args.meshes, args.images, args.output, label, settings,
                                   cut_planes=planes, jobs=args.jobs,
                                   progress=not args.no_progress,
                                   myocardium_label=args.myocardium_label,
                                   epicardia=args.epicardia)  # fmt: skip
    except (SeriesError, ValueError) as exc:
        raise UsageError(f"symladders track: error: {exc}") from None
    counts = {
        s: sum(r["status"] == s for r in outcome.records) for s in ("ok", "skipped", "failed")
    }
    print(
        f"symladders track: {len(outcome.records)} subject(s): {counts['ok']} tracked, "
        f"{counts['skipped']} already done, {counts['failed']} failed, in {outcome.output} "
        "(tracking.csv)"
    )
    if outcome.planes_file is not None:
        print(f"valve planes estimated from the images: {outcome.planes_file} (the --cut-planes "
              "table: inspect or edit it and pass it back)")  # fmt: skip
    for r in outcome.failed:
        print(f"symladders track: failed: {r['subject']}: {r['error']}", file=sys.stderr)
    return 1 if outcome.failed else 0
