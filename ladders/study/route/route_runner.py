"""Running the route: every step in order, reused when what it reads and wrote are unchanged.

:func:`run_route` reads the settings and the subjects table, writes the inputs folder,
and runs each step of :func:`~.route_plan.plan_route` through ``execute`` (the
``symladders`` entry point: the same parser and functions as the commands typed one by
one). Before a step runs, the fingerprints of what it reads are taken; a step whose
command, inputs and outputs are those recorded in ``OUTPUT/run.json`` when it last
finished is not run again (``reused``). A step that runs writes its standard output
and error to ``OUTPUT/logs/<step>.log``; its summary lines are printed.

The record is written after every step, so an interruption loses nothing finished;
the commands themselves keep every finished subject, so the step resumes. A step in
which some subjects failed (exit status 1) is recorded as ``partial`` and the route
goes on with the others; a usage error or an internal error stops the route, naming
the step and its log.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from ..files import atomic_write_text
from .fingerprint import Fingerprints
from .route_inputs import write_route_inputs
from .route_model import route_model
from .route_plan import STEP_NAMES, Step, plan_route
from .route_settings import read_route_settings
from .subjects_table import read_subjects_table

__all__ = ["RouteError", "StepOutcome", "RouteOutcome", "load_route", "run_route", "RECORD_FILE"]

#: The run's record, in the output folder.
RECORD_FILE = "run.json"
_LOG_EXCLUDE = ()


class RouteError(RuntimeError):
    """A step stopped the route (a usage or internal error); the message names it and its log."""


@dataclass
class StepOutcome:
    """What a step did: ``ran``, ``partial`` (some subjects failed) or ``reused``; its
    ``exit_status`` is the command's (1: some subjects failed, also when reused)."""

    name: str
    status: str
    seconds: float = 0.0
    summary: list = field(default_factory=list)
    log: Path | None = None
    exit_status: int = 0


@dataclass
class RouteOutcome:
    """The route's steps and what each did."""

    settings: object
    table: object
    model: object
    steps: list
    outcomes: list = field(default_factory=list)


def load_route(settings_path, scheduler: str | None = None):
    """Settings, subjects table, model and steps of a settings file (nothing written)."""
    from .route_inputs import RouteInputs

    settings = read_route_settings(settings_path)
    table = read_subjects_table(settings.subjects, ignore=settings["model"]["ignore"])
    model = route_model(table, settings)
    inputs = RouteInputs(settings.output)
    steps = plan_route(table, settings, model, inputs, scheduler)
    return settings, table, model, inputs, steps


def _key(step: Step, reads: str | None, root: Path) -> str:
    h = hashlib.sha256(step.command(root).encode())
    h.update(f"\0{reads}".encode())
    return h.hexdigest()


def _read_record(path: Path) -> dict:
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {"steps": {}, "hashes": {}}
    return record if isinstance(record, dict) else {"steps": {}, "hashes": {}}


def _summary(text: str, command: str) -> list[str]:
    """The lines of a command's output that sum it up (those naming the command)."""
    lines = [ln for ln in text.splitlines() if ln.startswith(f"symladders {command}")]
    return lines[-3:] if lines else [ln for ln in text.splitlines() if ln.strip()][-2:]


def _write_design(step: Step, table, model, settings) -> None:
    """The design table of the subjects that reached ``step.design_from``."""
    from .route_report import subjects_with_results

    have = set(subjects_with_results(step.design_from))
    s = settings["model"]
    columns = list(dict.fromkeys(
        [*model.columns, *(c for c in (s["blocks"], *(s["outcome"] or ())) if c)]
    ))  # fmt: skip
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["subject", *columns])
    for e in table.entries:
        if e.subject in have:
            writer.writerow([e.subject, *(e.covariates[c] for c in columns)])
    step.design.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(step.design, out.getvalue())


def run_route(
    settings_path,
    execute: Callable[[list], int],
    *,
    dry_run: bool = False,
    redo=(),
    echo: Callable[[str], None] = print,
    scheduler: str | None = None,
    start_cluster: Callable | None = None,
) -> RouteOutcome:
    """Run (or, with ``dry_run``, print) the route of a settings file (see the module).

    Parameters
    ----------
    settings_path : path
    execute : callable
        ``execute(argv) -> exit status``: runs ``symladders ARGV``.
    dry_run : bool
        Print the plan (each step's command and whether it would run) and stop.
    redo : sequence of str
        Steps run again even when they could be reused.
    echo : callable
        Where the route's lines go.
    scheduler : str, optional
        A running Dask scheduler's address (with ``execution.backend = "dask"``).
    start_cluster : callable, optional
        ``start_cluster(settings) -> (address, close)``: a local Dask cluster when the
        settings ask for Dask and name no scheduler.

    Raises
    ------
    RouteError
        A step stopped with a usage or internal error.
    """
    unknown = [s for s in redo if s not in STEP_NAMES]
    if unknown:
        raise ValueError(f"redo: unknown step {unknown[0]!r} (steps: {', '.join(STEP_NAMES)})")
    settings, table, model, inputs, steps = load_route(settings_path, scheduler)
    root = Path(settings.output)
    record_path = root / RECORD_FILE
    record = _read_record(record_path)
    prints = Fingerprints(record.get("hashes"))
    outcome = RouteOutcome(settings, table, model, steps)
    echo(_headline(settings, table, model))
    if dry_run:
        for i, step in enumerate(steps, 1):
            echo(f"{i:>2}. {step.name:<15} {step.why}")
            echo(f"    {step.command(root)}")
        echo(f"Results in {root}; the report: {root / 'report.md'}")
        return outcome
    root.mkdir(parents=True, exist_ok=True)
    write_route_inputs(table, root, settings, settings["tracking"]["track"])
    close = None
    if settings["execution"]["backend"] == "dask" and scheduler is None and start_cluster:
        scheduler, close = start_cluster(settings)
        settings, table, model, inputs, steps = load_route(settings_path, scheduler)
        outcome.steps = steps
    try:
        for i, step in enumerate(steps, 1):
            result = _run_step(step, i, len(steps), root, record, prints, redo, execute, echo,
                               outcome, table, model, settings)  # fmt: skip
            outcome.outcomes.append(result)
            record["hashes"] = prints.cache
            atomic_write_text(record_path, json.dumps(record, indent=1, default=str))
    finally:
        if close is not None:
            close()
    return outcome


def _headline(settings, table, model) -> str:
    tracked = len(table.tracked)
    series = f", {tracked} with a series to track" if tracked else ""
    what = (f"model '{model.formula}', contrast(s) {'; '.join(model.contrasts)}"
            if model.formula else "no covariate: no model to test")  # fmt: skip
    return f"symladders run {settings.path.name}: {len(table)} subjects{series}; {what}"


def _run_step(step, i, n, root, record, prints, redo, execute, echo, outcome, table, model,
              settings) -> StepOutcome:  # fmt: skip
    if step.design is not None:
        _write_design(step, table, model, settings)
    reads = prints.paths(step.reads)
    key = _key(step, reads, root)
    stored = record["steps"].get(step.name, {})
    writes = prints.paths(step.writes)
    if (step.name not in redo and stored.get("key") == key and writes is not None
            and stored.get("writes") == writes and stored.get("status") in ("ran", "partial")):  # fmt: skip
        echo(f"[{i}/{n}] {step.name}: reused ({step.command(root)})")
        exit_status = 1 if stored["status"] == "partial" else 0
        return StepOutcome(step.name, "reused", 0.0, stored.get("summary", []), None, exit_status)
    logs = root / "logs"
    logs.mkdir(exist_ok=True)
    log = logs / f"{step.name}.log"
    echo(f"[{i}/{n}] {step.name}: {step.command(root)}")
    if step.argv is not None:
        echo(f"    (its output, as it runs: {log})")
    start = time.perf_counter()
    if step.argv is None:
        from .route_report import write_report

        write_report(outcome, root)
        status, summary = 0, [f"report: {root / 'report.md'}"]
        log.write_text("\n".join(summary) + "\n", encoding="utf-8")
    else:
        argv = [step.program, *map(str, step.argv)]
        with open(log, "w", encoding="utf-8", buffering=1) as fh:  # followed live: tail -f
            fh.write(f"$ symladders {' '.join(argv)}\n")
            with contextlib.redirect_stdout(fh), contextlib.redirect_stderr(fh):
                status = execute(argv)
        text = log.read_text(encoding="utf-8")
        summary = _summary(text, argv[0])
    seconds = time.perf_counter() - start
    for line in summary:
        echo(f"    {line}")
    if status not in (0, 1):
        record["steps"][step.name] = {"status": "failed", "exit": status}
        raise RouteError(
            f"symladders run: step {step.name} stopped (exit status {status}): "
            f"{summary[-1] if summary else ''} (full output in {log})"
        )
    state = "ran" if status == 0 else "partial"
    record["steps"][step.name] = {
        "status": state, "key": key, "writes": prints.paths(step.writes),
        "command": step.command(root), "seconds": round(seconds, 1), "summary": summary,
        "finished": time.strftime("%Y-%m-%dT%H:%M:%S"),
    }  # fmt: skip
    echo(f"    {state} in {seconds:.0f} s" + ("" if status == 0 else
         f"; some subjects failed: see {log} and the report"))  # fmt: skip
    return StepOutcome(step.name, state, seconds, summary, log, status)
