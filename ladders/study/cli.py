"""Command-line interface: ``symladders validate`` and ``symladders study``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

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
    p.add_argument("--output", "-o", default="symladders-output/validation", help="output folder")
    p.add_argument("--seed", type=int, default=0, help="seed of the random configurations")
    p.add_argument("--quick", action="store_true", help="fewer trials and rungs (seconds)")


def _run_validate(args) -> int:
    from .analytic_validation import run_validation

    report = run_validation(args.output, seed=args.seed, quick=args.quick)
    print(report.to_markdown())
    print(f"\nWritten to {args.output}/ (validation.json, validation.md, convergence.png)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="symladders",
        description="Symmetric components for shape analysis: ladders, symmetries, LDDMM.",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    add_study_parser(sub)
    _add_validate(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``symladders`` console script.

    Invalid input (unreadable or non-corresponding meshes, bad values) is
    reported on standard error with exit status 2, without a traceback.
    """
    from manifolds.errors import ManifoldError

    from .cohort import CohortError

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if args.command == "validate":
            return _run_validate(args)
        return args.run(args)
    except (CohortError, ManifoldError) as exc:
        print(f"symladders {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
