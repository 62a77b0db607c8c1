"""``symladders validate``: the analytic validation of the ladders on closed-form spaces."""

from __future__ import annotations

from .cli_types import DefaultsFormatter
from .common_arguments import add_output, add_seed
from .plugin_arguments import add_plugin_argument, one_deformation

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
    p.add_argument(
        "--deformation",
        type=one_deformation,
        default=None,
        metavar="NAME",
        help="validate this registered deformation model instead (the interface, the "
        "contract of every space and the pole ladder's convergence; "
        "docs/add_your_own_space.md), written to OUTPUT/deformation_NAME.md",
    )
    add_plugin_argument(p)
    p.set_defaults(run=run_validate_command)


def run_validate_command(args) -> int:
    """Run the analytic validation (or a deformation model's) from parsed arguments.

    With ``--deformation`` the status is 1 when a check failed (the first named on
    standard error in one line).
    """
    if args.deformation is not None:
        return _validate_deformation(args)
    from ..analytic_validation import run_validation

    report = run_validation(args.output, seed=args.seed, quick=args.quick)
    print(report.to_markdown())
    print(f"\nWritten to {args.output}/ (validation.json, validation.md, convergence.png)")
    return 0


def _validate_deformation(args) -> int:
    import sys
    from pathlib import Path

    from ..deformations import validate_deformation_model
    from ..files import atomic_write_text

    report = validate_deformation_model(args.deformation, seed=args.seed, raise_on_failure=False)
    text = report.to_markdown()
    print(text)
    path = Path(args.output) / f"deformation_{args.deformation}.md"
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, text)
    print(f"Written to {path}")
    if report.failures:
        prop, why = next(iter(report.failures.items()))
        print(f"symladders validate: deformation model {args.deformation!r} failed {prop}: {why}",
              file=sys.stderr)  # fmt: skip
        return 1
    return 0
