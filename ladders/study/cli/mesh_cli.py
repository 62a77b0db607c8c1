"""``symladders mesh``: label images (NIfTI) to a folder of meshes the study reads.

A thin wrapper of :func:`~ladders.study.imaging.mesh_label_images`. Exit status 1
when an image failed (the others are written, the reason is in ``meshing.csv``),
2 on a usage error.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .cli_types import DefaultsFormatter, UsageError, nonnegative_float, nonnegative_int
from .common_arguments import (
    MESH_FORMATS,
    add_batch_arguments,
    add_cut_planes,
    add_output,
    parallel_backend,
    read_cut_planes,
    table_usage_error,
)

__all__ = ["add_mesh_parser", "run_mesh_command"]


def _frames(text: str) -> tuple[int, int] | Path:
    """``ED,ES`` (two frame indices, 0-based) or the path of a frames table."""
    parts = [t.strip() for t in str(text).split(",")]
    if len(parts) == 2 and all(p.lstrip("-").isdigit() for p in parts):
        values = tuple(int(p) for p in parts)
        if min(values) < 0:
            raise argparse.ArgumentTypeError(
                f"expected the end-diastole and end-systole frames as ED,ES (0-based), got {text!r}"
            )
        return values
    if "," in str(text) or not str(text).strip():
        raise argparse.ArgumentTypeError(
            f"expected ED,ES (two 0-based frames) or a frames table (CSV), got {text!r}"
        )
    return Path(text)


def _plane(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(t) for t in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 6:
        raise argparse.ArgumentTypeError(
            f"expected a point and a normal as x,y,z,nx,ny,nz (mm), got {text!r}"
        )
    return values


def _lid_angle(text: str) -> float | None:
    if text.strip().lower() == "none":
        return None
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected degrees in [0, 90) or 'none', got {text!r}"
        ) from None
    if not 0 <= value < 90:
        raise argparse.ArgumentTypeError(f"expected degrees in [0, 90) or 'none', got {text!r}")
    return value


def _image_names(images) -> dict:
    """``{name: frame count}`` of every name a cut-plane table may give an image by (its
    file name, its path; None for a 3-D image)."""
    from ..imaging.label_images import image_stem
    from ..imaging.plane_table import image_names
    from ..imaging.series_frames import series_frame_counts

    counts = series_frame_counts(images)
    return {name: counts.get(image_stem(p)) for p in images for name in image_names(p)}


def _frames_table(path: Path, images) -> dict:
    """``{subject: (ed, es)}`` of ``--frames TABLE``, or a usage error naming the line."""
    from ladders.tables import TableError

    from ..imaging.series_frames import read_frames_table

    try:
        return read_frames_table(path, images)
    except TableError as exc:
        raise table_usage_error("mesh", "--frames", exc) from None


def add_mesh_parser(sub) -> None:
    """Register the ``mesh`` subcommand on an argparse subparsers object."""
    p = sub.add_parser(
        "mesh",
        help="turn label images (NIfTI) into surface meshes in world millimetres",
        description=(
            "Extract the surface of one label of every image (NIfTI .nii/.nii.gz, 3-D per "
            "frame as <subject>_ed / <subject>_es, or 4-D series <subject>, see --frames) in the "
            "image's world frame (its affine: orientation, spacing, flips), keep the largest "
            "connected component, smooth (Gaussian mask, Taubin) and decimate. OUTPUT holds "
            "<subject>_ed.<ext>, <subject>_es.<ext> with a provenance record each (.json), "
            "read by 'symladders correspond' (and then 'symladders study'), and meshing.csv. "
            "A failing image is recorded with its reason and the others finish (exit 1); a "
            "rerun skips the meshes already made from the same bytes and settings. With "
            "--rv-label, the apex, base-plane centre and septal point of every mesh are found "
            "(the septum faces the right ventricle) and OUTPUT gets landmarks.csv (one row "
            "per subject, from its ED mesh), which 'symladders correspond' and 'symladders atlas' "
            "read."
        ),
        formatter_class=DefaultsFormatter,
    )
    p.add_argument("images", nargs="+", type=Path, metavar="IMAGES", help="label images")
    p.add_argument("--label", type=nonnegative_int, required=True, help="the structure's label")
    p.add_argument("--frames", type=_frames, default=None, metavar="ED,ES|TABLE",
                   help="the end-diastole and end-systole frames of the 4-D series (0-based): ED,ES "
                        "for every series, or a CSV table with the columns subject,ed,es, one row "
                        "per series (subject: the file name without .nii.gz); a series without "
                        "them is meshed at ED = frame 0 and ES = its frame of least cavity volume "
                        "(--label's voxels), recorded in meshing.csv and the meshes' records")  # fmt: skip
    add_output(p, "symladders-output/meshes", "folder of the meshes")
    p.add_argument("--vertices", type=nonnegative_int, default=2000,
                   help="target vertex count of each mesh (0: no decimation)")  # fmt: skip
    p.add_argument("--mask-sigma", type=nonnegative_float, default=0.5, metavar="VOXELS",
                   help="Gaussian smoothing of the mask before marching cubes, in voxels")  # fmt: skip
    p.add_argument("--taubin-iterations", type=nonnegative_int, default=20,
                   help="iterations of Taubin (volume-preserving) smoothing of the surface")  # fmt: skip
    p.add_argument("--cut-plane", type=_plane, default=None, metavar="X,Y,Z,NX,NY,NZ",
                   help="remove the surface beyond this plane (mm), e.g. the valve plane")  # fmt: skip
    add_cut_planes(p)
    p.add_argument("--cut-margin", type=nonnegative_float, default=0.5,
                   help="move the cut plane this many voxel widths against its normal, so that "
                        "the lid a label makes at the valve plane goes (0: cut at the plane)")  # fmt: skip
    p.add_argument("--lid-angle", type=_lid_angle, default=None, metavar="DEG",
                   help="also remove the faces within one voxel width below the plane whose "
                        "normal is within DEG degrees of the plane's normal (the lid), e.g. "
                        "--cut-margin 0 --lid-angle 45 (default: none)")  # fmt: skip
    p.add_argument("--rv-label", type=nonnegative_int, default=None, metavar="INT",
                   help="the right ventricle's label: find each mesh's apex, base-plane centre "
                        "and septal point and write landmarks.csv (default: no landmarks)")  # fmt: skip
    p.add_argument("--myocardium-label", type=nonnegative_int, default=None, metavar="INT",
                   help="the myocardium's label: also write each image's epicardium (the outer "
                        "surface of --label and this label, the same settings and cut) as "
                        "OUTPUT/epicardium/<mesh>, which 'symladders track --cine --epicardia' "
                        "follows (default: no epicardium)")  # fmt: skip
    p.add_argument("--rv-septum", choices=("insertion", "centroid"), default="insertion",
                   help="with --rv-label, the septal direction: half way between the RV's "
                        "insertion points (its angular edges about the long axis, as the AHA "
                        "segments are bounded) or towards the RV's centroid")  # fmt: skip
    p.add_argument("--ext", choices=MESH_FORMATS, default="vtk", help="format of the meshes")
    add_batch_arguments(p)
    p.set_defaults(run=run_mesh_command, output_is_file=False)


def run_mesh_command(args) -> int:
    """Mesh the images from parsed arguments."""
    from ..imaging import ImageError, MeshingSettings, mesh_label_images

    missing = [p for p in args.images if not p.is_file()]
    if missing:
        raise UsageError(f"symladders mesh: error: no such file: {missing[0]}")
    if args.rv_label is not None and args.rv_label == args.label:
        raise UsageError(
            f"symladders mesh: error: --rv-label {args.rv_label}: the right ventricle's label "
            "must differ from --label (the left ventricle's)"
        )
    planes = None
    if args.cut_planes is not None:
        planes = read_cut_planes(args.cut_planes, "mesh", _image_names(args.images))
    frames = args.frames
    if isinstance(frames, Path):
        frames = _frames_table(frames, args.images)
    try:
        settings = MeshingSettings(
            mask_sigma=args.mask_sigma, taubin_iterations=args.taubin_iterations,
            n_vertices=args.vertices or None, cut_plane=args.cut_plane,
            cut_margin=args.cut_margin, lid_angle=args.lid_angle,
        )  # fmt: skip
        with parallel_backend(args, "mesh"):
            outcome = mesh_label_images(
                args.images, args.label, args.output, frames, settings, jobs=args.jobs,
                progress=not args.no_progress, ext=args.ext, cut_planes=planes,
                rv_label=args.rv_label, rv_septum=args.rv_septum,
                myocardium_label=args.myocardium_label,
            )  # fmt: skip
    except (ImageError, ValueError) as exc:
        raise UsageError(f"symladders mesh: error: {exc}") from None
    done = [r for r in outcome.records if r["status"] == "ok"]
    skipped = [r for r in outcome.records if r["status"] == "skipped"]
    print(
        f"symladders mesh: {len(done)} mesh(es) written, {len(skipped)} already done, "
        f"{len(outcome.failed)} failed, in {outcome.folder} (meshing.csv)"
    )
    for r in done:
        print(f"  {r['mesh']}: {r['report']}")
    if outcome.landmarks_file is not None:
        from ..preparation.landmarks import read_landmarks

        table = read_landmarks(outcome.landmarks_file)
        print(
            f"symladders mesh: landmarks of {len(table)} subject(s) (apex, base, septum, from "
            f"the ED meshes) in {outcome.landmarks_file}"
        )
    for r in outcome.failed:
        print(f"symladders mesh: failed: {r['error']}", file=sys.stderr)
    return 1 if outcome.failed else 0
