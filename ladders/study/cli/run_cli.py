"""``symladders run SETTINGS``: the whole route from a subjects table to the adjusted maps.

A thin wrapper of :func:`~ladders.study.route.run_route`: every step is a
``symladders`` command run through this entry point (:func:`~.entry.main`), so that
the route and the commands typed one by one are the same code.
"""

from __future__ import annotations

import sys
from pathlib import Path

from .cli_types import DefaultsFormatter, UsageError

__all__ = ["add_run_parser", "run_run_command"]


def add_run_parser(sub, execute) -> None:
    """Register the ``run`` subcommand on an argparse subparsers object; ``execute(argv)``
    runs ``symladders ARGV`` (the entry point, :func:`~.entry.main`), each step's command."""
    from ..route import STEP_NAMES

    p = sub.add_parser(
        "run",
        help="the whole route from a subjects table to the adjusted maps (start here)",
        description=(
            "Run the route a settings file describes: its subjects table (one row per "
            "subject: images, ED/ES frames, group, covariates, landmarks) is meshed, the atlas "
            "estimated, every subject corresponded to it and tracked through its series, the "
            "motion transported to the atlas and the table's model tested at every vertex; "
            "OUTPUT/report.md is the entry point to the results. Every step is a symladders "
            "command (--dry-run prints them), writes its own folder and is reused when what it "
            "reads has not changed; a failing subject is recorded with its reason and the "
            "others go on. 'symladders run --template' prints a settings file with every key."
        ),
        formatter_class=DefaultsFormatter,
    )
    p.add_argument("settings", type=Path, nargs="?", metavar="SETTINGS",
                   help="the settings file (TOML), e.g. study.toml")  # fmt: skip
    p.add_argument("--dry-run", action="store_true",
                   help="print the plan (each step's command) and stop")  # fmt: skip
    p.add_argument("--redo", nargs="+", default=(), choices=STEP_NAMES, metavar="STEP",
                   help=f"run these steps again even when they could be reused "
                        f"({', '.join(STEP_NAMES)})")  # fmt: skip
    p.add_argument("--template", action="store_true",
                   help="print a settings file with every key at its default, and stop")  # fmt: skip
    p.set_defaults(run=run_run_command, output_is_file=False, execute=execute)


def _start_cluster(settings):
    """A local Dask cluster for the route's batch steps: ``(address, close)``."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise UsageError(
            "symladders run: error: execution.backend = 'dask' needs the optional extra: "
            "pip install 'symladders[cluster]'"
        ) from None
    import os

    jobs = settings["execution"]["jobs"]
    workers = os.cpu_count() or 1 if jobs == -1 else jobs
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True)
    client = Client(cluster)

    def close():
        client.close()
        cluster.close()

    return cluster.scheduler_address, close


def run_run_command(args) -> int:
    """Run the route from parsed arguments."""
    from ..route import RouteError, run_route, settings_template

    if args.template:
        sys.stdout.write(settings_template())
        return 0
    if args.settings is None:
        raise UsageError("symladders run: error: the settings file is required (symladders run "
                         "--template > study.toml writes one)")  # fmt: skip
    if not args.settings.is_file():
        raise UsageError(f"symladders run: error: SETTINGS: no such file: {args.settings}")
    args.output = None
    try:
        outcome = run_route(args.settings, args.execute, dry_run=args.dry_run, redo=args.redo,
                            echo=lambda line: print(line, flush=True),
                            start_cluster=_start_cluster)  # fmt: skip
    except RouteError as exc:
        print(str(exc), file=sys.stderr)
        return 2
    if args.dry_run:
        return 0
    partial = [o.name for o in outcome.outcomes if o.exit_status == 1]
    print(f"symladders run: done; the report: {Path(outcome.settings.output) / 'report.md'}"
          + (f" (subjects failed in: {', '.join(partial)})" if partial else ""))  # fmt: skip
    return 1 if partial else 0
