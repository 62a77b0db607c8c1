"""Command-line interface: ``symladders validate`` and ``symladders study``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from .cli_types import (
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_USAGE,
    OneLineParser,
    UsageError,
    log_internal_error,
    nonnegative_int,
    output_folder,
)
from .study_cli import add_study_parser

__all__ = ["main", "build_parser"]


def _add_validate(sub) -> None:
    p = sub.add_parser(
        "validate",
        help="analytic validation of ladders and symmetry errors on closed-form spaces",
        description=(
            "Run the ladders and the symmetry estimators on spaces with known answers "
            "(sphere, hyperbolic space, SPD matrices, Poincare half-plane, warped surface), "
            "print errors and measured convergence slopes, and write validation.json, "
            "validation.md and convergence.png to the output folder."
        ),
    )
    p.add_argument(
        "--output",
        "-o",
        type=output_folder,
        default="symladders-output/validation",
        help="output folder",
    )
    p.add_argument(
        "--seed", type=nonnegative_int, default=0, help="seed of the random configurations"
    )
    p.add_argument("--quick", action="store_true", help="fewer trials and rungs (seconds)")


def _run_validate(args) -> int:
    from .analytic_validation import run_validation

    report = run_validation(args.output, seed=args.seed, quick=args.quick)
    print(report.to_markdown())
    print(f"\nWritten to {args.output}/ (validation.json, validation.md, convergence.png)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="symladders",
        description="Symmetric components for shape analysis: ladders, symmetries, LDDMM.",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    add_study_parser(sub)
    _add_validate(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``symladders`` console script.

    Exit statuses (see :mod:`ladders.study.cli_types`): 0 on success; 2 for
    invalid input (flags, meshes, output folder), reported as one line on
    standard error without a traceback; 3 for an internal error, reported as
    one line saying where the full traceback was written; 130 if interrupted.
    """
    from manifolds.errors import ManifoldError

    from .cohort import CohortError

    parser = build_parser()
    command = "symladders"
    args = None
    try:
        args = parser.parse_args(argv)
        command = f"symladders {args.command}"
        if args.command == "validate":
            return _run_validate(args)
        return args.run(args)
    except UsageError as exc:
        return _fail(str(exc), EXIT_USAGE)
    except (CohortError, ManifoldError) as exc:
        return _fail(f"{command}: error: {exc}", EXIT_USAGE)
    except OSError as exc:
        return _fail(f"{command}: error: {exc}", EXIT_USAGE)
    except KeyboardInterrupt:
        return _fail(f"{command}: interrupted", EXIT_INTERRUPTED)
    except SystemExit as exc:
        if exc.code is None or isinstance(exc.code, int):
            raise
        return _fail(str(exc.code), EXIT_USAGE)
    except Exception as exc:  # noqa: BLE001 - the last resort of the entry point
        log = log_internal_error(exc, getattr(args, "output", None))
        return _fail(
            f"{command}: internal error ({type(exc).__name__}: {_first_line(exc)}); "
            f"full traceback in {log}",
            EXIT_INTERNAL,
        )


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text else ""


def _fail(message: str, status: int) -> int:
    print(" ".join(message.split("\n")), file=sys.stderr)
    return status


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
