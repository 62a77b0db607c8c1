"""The ``symladders`` command: its parser and entry point.

Subcommands: ``study``, ``mesh`` (label images to meshes), ``correspond`` and ``atlas`` (a user's segmentations to
a cohort in correspondence and its atlas), ``cohort`` (the synthetic cohort in two
groups with a planted abnormality), ``analyze`` (group statistics of a study's
transported motion), ``validate``, ``track`` (corresponded ED meshes through label or cine
series), ``cycle-study`` and ``cycle-analyze`` (every frame transported and tested),
``wall`` (wall thickness, thickening and strain of tracked subjects).
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from pathlib import Path

from .analyze_cli import add_analyze_parser
from .atlas_cli import add_atlas_parser
from .cli_types import (
    EXIT_BROKEN_PIPE,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_USAGE,
    OneLineParser,
    UsageError,
    log_internal_error,
)
from .cohort_cli import add_cohort_parser
from .correspond_cli import add_correspond_parser
from .cycle_analyze_cli import add_cycle_analyze_parser
from .cycle_cli import add_cycle_study_parser
from .mesh_cli import add_mesh_parser
from .plugin_arguments import preload_plugins
from .run_cli import add_run_parser
from .study_cli import add_study_parser
from .track_cli import add_track_parser
from .validate_cli import add_validate_parser
from .wall_cli import add_wall_parser

__all__ = ["main", "build_parser"]


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``symladders`` with its subcommands."""
    parser = OneLineParser(
        prog="symladders",
        description="Symmetric components for shape analysis: ladders, symmetries, LDDMM.",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    add_run_parser(sub, main)
    add_study_parser(sub)
    add_mesh_parser(sub)
    add_correspond_parser(sub)
    add_atlas_parser(sub)
    add_cohort_parser(sub)
    add_analyze_parser(sub)
    add_validate_parser(sub)
    add_track_parser(sub)
    add_cycle_study_parser(sub)
    add_cycle_analyze_parser(sub)
    add_wall_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``symladders`` console script.

    Exit statuses (see :mod:`ladders.study.cli.cli_types`): 0 on success; 2 for
    invalid input (flags, meshes, output folder), reported as one line on
    standard error without a traceback; 3 for an internal error, reported as
    one line saying where the full traceback was written; 130 if interrupted.
    """
    from ladders.tables import TableError
    from manifolds.errors import ManifoldError

    from ..errors import CohortError

    command = "symladders"
    args = None
    try:
        preload_plugins(sys.argv[1:] if argv is None else argv)
        args = build_parser().parse_args(argv)
        command = f"symladders {args.command}"
        return args.run(args)
    except BrokenPipeError:
        return _closed_pipe()
    except UsageError as exc:
        return _fail(str(exc), EXIT_USAGE)
    except (CohortError, ManifoldError, TableError) as exc:
        return _fail(f"{command}: error: {exc}", EXIT_USAGE)
    except OSError as exc:
        return _fail(f"{command}: error: {exc}", EXIT_USAGE)
    except KeyboardInterrupt:
        hint = getattr(args, "on_interrupt", None)
        return _fail(f"{command}: interrupted{'; ' + hint if hint else ''}", EXIT_INTERRUPTED)
    except SystemExit as exc:
        if exc.code is None or isinstance(exc.code, int):
            raise
        return _fail(str(exc.code), EXIT_USAGE)
    except Exception as exc:  # noqa: BLE001 - the last resort of the entry point
        log = log_internal_error(exc, _log_folder(args))
        return _fail(
            f"{command}: internal error ({type(exc).__name__}: {_first_line(exc)}); "
            f"full traceback in {log}",
            EXIT_INTERNAL,
        )


def _log_folder(args) -> str | None:
    """The output folder, where the traceback of an internal error is written (the folder
    of the output file for a command that writes one file)."""
    output = getattr(args, "output", None)
    if output is not None and getattr(args, "output_is_file", False):
        return str(Path(output).parent)
    return None if output is None else str(output)


def _closed_pipe() -> int:
    """The reader of standard output went away (``symladders study | head``): end
    quietly, as standard tools do, with the status of a SIGPIPE (128 + 13)."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())  # no second error when Python flushes at exit
    return EXIT_BROKEN_PIPE


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text else ""


def _fail(message: str, status: int) -> int:
    print(" ".join(message.split("\n")), file=sys.stderr)
    return status
