"""The linear model's flags, shared by ``symladders analyze`` and ``symladders cycle-analyze``.

:func:`add_model_arguments` defines ``--design``, ``--model``, ``--contrast``,
``--blocks``, ``--outcome``, ``--baseline``, ``--tfce``, ``--aha``, ``--fwhm`` and
``--alpha`` once, with the same meaning and format in both commands, and adds
``--compare`` (:func:`~.common_arguments.add_compare`, every command's);
:func:`model_request` turns the parsed flags into the table, formula and contrasts
to test (a design table, or a groups table as the model ``group``), with the checks
both commands make before any computation; :func:`print_outcome` reports a survival
analysis (``--outcome``).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

from .cli_types import UsageError, existing_file, positive_float
from .common_arguments import add_compare

__all__ = ["ModelRequest", "add_model_arguments", "column_pair", "model_request", "print_outcome"]


def column_pair(text: str) -> tuple[str, str]:
    """``TIME,EVENT`` -> ``("TIME", "EVENT")``: two column names separated by a comma."""
    names = tuple(t.strip() for t in text.split(","))
    if len(names) != 2 or not all(names):
        raise argparse.ArgumentTypeError(f"expected two column names as TIME,EVENT, got {text!r}")
    return names


def _level(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a level in (0, 1), got {text!r}") from None
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"expected a level in (0, 1), got {text!r}")
    return value


def add_model_arguments(p, aha_use: str, fwhm_when: str = "") -> None:
    """Add the linear model's flags to a parser.

    Parameters
    ----------
    p : argparse.ArgumentParser
    aha_use : str
        What ``--aha``'s landmarks are used for in this command (ends its help).
    fwhm_when : str
        When ``--fwhm`` applies, if not always (starts its help).
    """
    p.add_argument("--design", type=existing_file, default=None,
                   help="CSV design table: a column subject and any covariates (a linear model "
                        "per vertex instead of two groups; with --model and --contrast)")  # fmt: skip
    p.add_argument("--model", default=None, metavar="FORMULA",
                   help="model formula on the design's columns, e.g. 'group + age + sex'")  # fmt: skip
    p.add_argument("--contrast", nargs="+", default=None, metavar="SPEC",
                   help="contrasts to test, e.g. 'group[patients] - group[controls]', 'age', "
                        "or 'group' (F test over its levels)")  # fmt: skip
    p.add_argument("--blocks", default=None, metavar="COLUMN",
                   help="a design column of exchangeability blocks (e.g. site): permutations "
                        "within blocks")  # fmt: skip
    p.add_argument("--outcome", type=column_pair, default=None, metavar="TIME,EVENT",
                   help="design columns of a survival outcome (follow-up time, event 1 or "
                        "censored 0): Cox regression on the motion's PCA scores, cross-validated "
                        "C-index per motion")  # fmt: skip
    p.add_argument("--baseline", nargs="+", default=None, metavar="COLUMN",
                   help="with --outcome: clinical design columns predicted alone for comparison "
                        "(e.g. ejection_fraction)")  # fmt: skip
    p.add_argument("--tfce", action="store_true",
                   help="also threshold-free cluster enhancement (H = 2, E = 1) on the atlas's "
                        "triangles, with its own family-wise p-values")  # fmt: skip
    p.add_argument("--aha", type=existing_file, default=None, metavar="LANDMARKS",
                   help="the atlas's apex, base-plane centre and septal point (a JSON file, or a "
                        f"landmark table's row 'atlas'): {aha_use}")  # fmt: skip
    p.add_argument("--fwhm", type=positive_float, default=None, metavar="MM",
                   help=f"{fwhm_when}smooth every subject's maps on the atlas before the tests, "
                        "by the heat kernel of this full width at half maximum (mm); default: "
                        "not smoothed")  # fmt: skip
    add_compare(p)
    p.add_argument("--alpha", type=_level, default=0.05, help="family-wise error level")


@dataclass(frozen=True)
class ModelRequest:
    """What to test: the table, the model formula and the contrasts, and where they came from.

    ``formula`` and ``contrasts`` are None when only an outcome is asked for.
    """

    table: dict
    formula: str | None
    contrasts: list | None
    source: Path
    groups: bool = False


def model_request(args, command: str) -> ModelRequest:
    """The model of ``--design`` (with ``--model`` and ``--contrast``) or of ``--groups``.

    ``--groups`` is the model ``group`` with the contrast of the two groups (``--compare
    A,B``: A against B, the subjects of other groups left out). Raises
    :class:`UsageError` (one line, naming the flag or the file) for: neither or both of
    ``--groups`` and ``--design``; ``--outcome`` or ``--blocks`` without ``--design``;
    ``--design`` without ``--model`` and ``--contrast`` (unless ``--outcome``); a table
    that cannot be read.
    """
    from ladders.statistics import read_design

    from ..cohort import read_groups
    from ..errors import CohortError
    from ..population import groups_design

    prefix = f"symladders {command}: error:"
    if (args.groups is None) == (args.design is None):
        raise UsageError(f"{prefix} give --groups or --design (one of them)")
    if args.groups is not None:
        for flag in ("outcome", "blocks", "model", "contrast"):
            if getattr(args, flag) is not None:
                raise UsageError(f"{prefix} --{flag}: needs --design (not with --groups)")
        try:
            table, formula, contrasts = groups_design(read_groups(args.groups), args.compare)
        except CohortError as exc:
            raise UsageError(f"{prefix} --groups {args.groups}: {exc}") from None
        return ModelRequest(table, formula, contrasts, Path(args.groups), groups=True)
    if args.compare is not None:
        raise UsageError(f"{prefix} --compare: only with --groups (with --design, write the "
                         "contrast: --contrast 'group[A] - group[B]')")  # fmt: skip
    if (args.model is None or not args.contrast) and args.outcome is None:
        raise UsageError(f"{prefix} --design needs --model and --contrast (or --outcome)")
    if (args.model is None) != (not args.contrast):
        raise UsageError(f"{prefix} --model and --contrast go together")
    try:
        table = read_design(args.design)
    except ValueError as exc:
        raise UsageError(f"{prefix} --design: {exc}") from None
    return ModelRequest(table, args.model, args.contrast, Path(args.design))


def print_outcome(outcome, baseline) -> None:
    """One line per motion: the cross-validated C-index and its interval (and the baseline's)."""
    for m, r in outcome.results:
        base = ("" if r.baseline_c_index is None else
                f"; {', '.join(baseline)} alone {r.baseline_c_index:.2f}")  # fmt: skip
        print(f"{m.label}: C-index {r.c_index:.2f} [{r.ci_low:.2f}, {r.ci_high:.2f}]{base}")
    print(f"Outcome tables in {Path(outcome.paths['outcome.csv']).parent}: outcome.csv, "
          "outcome_summary.md")  # fmt: skip
