"""Benchmark figures as generated tables: one source per figure in the README and the docs.

A benchmark calls :func:`publish` with a name and a Markdown table. The table is
written, under a heading naming the CPU model, the core count, the SIMD level and
the date (:func:`machine`), to ``docs/generated/<name>.md``, and copied into every
README or docs page between the markers::

    <!-- BEGIN generated/<name> -->
    ...
    <!-- END generated/<name> -->

so that no figure is typed by hand; ``tests/test_generated_tables.py`` checks
that every marked region equals its generated file.
"""

from __future__ import annotations

import datetime
import os
import platform
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "docs" / "generated"

__all__ = ["machine", "simd_level", "publish", "refresh", "PAGES"]

#: The pages whose marked regions are kept equal to the generated tables.
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


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


def machine() -> str:
    """One line: CPU model, cores, SIMD level, date."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    today = datetime.date.today().isoformat()
    return f"{_cpu_model()}, {cores} cores, {simd_level()}, measured {today}"


def _copy_into_pages(name: str, text: str) -> list[str]:
    """Replace the region ``generated/<name>`` of every page by ``text``; the pages changed."""
    begin, end = f"<!-- BEGIN generated/{name} -->", f"<!-- END generated/{name} -->"
    pattern = re.compile(re.escape(begin) + r".*?" + re.escape(end), flags=re.S)
    region = f"{begin}\n{text}{end}"
    changed = []
    for page in PAGES:
        content = page.read_text(encoding="utf-8")
        if begin in content:
            page.write_text(pattern.sub(lambda _: region, content), encoding="utf-8")
            changed.append(f"{page.name}: {name}")
    return changed


def publish(name: str, table: str, command: str) -> Path:
    """Write ``table`` as ``docs/generated/<name>.md`` and into every marked region of it."""
    text = f"*Measured by `{command}` on {machine()}.*\n\n{table.strip()}\n"
    GENERATED.mkdir(parents=True, exist_ok=True)
    path = GENERATED / f"{name}.md"
    path.write_text(text, encoding="utf-8")
    _copy_into_pages(name, text)
    return path


def refresh() -> list[str]:
    """Copy every table of ``docs/generated/`` into its marked regions (no benchmark is run)."""
    names = []
    for path in sorted(GENERATED.glob("*.md")):
        names += _copy_into_pages(path.stem, path.read_text(encoding="utf-8"))
    return names


if __name__ == "__main__":
    print("\n".join(refresh()))
