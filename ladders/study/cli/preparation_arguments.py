"""Flags shared by ``symladders correspond``, ``atlas`` and ``study``: units, the data term, files.

The defaults of the data term's flags are the library's
(:class:`~ladders.study.preparation.CorrespondenceSettings`); a units
disagreement found by :func:`~ladders.study.preparation.check_units_and_pose`
becomes a one-line usage error naming ``--meshes`` and the flags that resolve it.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .cli_types import UsageError, checks_files, positive_float

__all__ = [
    "UNIT_CHOICES",
    "add_units_arguments",
    "add_data_term_arguments",
    "correspondence_settings",
    "units_usage_error",
    "mesh_file",
    "mesh_output_file",
    "data_term_weight",
    "print_line",
]

#: The values of ``--units``: ``auto`` (detected per subject) or a length unit.
UNIT_CHOICES = ("auto", "mm", "cm", "m", "um")


def add_units_arguments(p, reference: str, pose: str | None = None, note: str = "") -> None:
    """Add ``--units``, ``--allow-scale`` and (with its help text ``pose``) ``--allow-pose``.

    ``reference`` names what the sizes are compared with (e.g. ``"the atlas's (taken to
    be in mm)"``); ``note`` ends the help of ``--units``.
    """
    p.add_argument(
        "--units",
        choices=UNIT_CHOICES,
        default=None,
        help="unit of the subjects' meshes, converted to mm; 'auto': each subject's unit "
        f"detected from its size. Without it every size must agree with {reference}, and "
        f"a mesh that does not (e.g. in metres) stops the command, named with its likely "
        f"unit{note}",
    )
    p.add_argument(
        "--allow-scale",
        action="store_true",
        help=f"accept meshes whose size disagrees with {reference}, as they are",
    )
    if pose is not None:
        p.add_argument("--allow-pose", action="store_true", help=pose)


def data_term_weight(text: str) -> float | str:
    """``landmarks`` or a finite positive number."""
    if str(text).strip() == "landmarks":
        return "landmarks"
    try:
        return positive_float(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(
            f"expected 'landmarks' or a positive number, got {text!r}"
        ) from None


def add_data_term_arguments(p) -> None:
    """Add ``--sigma-w`` and ``--weight``, the surface data term's, with the library's defaults."""
    from ..preparation import CorrespondenceSettings

    d = CorrespondenceSettings()
    p.add_argument(
        "--sigma-w",
        type=positive_float,
        default=d.sigma_w,
        help="width of the surface data term's kernel (mesh units, mm): a few mean edge "
        "lengths, below the features to match (docs/preparation.md)",
    )
    p.add_argument(
        "--weight",
        type=data_term_weight,
        default=d.weight,
        help="weight of the surface data term: a number, or 'landmarks' (chosen so that "
        "alpha^2 means what it means for meshes in correspondence)",
    )


def correspondence_settings(args, **changes):
    """The library's :class:`CorrespondenceSettings` with the flags' data term and ``changes``."""
    from ..preparation import CorrespondenceSettings

    return CorrespondenceSettings().replace(sigma_w=args.sigma_w, weight=args.weight, **changes)


def units_usage_error(command: str, exc, flag: str = "--meshes") -> UsageError:
    """A :class:`~ladders.study.preparation.UnitsError` as the command's one-line usage error,
    naming the input flag ``flag``."""
    return UsageError(f"symladders {command}: error: {flag}: {exc.for_command_line()}")


def _mesh_extensions(writable: bool) -> tuple[str, ...]:
    from ..meshes import MESH_EXTENSIONS, WRITE_EXTENSIONS

    return WRITE_EXTENSIONS if writable else MESH_EXTENSIONS


def _mesh_name(text: str, writable: bool = False) -> Path:
    """A path whose extension is a mesh format's (read, or with ``writable`` written)."""
    path = Path(text).expanduser()
    if path.suffix.lower() not in _mesh_extensions(writable=writable):
        raise argparse.ArgumentTypeError(
            f"expected a mesh file ({', '.join(_mesh_extensions(writable=writable))}), got {text!r}"
        )
    return path


@checks_files(_mesh_name)
def mesh_file(text: str) -> Path:
    """An existing file with the extension of a mesh format that is read."""
    path = Path(text).expanduser()
    if not path.is_file():
        what = "a folder" if path.is_dir() else "no such file"
        raise argparse.ArgumentTypeError(f"expected a mesh file, got {text!r} ({what})")
    if path.suffix.lower() not in _mesh_extensions(writable=False):
        raise argparse.ArgumentTypeError(
            f"expected a mesh file ({', '.join(_mesh_extensions(writable=False))}), got {text!r}"
        )
    return path


@checks_files(lambda text: _mesh_name(text, writable=True))
def mesh_output_file(text: str) -> Path:
    """A mesh file to write: an extension that is written, in a folder that exists or can be
    created (nothing is created here), not an existing folder."""
    from .cli_types import output_folder

    path = Path(text).expanduser()
    if path.suffix.lower() not in _mesh_extensions(writable=True):
        raise argparse.ArgumentTypeError(
            f"expected a mesh file name ending in {', '.join(_mesh_extensions(writable=True))}, "
            f"got {text!r}"
        )
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"expected a file name, got the folder {text!r}")
    output_folder(str(path.parent))
    return path


def print_line(text: str) -> None:
    """Print a progress line at once (a long run's progress must not wait in a buffer)."""
    print(text, flush=True)


@checks_files(Path)
def _table_file(text: str) -> Path:
    path = Path(text).expanduser()
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"expected a landmark table (CSV file), got {text!r}")
    return path


def add_landmark_arguments(p, atlas_landmarks: bool = False) -> None:
    """Add ``--landmarks`` and ``--no-landmarks`` (and ``--atlas-landmarks``)."""
    p.add_argument(
        "--landmarks",
        type=_table_file,
        default=None,
        help="landmark table (subject, apex_x..z, base_x..z, septum_x..z; row 'atlas' for the "
        "atlas), in the mesh files' coordinates: fixes each subject's turn about the long axis, "
        "which a surface fit leaves open, and anchors the stretch along it (default: landmarks.csv of --meshes when present, as "
        "'symladders mesh --rv-label' writes it)",
    )
    p.add_argument("--no-landmarks", action="store_true", help="ignore landmarks.csv of --meshes")
    if atlas_landmarks:
        p.add_argument(
            "--atlas-landmarks",
            type=_table_file,
            default=None,
            help="the atlas's landmarks (a table with a row 'atlas' or a single row); default: "
            "the row 'atlas' of --landmarks, else <atlas>_landmarks.csv beside the atlas file "
            "(written by 'symladders atlas')",
        )


def landmarks_argument(args, folder: Path):
    """The landmark table to use: ``--landmarks``, ``folder/landmarks.csv``, or False (none)."""
    from ..preparation.landmarks import LANDMARKS_FILE

    if args.no_landmarks:
        return False
    if args.landmarks is not None:
        return args.landmarks
    found = Path(folder) / LANDMARKS_FILE
    return found if found.is_file() else False
