"""``symladders validate``: the analytic validation of the ladders on closed-form spaces."""

from __future__ import annotations

from .cli_types import DefaultsFormatter
from .common_arguments import add_output, add_seed

__all__ = ["add_validate_parser", "run_validate_command"]


def add_validate_parser(sub) -> None:
    """Register the ``validate`` subcommand on an argparse subparsers object."""
    p = sub.add_parser(
        "validate",
        help="analytic validation of ladders and symmetry errors on closed-form spaces",
        description=(
            "Run the ladders and the symmetry estimators on spaces with known answers "
            "(sphere, hyperbolic space, SPD matrices, Poincare half-plane, warped surface), "
            "print errors and measured convergence slopes, and write validation.json, "
            "validation.md and convergence.png to the output folder."
        ),
        formatter_class=DefaultsFormatter,
    )
    add_output(p, "symladders-output/validation", "output folder")
    add_seed(p)
    p.add_argument("--quick", action="store_true", help="fewer trials and rungs (seconds)")
    p.set_defaults(run=run_validate_command)


def run_validate_command(args) -> int:
    """Run the analytic validation from parsed command-line arguments."""
    from ..analytic_validation import run_validation

    report = run_validation(args.output, seed=args.seed, quick=args.quick)
    print(report.to_markdown())
    print(f"\nWritten to {args.output}/ (validation.json, validation.md, convergence.png)")
    return 0
