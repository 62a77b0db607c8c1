"""Benchmark figures as generated tables: one source per figure in the README and the docs.

A benchmark calls :func:`publish` with a name and a Markdown table. The table is
written, under a heading naming the CPU model, the core count, the SIMD level and
the date (:func:`machine`), to ``docs/generated/<name>.md``, and copied into every
page of the README, the user guide (``docs/*.md``) or the evidence
(``docs/evidence/*.md``) between the markers::

    <!-- BEGIN generated/<name> -->
    ...
    <!-- END generated/<name> -->

so that no figure is typed by hand; ``tests/test_generated_tables.py`` checks
that every marked region equals its generated file.

A benchmark whose figure depends on the CPU (the main job's time, the test suite's
time) calls :func:`publish_rows` instead: its table keeps one row per CPU (model and
SIMD level), stored with the date of each row in ``docs/generated/<name>.rows.json``;
a run replaces the row of its own CPU and keeps the rows measured on other CPUs.
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "docs" / "generated"

__all__ = [
    "machine",
    "simd_level",
    "this_cpu",
    "publish",
    "publish_rows",
    "read_table",
    "refresh",
    "PAGES",
    "GUIDE_PAGES",
    "EVIDENCE_PAGES",
]

#: The README and the pages of ``docs/``: the user guide and the library (what to do, what a
#: result means; ``docs/index.md`` lists which is which).
GUIDE_PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: The evidence: the validation and benchmark reports of ``docs/evidence/`` the guide links to.
EVIDENCE_PAGES = sorted((ROOT / "docs" / "evidence").glob("*.md"))
#: The pages whose marked regions are kept equal to the generated tables.
PAGES = [*GUIDE_PAGES, *EVIDENCE_PAGES]


def simd_level() -> str:
    """The widest vector instruction set of this CPU (avx512, avx2, sse4, neon, ...)."""
    try:
        flags = Path("/proc/cpuinfo").read_text()
    except OSError:
        flags = ""
    for level, flag in (("avx512", "avx512f"), ("avx2", "avx2"), ("sse4", "sse4_2"),
                        ("neon", "asimd"), ("neon", "neon")):  # fmt: skip
        if re.search(rf"\b{flag}\b", flags):
            return level
    return platform.machine() or "unknown"


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith(("model name", "hardware", "cpu model")):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown CPU"


def _cores() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()


def machine() -> str:
    """One line: CPU model, cores, SIMD level, date."""
    today = datetime.date.today().isoformat()
    return f"{_cpu_model()}, {_cores()} cores, {simd_level()}, measured {today}"


def _copy_into_pages(name: str, text: str, pages=None) -> list[str]:
    """Replace the region ``generated/<name>`` of every page by ``text``; the pages changed."""
    begin, end = f"<!-- BEGIN generated/{name} -->", f"<!-- END generated/{name} -->"
    pattern = re.compile(re.escape(begin) + r".*?" + re.escape(end), flags=re.S)
    region = f"{begin}\n{text}{end}"
    changed = []
    for page in PAGES if pages is None else pages:
        content = page.read_text(encoding="utf-8")
        if begin in content:
            page.write_text(pattern.sub(lambda _: region, content), encoding="utf-8")
            changed.append(f"{page.name}: {name}")
    return changed


def publish(name: str, table: str, command: str, *, folder=None, pages=None) -> Path:
    """Write ``table`` as ``docs/generated/<name>.md`` and into every marked region of it.

    ``folder`` (default :data:`GENERATED`) and ``pages`` (default :data:`PAGES`) are
    for tests, which write into a temporary folder instead of the repository.
    """
    text = f"*Measured by `{command}` on {machine()}.*\n\n{table.strip()}\n"
    folder = GENERATED if folder is None else Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.md"
    path.write_text(text, encoding="utf-8")
    _copy_into_pages(name, text, pages)
    return path


def publishing_main(name: str, doc: str, make_table, argv=None, *, folder=None, pages=None):
    """The command line of a benchmark with one table: ``[--publish]``.

    Prints the machine and the table ``make_table()`` measures; with ``--publish``
    writes it as ``docs/generated/<name>.md`` (:func:`publish`; ``folder`` and ``pages``
    as there), the command named after the calling script. Returns the table.
    """
    import argparse
    import sys

    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    table = make_table()
    print("\n" + table)
    if args.publish:
        script = Path(sys.argv[0]).name
        publish(name, table, f"python benchmarks/{script} --publish", folder=folder, pages=pages)
    return table


def read_table(path) -> dict:
    """The machine line and the table of a file written by :func:`publish`.

    Returns ``cpu``, ``cores``, ``simd`` and ``date`` (from the heading), ``header``
    (the column names) and ``rows`` (each a dict column -> cell).
    """
    lines = Path(path).read_text(encoding="utf-8").splitlines()
    head = re.search(r" on (.*), (\d+) cores, (\w+), measured (\d{4}-\d\d-\d\d)\.\*$", lines[0])
    if head is None:
        raise ValueError(f"{path}: no machine line")
    cells = lambda line: [c.strip() for c in line.strip().strip("|").split("|")]  # noqa: E731
    table = [line for line in lines[1:] if line.startswith("|")]
    header = cells(table[0])
    rows = [dict(zip(header, cells(line))) for line in table[2:]]
    cpu, cores, simd, date = head.groups()
    return {"cpu": cpu, "cores": int(cores), "simd": simd, "date": date, "header": header,
            "rows": rows}  # fmt: skip


def _cpu_key(cpu: str, simd: str) -> str:
    return f"{cpu} / {simd}"


def this_cpu() -> dict:
    """The fields of a per-CPU row that name this machine and today's date."""
    return {"cpu": _cpu_model(), "cores": _cores(), "simd": simd_level(),
            "date": datetime.date.today().isoformat()}  # fmt: skip


def _render_rows(header: list[str], rows: list[dict]) -> str:
    columns = ["CPU", "date", *header]
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for row in rows:
        cpu = f"{row['cpu']}, {row['cores']} cores, {row['simd']}"
        cells = [cpu, row["date"], *(row["cells"].get(c, "–") for c in header)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def publish_rows(name: str, header: list[str], row: dict, command: str, *, seed=None,
                 folder=None, pages=None) -> Path:  # fmt: skip
    """Publish a table of one row per CPU as ``docs/generated/<name>.md``.

    ``row`` maps the columns of ``header`` to this run's cells. The rows are stored in
    ``docs/generated/<name>.rows.json``, keyed by CPU model and SIMD level, each with
    its date and core count: this run's row replaces the row of this CPU, the rows of
    other CPUs are kept (in the order they were first stored). The table lists the
    CPU and the date of every row before the columns of ``header`` (a cell a row does
    not have is shown as "–"). ``seed`` (a list of rows as :func:`this_cpu` fields plus
    ``cells``) is stored first when there is no ``.rows.json`` yet: the rows measured
    before the table kept one per CPU. ``folder`` and ``pages`` are as in :func:`publish`.
    """
    folder = GENERATED if folder is None else Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    store = folder / f"{name}.rows.json"
    if store.is_file():
        rows = json.loads(store.read_text(encoding="utf-8"))["rows"]
    else:
        rows = [dict(r) for r in seed or []]
    new = {**this_cpu(), "cells": {c: str(row[c]) for c in header if c in row}}
    key = _cpu_key(new["cpu"], new["simd"])
    keys = [_cpu_key(r["cpu"], r["simd"]) for r in rows]
    if key in keys:
        rows[keys.index(key)] = new
    else:
        rows.append(new)
    store.write_text(json.dumps({"command": command, "header": header, "rows": rows},
                                indent=1, ensure_ascii=False) + "\n", encoding="utf-8")  # fmt: skip
    text = (f"*Measured by `{command}`, one row per CPU (a run replaces the row of its CPU); "
            f"last run on {machine()}.*\n\n{_render_rows(header, rows)}\n")  # fmt: skip
    path = folder / f"{name}.md"
    path.write_text(text, encoding="utf-8")
    _copy_into_pages(name, text, pages)
    return path


def refresh(folder=None, pages=None) -> list[str]:
    """Copy every table of ``docs/generated/`` into its marked regions (no benchmark is run)."""
    names = []
    for path in sorted((GENERATED if folder is None else Path(folder)).glob("*.md")):
        names += _copy_into_pages(path.stem, path.read_text(encoding="utf-8"), pages)
    return names


if __name__ == "__main__":
    print("\n".join(refresh()))
