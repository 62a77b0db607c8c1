"""Wall time of the test suite: the pytest part of the README's test command.

Runs ``python -m pytest -q -p no:cacheprovider`` in the repository as a subprocess
(the README's ``pip install -e ".[test,docs,cluster,geomstats]" && python -m pytest``
without the install, and without writing pytest's cache), and prints its wall time
and the counts of passed, skipped and failed tests (and errors). The 1-minute load
average at the start is recorded, since other jobs may share the CPU.

``--publish`` writes the row into the table of one row per CPU
``docs/generated/test_suite_time.md`` (``generated_tables.publish_rows``): the run
replaces the row of its CPU (model and SIMD level) and keeps the others. The time is
published whatever the outcome of the tests; the counts say how it ended.

Usage: ``python benchmarks/bench_tests.py [--publish] [-- extra pytest arguments]``.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMMAND = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"]
HEADER = ["load", "Python", "wall time", "passed", "skipped", "failed", "errors"]


def counts(output: str) -> dict[str, int]:
    """The counts of pytest's last summary line (``3 passed, 1 skipped in 2.0s``)."""
    summary = [line for line in output.splitlines() if re.search(r"\bin [\d.]+s\b", line)]
    found = {"passed": 0, "skipped": 0, "failed": 0, "errors": 0}
    if summary:
        for number, word in re.findall(r"(\d+) (passed|skipped|failed|errors?)\b", summary[-1]):
            found["errors" if word.startswith("error") else word] += int(number)
    return found


def run(extra=()) -> dict:
    load = os.getloadavg()[0]
    start = time.perf_counter()
    proc = subprocess.run([*COMMAND, *extra], cwd=ROOT, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    return {"load": load, "seconds": seconds, "returncode": proc.returncode,
            "output": proc.stdout + proc.stderr, **counts(proc.stdout)}  # fmt: skip


def _minutes(seconds: float) -> str:
    return f"{seconds / 60:.1f} min"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--publish", action="store_true",
                        help="write the table to docs/generated (README and docs include it)")  # fmt: skip
    parser.add_argument("extra", nargs="*", help="further pytest arguments (after --)")
    args = parser.parse_args(argv)
    r = run(args.extra)
    tail = r["output"].strip().splitlines()[-15:]
    print("\n".join(tail))
    print(
        f"test suite: {r['seconds']:.0f} s wall ({_minutes(r['seconds'])}), "
        f"{r['passed']} passed, {r['skipped']} skipped, {r['failed']} failed, "
        f"{r['errors']} errors (pytest exit code {r['returncode']}); "
        f"load average at start {r['load']:.2f}"
    )
    if args.publish:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from generated_tables import publish_rows

        python = ".".join(map(str, sys.version_info[:2]))
        cells = [f"{r['load']:.2f}", python, _minutes(r["seconds"])]
        cells += [str(r[k]) for k in ("passed", "skipped", "failed", "errors")]
        command = "python benchmarks/bench_tests.py --publish"
        if args.extra:
            command = f"{command} -- {' '.join(args.extra)}"
        publish_rows("test_suite_time", HEADER, dict(zip(HEADER, cells)), command)
    return 0


if __name__ == "__main__":
    sys.exit(main())
