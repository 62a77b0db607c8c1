"""Side-by-side benchmark against Deformetrica 4.3.0 on one landmark registration.

The problem is ``bench_registration.py``'s: the 642-vertex icosphere scaled to semi-axes
(1, 0.7, 0.5) onto ``bent_ellipsoid(3, twist=0.4, bend=0.2)``, Gaussian kernel
``exp(-|x - y|^2 / sigma^2)`` with sigma = 0.5, 10 explicit Euler steps (Deformetrica:
11 time points, RK2 off for shoot and flow), point-to-point squared distances
(Deformetrica's ``Landmark`` object), alpha = noise_std = 0.02, 100 L-BFGS-B
iterations, frozen control points: ``grid`` (the project's 45 grid points, given to
Deformetrica as a file) or ``dense`` (the 642 vertices; Deformetrica's ``dense_mode``).

Deformetrica minimises ``SSE / alpha^2 + <mu, K mu>``; the project ``SSE + alpha^2
<mu, K mu>``: every objective below is in the project's units (Deformetrica's times
alpha^2). Each side's final momenta are re-evaluated by the other side's code as a check
that both compute the same objective. Printed per case: wall time of 100 iterations
(project: best of ``--repeats`` after a numba warm-up; Deformetrica: best of
``--repeats`` of its estimator loop, the ``scipy.optimize.minimize`` call, without
start-up, file reading or output), objective/gradient evaluations, time per evaluation,
the ratio, and the time each side needs to reach Deformetrica's 100-iteration objective.
Deformetrica runs on its torch kernel (pykeops 1.4.1 does not install here) in float64
(``--dfm-dtype float32``: its default), with its L-BFGS-B defaults (memory 10,
``--dfm-memory``; 10 line-search steps), zero initial momenta, its convergence tolerance
set to 1e-30 so that it does all 100 iterations, and no intermediate output; the project
uses its defaults (memory 100, preconditioned momenta, linearised start). Both sides use
2 threads (torch; numba). The CPU-seconds used by other processes during each case and
each Deformetrica run are printed: timings with a busy neighbour are worthless.

Installing Deformetrica (it pins torch 1.6, which has no Python 3.11 build)::

    python3 -m venv dfm-venv
    dfm-venv/bin/pip install torch==2.13.0                # a CPU build
    dfm-venv/bin/pip install --no-deps deformetrica==4.3.0
    dfm-venv/bin/pip install numpy scipy scikit-learn matplotlib nibabel pillow psutil vtk

Compatibility patches, applied in the worker process only (site-packages untouched):
a stub ``pykeops`` module (its kernel class is imported but not used), a stub
``deformetrica.gui`` (it needs PyQt5 and ``pkg_resources``), and a wrapper around the
estimator's ``scipy.optimize.minimize`` that times it and gives ``result.message`` the
``bytes`` type that Deformetrica decodes.

Usage (from the project's environment): ``python benchmarks/bench_deformetrica.py
--deformetrica-python dfm-venv/bin/python [--case grid|dense|both] [--repeats 3] [--dfm-dtype float64|float32]
[--dfm-memory 10] [--json out.json] [--publish]``; ``--publish`` writes
``docs/generated/deformetrica.md`` (refused when other processes disturbed a case).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ALPHA, SIGMA, N_STEPS, MAX_ITER, THREADS = 0.02, 0.5, 10, 100, 2


def problem(case: str):
    """Template, target and control points of ``case`` ("grid" or "dense")."""
    from ladders.study.cohort.benchmark_shapes import bent_ellipsoid
    from manifolds.lddmm.control_points import resolve_control_points

    template, target, _ = bent_ellipsoid(3, twist=0.4, bend=0.2)
    cp = resolve_control_points(template, "grid", SIGMA) if case == "grid" else template.copy()
    return template, target, cp


# ---------------------------------------------------------------- Deformetrica side
def _write_vtk(path: Path, points: np.ndarray) -> None:
    lines = ["# vtk DataFile Version 3.0", "points", "ASCII", "DATASET POLYDATA"]
    lines.append(f"POINTS {len(points)} double")
    lines += [" ".join(f"{v:.17g}" for v in p) for p in points]
    path.write_text("\n".join(lines) + "\n")


def _patch_deformetrica():
    """Import Deformetrica 4.3.0 on today's torch/scipy; return (module, timing record)."""
    import types

    keops = types.ModuleType("pykeops")
    keops.torch = types.ModuleType("pykeops.torch")
    keops.torch.Genred = None
    sys.modules.update({"pykeops": keops, "pykeops.torch": keops.torch})
    sys.modules["deformetrica.gui"] = types.ModuleType("deformetrica.gui")
    import deformetrica
    from deformetrica.core.estimators import scipy_optimize

    record: dict = {}
    inner = scipy_optimize.minimize

    def timed_minimize(*args, **kwargs):
        t0 = time.perf_counter()
        res = inner(*args, **kwargs)
        record.update(t0=t0, seconds=time.perf_counter() - t0, nit=int(res.nit), nfev=int(res.nfev))
        res.message = str(res.message).encode()  # Deformetrica calls message.decode()
        return res

    scipy_optimize.minimize = timed_minimize
    return deformetrica, record


def deformetrica_worker(npz: str, out: str, repeats: int) -> None:
    """Run the registration with Deformetrica (in its own interpreter); write JSON to ``out``."""
    import torch

    torch.set_num_threads(THREADS)
    deformetrica, record = _patch_deformetrica()
    from deformetrica.core import GpuMode
    from deformetrica.core.model_tools.deformations.exponential import Exponential
    from deformetrica.support.kernels.torch_kernel import TorchKernel

    data = np.load(npz)
    case = str(data["case"])
    tmp = Path(out).parent  # the driver's temporary folder
    _write_vtk(tmp / "template.vtk", data["template"])
    _write_vtk(tmp / "target.vtk", data["target"])
    np.savetxt(tmp / "cp.txt", data["cp"], fmt="%.17g")
    runs, dtypes = [], set()
    for _ in range(repeats):
        trace: list = []

        def callback(info, trace=trace):  # called at every cost-and-gradient evaluation
            trace.append((time.perf_counter(), -float(info["current_log_likelihood"])))
            dtypes.add(str(info["gradient"]["momenta"].dtype))
            return True

        template = {"shape": {"deformable_object_type": "Landmark", "noise_std": ALPHA,
                              "filename": str(tmp / "template.vtk"), "attachment_type": "Landmark"}}  # fmt: skip
        dataset = {"dataset_filenames": [[{"shape": str(tmp / "target.vtk")}]],
                   "subject_ids": ["target"], "visit_ages": [[]]}  # fmt: skip
        model = {"dimension": 3, "dtype": str(data["dtype"]), "deformation_kernel_type": "torch",
                 "deformation_kernel_width": SIGMA, "number_of_time_points": N_STEPS + 1,
                 "use_rk2_for_shoot": False, "use_rk2_for_flow": False,
                 "freeze_control_points": True, "number_of_processes": 1}  # fmt: skip
        if case == "dense":
            model["dense_mode"] = True  # control points = template vertices, frozen
        else:
            model["initial_control_points"] = str(tmp / "cp.txt")
        estimator = {"optimization_method_type": "ScipyLBFGS", "max_iterations": MAX_ITER,
                     "convergence_tolerance": 1e-30, "memory_length": int(data["memory"]),
                     "save_every_n_iters": 10**9,
                     "print_every_n_iters": 10**9, "callback": callback,
                     "gpu_mode": GpuMode.NONE, "state_file": str(tmp / "state.p")}  # fmt: skip
        others = other_cpu_seconds()
        dfm = deformetrica.Deformetrica(output_dir=str(tmp / "out"), verbosity="WARNING")
        fitted = dfm.estimate_registration(template, dataset, model, estimator, write_output=False)
        momenta = np.asarray(fitted.get_momenta(), dtype=float).reshape(data["cp"].shape)
        trace = [(t - record["t0"], c) for t, c in trace]
        others = max(other_cpu_seconds() - others, 0.0)  # CPU-s of other processes during the run
        runs.append(dict(record, trace=trace, momenta=momenta.tolist(), others=others))
    best = min(runs, key=lambda r: r["seconds"])
    # Deformetrica's own objective at the project's final momenta (its Exponential, float64).
    kernel = TorchKernel(gpu_mode=GpuMode.NONE, kernel_width=SIGMA)
    flow = Exponential(kernel=kernel, number_of_time_points=N_STEPS + 1)
    as_t = lambda a: torch.tensor(np.asarray(a), dtype=torch.float64)  # noqa: E731
    flow.set_initial_template_points({"landmark_points": as_t(data["template"])})
    flow.set_initial_control_points(as_t(data["cp"]))
    flow.set_initial_momenta(as_t(data["project_momenta"]))
    flow.update()
    deformed = flow.get_template_points()["landmark_points"].numpy()
    sse = float(((deformed - data["target"]) ** 2).sum())
    check = sse / ALPHA**2 + float(flow.get_norm_squared())
    result = dict(case=case, runs=[(r["seconds"], r["others"]) for r in runs], best=best, check_cost=check,
                  torch=torch.__version__, threads=torch.get_num_threads(), dtypes=sorted(dtypes))  # fmt: skip
    Path(out).write_text(json.dumps(result))


# ---------------------------------------------------------------- project side
def _register(case_data, max_iter, repeats):
    """Best wall time of ``repeats`` project registrations and the last result."""
    from manifolds.lddmm.registration import register
    from manifolds.lddmm.settings import RegistrationSettings

    template, target, cp, kernel = case_data
    settings = RegistrationSettings(sigma=SIGMA, integrator="euler", max_iter=max_iter)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = register(
            template, target, ALPHA, settings, control_points=cp, kernel=kernel, warn=False
        )
        times.append(time.perf_counter() - t0)
    return min(times), res


def run_project(case: str, repeats: int) -> dict:
    from manifolds.lddmm.settings import RegistrationSettings

    template, target, cp = problem(case)
    kernel = RegistrationSettings(sigma=SIGMA).make_kernel()
    for n in (20, 300):  # load the compiled kernels (serial and parallel) as bench_registration
        sub = cp[:n] if len(cp) >= n else template[:n]
        _register((template[:n], target[:n], sub, kernel), 2, 1)
    data = (template, target, cp, kernel)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        seconds, res = _register(data, MAX_ITER, repeats)
    return dict(data=data, seconds=seconds, n_evals=res.n_evals, n_iter=res.n_iter,
                objective=res.objective, history=list(res.history), momenta=res.momenta,
                backend=kernel.__class__.__name__)  # fmt: skip


def project_time_to(proj: dict, goal: float, repeats: int):
    """(seconds, iterations) the project needs to reach objective ``goal`` (None if never)."""
    history, limit = proj["history"], MAX_ITER
    while min(history) > goal and limit < 3000:
        limit *= 3
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            history = list(_register(proj["data"], limit, 1)[1].history)
    k = next((i for i, h in enumerate(history) if h <= goal), None)
    if k is None:
        return None, None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return _register(proj["data"], max(k, 1), repeats)[0], k


# ---------------------------------------------------------------- driver
def machine() -> dict:
    """The shared machine line of the generated tables, and the project's kernel threads."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import numba
    from generated_tables import machine as machine_line

    return dict(line=machine_line(), numba_threads=numba.get_num_threads(),
                date=datetime.datetime.now().isoformat(timespec="seconds"))  # fmt: skip


def other_cpu_seconds() -> float:
    """CPU seconds used on the machine so far by processes other than this one and its children."""
    import resource

    ticks = [int(v) for v in Path("/proc/stat").read_text().split("\n")[0].split()[1:]]
    busy = (sum(ticks[:8]) - ticks[3] - ticks[4]) / os.sysconf("SC_CLK_TCK")  # minus idle, iowait
    mine = sum(getattr(resource.getrusage(who), f) for f in ("ru_utime", "ru_stime")
               for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))  # fmt: skip
    return busy - mine


def run_deformetrica(python: str, case: str, proj: dict, args) -> dict:
    template, target, cp, _ = proj["data"]
    with tempfile.TemporaryDirectory() as tmp:
        npz, out = Path(tmp) / "problem.npz", Path(tmp) / "out.json"
        np.savez(npz, case=case, template=template, target=target, cp=cp,
                 project_momenta=proj["momenta"], dtype=args.dfm_dtype, memory=args.dfm_memory)  # fmt: skip
        env = dict(os.environ, OMP_NUM_THREADS=str(THREADS), MKL_NUM_THREADS=str(THREADS))
        cmd = [python, str(Path(__file__).resolve()), "--worker", "deformetrica", "--npz", str(npz)]
        cmd += ["--out", str(out), "--repeats", str(args.repeats)]
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=tmp)
        if proc.returncode != 0 or not out.exists():
            sys.exit(
                f"The Deformetrica worker failed (exit {proc.returncode}):\n{proc.stderr[-3000:]}"
            )
        return json.loads(out.read_text())


def compare(case: str, proj: dict, dfm: dict, repeats: int) -> dict:
    from manifolds.lddmm.registration import registration_objective

    a2, best = ALPHA**2, dfm["best"]
    template, target, cp, kernel = proj["data"]
    dfm_final = a2 * best["trace"][-1][1]  # the last evaluation is at the final iterate
    project_at_dfm = registration_objective(kernel, template, target, cp, np.array(best["momenta"]),
                                            ALPHA, "euler", N_STEPS, with_gradient=False)[0]  # fmt: skip
    t_proj, k_proj = project_time_to(proj, dfm_final, repeats)
    t_dfm = next(t for t, c in best["trace"] if a2 * c <= dfm_final)
    t_dfm_proj = next((t for t, c in best["trace"] if a2 * c <= proj["objective"]), None)
    per_p, per_d = proj["seconds"] / proj["n_evals"], best["seconds"] / best["nfev"]
    return dict(case=case, n_cp=len(cp), project=dict(seconds=proj["seconds"], evals=proj["n_evals"],
                iterations=proj["n_iter"], per_eval=per_p, objective=proj["objective"],
                objective_by_deformetrica=a2 * dfm["check_cost"], backend=proj["backend"],
                time_to_dfm_final=t_proj, iterations_to_dfm_final=k_proj),
                deformetrica=dict(seconds=best["seconds"], all_runs=dfm["runs"], evals=best["nfev"],
                iterations=best["nit"], per_eval=per_d, objective=dfm_final,
                objective_by_project=project_at_dfm, time_to_own_final=t_dfm,
                time_to_project_objective=t_dfm_proj, dtypes=dfm["dtypes"], torch=dfm["torch"],
                threads=dfm["threads"]), ratio_per_eval=per_d / per_p)  # fmt: skip


def report(r: dict) -> str:
    p, d = r["project"], r["deformetrica"]
    fmt = lambda t: "not reached" if t is None else f"{t:.3f} s"  # noqa: E731
    return "\n".join([
        f"[{r['case']}] 642 vertices, {r['n_cp']} frozen control points; objective = SSE + alpha^2 <mu,K mu>",
        f"  {'':34}{'project':>16}{'Deformetrica':>16}",
        f"  {'wall time, 100 iterations (best)':34}{p['seconds']:>14.3f} s{d['seconds']:>14.3f} s",
        f"  {'iterations done':34}{p['iterations']:>16}{d['iterations']:>16}",
        f"  {'objective/gradient evaluations':34}{p['evals']:>16}{d['evals']:>16}",
        f"  {'time per evaluation':34}{1e3 * p['per_eval']:>13.2f} ms{1e3 * d['per_eval']:>13.2f} ms",
        f"  {'final objective':34}{p['objective']:>16.6g}{d['objective']:>16.6g}",
        f"  {'its momenta, other code objective':34}{p['objective_by_deformetrica']:>16.6g}{d['objective_by_project']:>16.6g}",
        f"  {'time to reach Deformetrica final':34}{fmt(p['time_to_dfm_final']):>16}{fmt(d['time_to_own_final']):>16}",
        f"  per-evaluation time ratio Deformetrica / project: {r['ratio_per_eval']:.2f}; project reaches "
        f"Deformetrica's final objective after {p['iterations_to_dfm_final']} iterations; Deformetrica "
        f"reaches the project's 100-iteration objective: {fmt(d['time_to_project_objective'])}",
    ])  # fmt: skip


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--deformetrica-python",
                        help="a Python interpreter with Deformetrica (see above); required")  # fmt: skip
    parser.add_argument("--case", default="both", choices=["grid", "dense", "both"])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--dfm-dtype", default="float64", choices=["float64", "float32"])
    parser.add_argument("--dfm-memory", type=int, default=10, help="Deformetrica's L-BFGS memory")
    parser.add_argument("--json", help="write the results to this file")
    parser.add_argument("--publish", action="store_true",
                        help="write docs/generated/deformetrica.md")  # fmt: skip
    parser.add_argument("--worker", choices=["deformetrica"], help=argparse.SUPPRESS)
    parser.add_argument("--npz", help=argparse.SUPPRESS)
    parser.add_argument("--out", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        deformetrica_worker(args.npz, args.out, args.repeats)
        return
    python = args.deformetrica_python
    if python is None:
        parser.error("--deformetrica-python is required (a Python with Deformetrica installed)")
    if not (Path(python).is_file() and os.access(python, os.X_OK)):
        sys.exit(f"Deformetrica interpreter not found: {python} (see this script's docstring).")
    info = machine()
    print(f"{info['date']}  {info['line']}; project: numba threads {info['numba_threads']}, "
          f"Python {platform.python_version()}")  # fmt: skip
    results = []
    for case in ["grid", "dense"] if args.case == "both" else [args.case]:
        others, wall = other_cpu_seconds(), time.perf_counter()
        proj = run_project(case, args.repeats)
        dfm = run_deformetrica(python, case, proj, args)
        results.append(compare(case, proj, dfm, args.repeats))
        others, wall = other_cpu_seconds() - others, time.perf_counter() - wall
        others = results[-1]["other_processes_cpu_s"] = max(others, 0.0)
        results[-1]["wall_s"] = wall
        print(f"Other processes used {others:.1f} CPU-seconds during this case ({wall:.0f} s "
              f"wall){': TIMINGS DISTURBED' if others > 0.05 * wall else ''}")  # fmt: skip
        d = results[-1]["deformetrica"]
        print(f"Deformetrica 4.3.0: torch {d['torch']}, {d['threads']} threads, {'/'.join(d['dtypes'])}, "
              f"torch kernel; its time is the scipy L-BFGS-B loop only ({len(d['all_runs'])} runs: "
              + ", ".join(f"{t:.2f} s (others {o:.1f} CPU-s)" for t, o in d["all_runs"]) + ")")  # fmt: skip
        print(report(results[-1]), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(dict(machine=info, results=results), indent=1))
    if args.publish:
        disturbed = [r["case"] for r in results if r["other_processes_cpu_s"] > 0.05 * r["wall_s"]]
        if disturbed:
            sys.exit(f"not published: other processes disturbed the case(s) {disturbed}")
        publish_table(results, args)


def publish_table(results: list, args) -> None:
    """``docs/generated/deformetrica.md``: one row per case."""
    from generated_tables import publish

    rows = []
    for r in results:
        p, d = r["project"], r["deformetrica"]
        rows.append(
            f"| {r['case']}, {r['n_cp']} control points | {p['seconds']:.2f} s / {d['seconds']:.2f} s | "
            f"{1e3 * p['per_eval']:.2f} ms / {1e3 * d['per_eval']:.1f} ms | "
            f"**{r['ratio_per_eval']:.1f}** | {p['objective']:.4g} / {d['objective']:.4g} | "
            f"{p['iterations_to_dfm_final']} iterations, {p['time_to_dfm_final']:.3f} s "
            f"({d['seconds'] / p['time_to_dfm_final']:.0f} times sooner) |"
        )  # fmt: skip
    d = results[0]["deformetrica"]
    note = (f"The registration of bench_registration.py (642 vertices, sigma 0.5, alpha 0.02, 10 "
            f"Euler steps, frozen control points, 100 L-BFGS-B iterations), project / Deformetrica "
            f"4.3.0 (torch {d['torch']} kernel, {'/'.join(d['dtypes'])}, {d['threads']} threads, "
            f"L-BFGS memory {args.dfm_memory}, zero start; its time is its optimiser loop), same "
            f"machine, same run; objectives in the project's units, SSE + alpha^2 <mu, K mu>.")  # fmt: skip
    header = ("| case | 100 iterations | per evaluation | Deformetrica / project per evaluation "
              "| objective at 100 iterations | the project reaches Deformetrica's 100-iteration "
              "objective after |\n|---|---|---|---|---|---|")  # fmt: skip
    cmd = "python benchmarks/bench_deformetrica.py --deformetrica-python PYTHON --publish"
    publish("deformetrica", note + "\n\n" + header + "\n" + "\n".join(rows), cmd)


if __name__ == "__main__":
    main()
