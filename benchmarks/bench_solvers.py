"""Solvers, stopping rules and starts of the registrations, on the study's own problems.

For each control-point setting (the study's default: 143 points at the vertices,
``sigma = 10`` mm; 45 fixed grid points at ``sigma = 20`` mm, the same 45 optimised
with the momenta, the 270-point grid at ``sigma = 10`` mm, dense), two
subjects of the built-in cohort (1,009 vertices) and ``alpha^2`` in {0.01, 1, 100},
and for each combination of solver, stopping rule and start, it prints:

* for the registration of the atlas onto the subject: flow passes (FE: one forward
  shooting, one adjoint or one tangent-linear pass), wall time, iterations, final
  objective, and whether it converged under the objective rule (L-BFGS-B's
  ``ftol = 1e-11``, today's) and under the shape rule;
* for the subject's whole study pair (13 registrations): flow passes, and the
  largest relative deviation of its symmetry errors (four errors, two variants) and
  of all its cells from a tight-tolerance reference (``ftol = 1e-14``).

The combinations ``lbfgsb/<n>-iterations/cold`` run every registration for exactly
``n`` iterations: the summary then says where the pairs' cells settle against the
iteration count. Results are cached in ``--cache`` (JSON, one entry per row), so an interrupted run
resumes. ``--plot`` draws the convergence of one registration per setting: the
objective's gap to the reference, the largest gradient entry and the change of the
deformed template, against FE, per solver.

Usage: ``python benchmarks/bench_solvers.py [--settings a,b] [--alpha2 0.01,1]
[--subjects 2] [--combos a,b] [--no-pairs-for dense] [--plot out.png]``.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np

ALPHA2 = (0.01, 1.0, 100.0)
SHAPE_TOL = 1e-4
SETTINGS = {
    "vertices10": dict(sigma=10.0, control_points="vertices"),
    "grid45": dict(sigma=20.0, control_points="grid"),
    "opt45": dict(sigma=20.0, control_points="grid", optimize_control_points=True),
    "sigma10": dict(sigma=10.0, control_points="grid"),
    "dense": dict(sigma=20.0, control_points="dense"),
}
#: combination name -> (registration settings, symmetric warm start)
COMBOS = {
    "lbfgsb/objective/cold": (dict(solver="lbfgsb", stopping="objective", ftol=1e-11), False),
    "lbfgsb-scaled/objective/cold": (
        dict(solver="lbfgsb", stopping="objective", ftol=1e-11, joint_metric=False),
        False,
    ),
    "lbfgsb/shape/cold": (dict(solver="lbfgsb", stopping="shape", shape_tol=SHAPE_TOL), False),
    "lbfgsb/shape/warm": (dict(solver="lbfgsb", stopping="shape", shape_tol=SHAPE_TOL), True),
    # the shape rule's tolerance a decade looser and a decade tighter
    "lbfgsb/shape-1e-3/cold": (dict(solver="lbfgsb", stopping="shape", shape_tol=1e-3), False),
    "lbfgsb/shape-1e-5/cold": (dict(solver="lbfgsb", stopping="shape", shape_tol=1e-5), False),
    "gauss-newton/shape/cold": (
        dict(solver="gauss-newton", stopping="shape", shape_tol=SHAPE_TOL),
        False,
    ),
}
#: a fixed number of L-BFGS-B iterations for every registration of a pair (no tolerance
#: stops it earlier): where the study's cells settle against the iteration count
ITERATION_CAPS = (5, 10, 15, 20, 30, 40)
COMBOS.update(
    {
        f"lbfgsb/{n}-iterations/cold": (
            dict(solver="lbfgsb", stopping="objective", ftol=0.0, gtol=0.0, cap=n),
            False,
        )
        for n in ITERATION_CAPS
    }
)
REFERENCE = dict(solver="lbfgsb", stopping="objective", ftol=1e-14, gtol=1e-12)
#: combination used as "today's" run per setting (the scaled joint variables for opt45)
TODAY = {"opt45": "lbfgsb-scaled/objective/cold"}


def _cells(pair) -> dict:
    cells = {
        f"{e.variant}.{name}": getattr(e, name)
        for e in pair.errors
        for name in ("midpoint_distance", "centrality", "involutivity", "transvectivity")
    }
    cells.update(
        registration_error=pair.registration.error,
        registration_norm=pair.registration.rkhs_norm,
        inverse_consistency=pair.registration.inverse_consistency,
    )
    cells.update({f"{t.method}.ase": t.ase for t in pair.transports})
    return cells


def _deviation(cells: dict, reference: dict, symmetry_only: bool) -> float:
    keys = (
        [k for k in reference if "." in k and not k.endswith("ase")]
        if symmetry_only
        else list(reference)
    )
    return max(abs(cells[k] - reference[k]) / max(abs(reference[k]), 1e-300) for k in keys)


def _settings(setting: str, overrides: dict, max_iter: int):
    from ladders.study.running.pipeline import DEFAULT_REGISTRATION

    overrides = dict(overrides)
    cap = overrides.pop("cap", None)  # an iteration cap of the combination wins over --max-iter
    fields = {**SETTINGS[setting], **overrides, "max_iter": cap or max_iter}
    return DEFAULT_REGISTRATION.replace(**fields)


def _pair(cohort, subject, alpha2, settings, warm):
    from ladders.study.running.pipeline import StudyConfig, compute_pair

    config = StudyConfig(registration=settings, alpha2=(alpha2,), warm_starts=warm)
    start = time.perf_counter()
    pair = compute_pair(config, cohort.atlas, cohort.faces, cohort.subjects[subject], alpha2)
    return pair, time.perf_counter() - start


def _registration(cohort, subject, alpha2, settings):
    from manifolds.lddmm import register
    from manifolds.numerics.solvers import StoppingRule

    start = time.perf_counter()
    res = register(cohort.atlas, cohort.subjects[subject].ed, np.sqrt(alpha2), settings, warn=False)
    seconds = time.perf_counter() - start
    old = StoppingRule("objective", ftol=1e-11, gtol=1e-9)
    new = StoppingRule("shape", shape_tol=SHAPE_TOL)
    return {
        "fe": res.n_flow_evaluations,
        "seconds": seconds,
        "iterations": res.n_iter,
        "objective": res.objective,
        "converged_objective_rule": old.met_by_trace(res.trace),
        "converged_shape_rule": new.met_by_trace(res.trace),
        "trace": [
            [r.flow_passes, r.objective, r.gradient, r.shape_change, r.predicted_change]
            for r in res.trace
        ],
    }


def run_row(cache: dict, key: str, compute):
    if key not in cache:
        cache[key] = compute()
    return cache[key]


def bench(args, cache: dict, save) -> list[dict]:
    from ladders.study import make_synthetic_cohort

    cohort = make_synthetic_cohort(max(args.subjects) + 1, seed=0)
    rows = []
    for setting in args.settings:
        for alpha2 in args.alpha2:
            for subject in args.subjects:
                pairs = setting not in args.no_pairs_for
                base = f"{setting}/{alpha2:g}/{subject}"
                ref = None
                if pairs:
                    ref_settings = _settings(setting, REFERENCE, args.reference_max_iter)
                    ref = run_row(cache, f"{base}/reference", lambda s=ref_settings, a=alpha2,
                                  j=subject: _pair_row(cohort, j, a, s, False))  # fmt: skip
                    save()
                for combo in args.combos:
                    if combo.startswith("lbfgsb-scaled") and setting != "opt45":
                        continue
                    overrides, warm = COMBOS[combo]
                    combo_pairs = pairs and combo not in args.no_pairs_for_combos
                    if warm and not combo_pairs:
                        continue
                    settings = _settings(setting, overrides, args.max_iter)
                    reg = run_row(cache, f"{base}/{combo}/registration", lambda s=settings,
                                  a=alpha2, j=subject: _registration(cohort, j, a, s))  # fmt: skip
                    save()
                    row = {"setting": setting, "alpha2": alpha2, "subject": subject,
                           "combo": combo, **{k: v for k, v in reg.items() if k != "trace"}}  # fmt: skip
                    if combo_pairs:
                        pair = run_row(cache, f"{base}/{combo}/pair", lambda s=settings, a=alpha2,
                                       j=subject, w=warm: _pair_row(cohort, j, a, s, w))  # fmt: skip
                        save()
                        row.update(
                            pair_fe=pair["fe"],
                            pair_seconds=pair["seconds"],
                            symmetry_deviation=_deviation(pair["cells"], ref["cells"], True),
                            cell_deviation=_deviation(pair["cells"], ref["cells"], False),
                            reference_pair_fe=ref["fe"],
                            cells=pair["cells"],
                        )
                    rows.append(row)
                    print(_format(row), flush=True)
    return rows


def _pair_row(cohort, subject, alpha2, settings, warm) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pair, seconds = _pair(cohort, subject, alpha2, settings, warm)
    return {"cells": _cells(pair), "fe": pair.counts.n_flow_evaluations, "seconds": seconds,
            "non_converged": pair.counts.non_converged}  # fmt: skip


def _format(r: dict) -> str:
    text = (
        f"| {r['setting']} | {r['alpha2']:g} | {r['subject']} | {r['combo']} | {r['fe']} | "
        f"{r['seconds']:.1f} s | {r['iterations']} | {r['objective']:.6g} | "
        f"{'y' if r['converged_objective_rule'] else 'n'} / "
        f"{'y' if r['converged_shape_rule'] else 'n'} |"
    )
    if "pair_fe" in r:
        text += (
            f" {r['pair_fe']} (ref {r['reference_pair_fe']}) | {r['symmetry_deviation']:.2%} | "
            f"{r['cell_deviation']:.2%} |"
        )
    else:
        text += " - | - | - |"
    return text


def summary(rows: list[dict]) -> list[str]:
    """Per setting and combination: FE of the pairs against today's run, worst deviation."""
    out = []
    for setting in dict.fromkeys(r["setting"] for r in rows):
        today = TODAY.get(setting, "lbfgsb/objective/cold")
        mine = [r for r in rows if r["setting"] == setting]
        base = {(r["alpha2"], r["subject"]): r for r in mine if r["combo"] == today}
        for combo in dict.fromkeys(r["combo"] for r in mine):
            these = [r for r in mine if r["combo"] == combo and (r["alpha2"], r["subject"]) in base]
            key = "pair_fe" if all("pair_fe" in r for r in these) else "fe"
            fe = sum(r[key] for r in these)
            fe_today = sum(base[(r["alpha2"], r["subject"])][key] for r in these)
            worst = max((r.get("cell_deviation", float("nan")) for r in these), default=np.nan)
            out.append(
                f"{setting:8s} {combo:30s} {key}: {fe} ({fe_today / max(fe, 1):.2f}x fewer than "
                f"{today}), worst cell deviation {worst:.2%}"
            )
        out.extend(_tightening(mine))
        out.extend(_settling(mine))
    return out


def _settling(rows: list[dict]) -> list[str]:
    """Per iteration cap, the largest deviation of any pair cell from the reference, and
    the share of the cells within 1 % of it."""
    out = []
    for n in ITERATION_CAPS:
        these = [r for r in rows if r["combo"] == f"lbfgsb/{n}-iterations/cold" and "cells" in r]
        if not these:
            continue
        out.append(
            f"  {n:3d} iterations per registration: pair FE {sum(r['pair_fe'] for r in these)}, "
            f"largest cell deviation {max(r['cell_deviation'] for r in these):.2%}, cells within "
            f"1 % in {np.mean([r['cell_deviation'] < 0.01 for r in these]):.0%} of the pairs"
        )
    return out


def _tightening(rows: list[dict]) -> list[str]:
    """Largest change of any pair cell when the shape rule is tightened tenfold."""
    cells = {(r["combo"], r["alpha2"], r["subject"]): r["cells"] for r in rows if "cells" in r}
    out = []
    for loose, tight in (
        ("lbfgsb/shape-1e-3/cold", "lbfgsb/shape/cold"),
        ("lbfgsb/shape/cold", "lbfgsb/shape-1e-5/cold"),
    ):
        pairs = [
            (k[1:], c, cells[(tight, *k[1:])])
            for k, c in cells.items()
            if k[0] == loose and (tight, *k[1:]) in cells
        ]
        if not pairs:
            continue
        worst = max(pairs, key=lambda p: _deviation(p[1], p[2], False))
        out.append(
            f"  {loose} -> {tight}: largest cell change {_deviation(worst[1], worst[2], False):.2%}"
            f" (alpha^2 {worst[0][0]:g}, subject {worst[0][1]}) over {len(pairs)} pairs"
        )
    return out


def plot(cache: dict, path: Path, settings, alpha2: float, subject: int = 0) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(settings), 3, figsize=(12, 3.2 * len(settings)), squeeze=False)
    for row, setting in enumerate(settings):
        runs = {
            k.split("/")[3] + "/" + k.split("/")[4] + "/" + k.split("/")[5]: v
            for k, v in cache.items()
            if k.startswith(f"{setting}/{alpha2:g}/{subject}/") and k.endswith("/registration")
        }
        if not runs:
            continue
        best = min(min(t[1] for t in v["trace"]) for v in runs.values() if v["trace"])
        for combo, v in runs.items():
            tr = np.array(v["trace"], dtype=float)
            if tr.size == 0:
                continue
            fe = tr[:, 0]
            gap = np.maximum(tr[:, 1] - best, 1e-16) / best
            for ax, y in zip(axes[row], (gap, tr[:, 2], tr[:, 3])):
                ax.loglog(fe, y, label=combo, lw=1)
        titles = ("objective gap to the best (relative)", "largest gradient entry",
                  "phi_1(T) change per iteration (mm)")  # fmt: skip
        for ax, title in zip(axes[row], titles):
            ax.set_title(f"{setting}, alpha^2 = {alpha2:g}: {title}", fontsize=8)
            ax.set_xlabel("flow passes (FE)")
            ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        axes[row][2].axhline(SHAPE_TOL, color="k", ls=":", lw=0.8)
        axes[row][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--settings", default=",".join(SETTINGS))
    parser.add_argument("--alpha2", default=",".join(f"{a:g}" for a in ALPHA2))
    parser.add_argument("--subjects", type=int, default=2)
    parser.add_argument("--combos", default=",".join(COMBOS))
    parser.add_argument("--no-pairs-for", default="dense", help="settings without pair cells")
    parser.add_argument(
        "--no-pairs-for-combos",
        default="gauss-newton/shape/cold",
        help="combinations measured on the registration alone (no pair cells)",
    )
    parser.add_argument("--max-iter", type=int, default=5000)
    parser.add_argument("--reference-max-iter", type=int, default=20000)
    parser.add_argument("--cache", type=Path, default=Path("symladders-output/bench_solvers.json"))
    parser.add_argument("--plot", type=Path, default=None)
    parser.add_argument("--plot-alpha2", type=float, default=0.01)
    args = parser.parse_args(argv)
    args.settings = [s for s in args.settings.split(",") if s]
    args.combos = [c for c in args.combos.split(",") if c]
    args.alpha2 = [float(a) for a in args.alpha2.split(",") if a]
    args.subjects = list(range(args.subjects))
    args.no_pairs_for = set(filter(None, args.no_pairs_for.split(",")))
    args.no_pairs_for_combos = set(filter(None, args.no_pairs_for_combos.split(",")))
    for name, known in (("settings", SETTINGS), ("combos", COMBOS)):
        unknown = sorted(set(getattr(args, name)) - set(known))
        if unknown:
            parser.error(f"--{name}: unknown {unknown}; choose from {sorted(known)}")
    args.cache.parent.mkdir(parents=True, exist_ok=True)
    cache = json.loads(args.cache.read_text()) if args.cache.exists() else {}

    def save():
        tmp = args.cache.with_suffix(".tmp")
        tmp.write_text(json.dumps(cache))
        tmp.replace(args.cache)

    print(
        f"alpha^2 = {args.alpha2}, subjects {args.subjects}, shape rule {SHAPE_TOL:g} mm; "
        "wall times on the shared 2-core machine"
    )
    print(
        "| setting | alpha^2 | subject | solver/rule/start | FE | time | iterations | objective | "
        "converged (objective / shape rule) | pair FE | symmetry-error deviation | "
        "cell deviation |"
    )
    print("| --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | --- | ---: | ---: | ---: |")
    rows = bench(args, cache, save)
    print()
    for line in summary(rows):
        print(line)
    if args.plot:
        plot(cache, args.plot, args.settings, args.plot_alpha2)
        print(f"convergence plot: {args.plot}")


if __name__ == "__main__":
    main()
