"""Why a transport loses power: the group difference it keeps against the spread it adds.

    python benchmarks/bench_spread.py --work WORK              # WORK of bench_population.py
    python benchmarks/bench_spread.py --work WORK --publish    # docs/generated/population_spread.md

Reads the studies of ``bench_population.py`` on the meshes in correspondence (40
subjects, 20 patients) and, per cohort (``hypokinesia_mild`` and ``twist`` by default)
and for every transport and ``alpha^2`` and the motion without transport, measures
over the planted region's vertices:

* the group difference: the mean over the region of ``|mean_patients - mean_controls|``
  of the displacement vectors (mm);
* the spread between subjects: the pooled within-group standard deviation of the
  displacement (the square root of the region's mean pooled variance, summed over the
  three coordinates; mm);
* their ratio, an effect size that sets the power of the per-vertex tests;
* the distance of the transported motion to the ideal transport (each subject's own
  motion parameters on the atlas's anatomy, :func:`~ladders.study.population.ideal_transport`):
  the median over the subjects of the mean vertex distance (mm), over all vertices.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_population import _cohort, _motions  # noqa: E402
from generated_tables import machine, publish  # noqa: E402

from ladders.study.population import ideal_transport, transport_error  # noqa: E402


def _label(m) -> str:
    if m.method == "none":
        return "no transport"
    prefix = "" if m.label.startswith(m.deformation.upper()) else f"{m.deformation.upper()} "
    return f"{prefix}{m.label}, alpha^2 = {m.alpha2:g}"


def spread_rows(work: Path, name: str) -> list[dict]:
    """One row per motion of the cohort ``name`` (arm ``corresponded``)."""
    data = _cohort(name, 40)
    ideal = ideal_transport(data)
    index = {s: i for i, s in enumerate(data.cohort.names)}
    region = data.region.affected
    rows = []
    for m in _motions(work, "corresponded", name):
        order = [index[s] for s in m.subjects]
        labels = np.array([data.groups[s] == "patients" for s in m.subjects])
        d = m.displacement[:, region]
        a, b = d[labels], d[~labels]
        difference = np.linalg.norm(a.mean(axis=0) - b.mean(axis=0), axis=1).mean()
        pooled = ((a - a.mean(axis=0)) ** 2).sum(axis=0) + ((b - b.mean(axis=0)) ** 2).sum(axis=0)
        pooled = np.sqrt((pooled.sum(axis=1) / (len(d) - 2)).mean())
        error = transport_error(m.displacement, ideal[order])
        rows.append({
            "label": _label(m),
            "difference": difference, "spread": pooled, "ideal": float(np.median(error)),
        })  # fmt: skip
    return rows


def table(rows: list[dict]) -> str:
    lines = [
        "| motion | group difference in the region (mm) | pooled SD in the region (mm) | "
        "difference / SD | distance to the ideal transport, median (mm) |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['label']} | {r['difference']:.2f} | {r['spread']:.2f} | "
            f"{r['difference'] / r['spread']:.2f} | {r['ideal']:.2f} |"
        )
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("symladders-output/bench_population"))
    parser.add_argument("--cohorts", nargs="+", default=["hypokinesia_mild", "twist"])
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    parts = []
    for name in args.cohorts:
        text = table(spread_rows(args.work, name))
        print(f"\n{name}\n{text}", flush=True)
        parts.append(f"**{name}** (40 subjects, 20 patients, meshes in correspondence)\n\n{text}")
    if args.publish:
        publish("population_spread", "\n".join(parts),
                "python benchmarks/bench_spread.py --work WORK --publish")  # fmt: skip


if __name__ == "__main__":
    main()
