"""Registration with fixed versus optimised control points (eq. 3 over ``c`` and ``mu``).

Run from the repository root::

    python benchmarks/bench_control_points.py [--max-iter 1000] [--alpha2 0.01,1,100]
    python benchmarks/bench_control_points.py --errors   # also the symmetry errors at 0.01
    python benchmarks/bench_control_points.py --ftol 1e-8  # a looser stopping test
    python benchmarks/bench_control_points.py --control-points vertices --sigma 10

Registers the atlas of the built-in 241-vertex synthetic cohort onto the
end-diastole shape of its first subject (by default sigma = 20 mm, the 45-point
grid, Euler, 10 steps, L-BFGS-B to ``ftol``) and prints, per ``alpha^2`` and per policy, the final
objective, the per-vertex RMS registration error (mm), the iterations, whether
L-BFGS-B met its tolerance, the wall time, and the number of iterations after
which the objective was within 1e-3 (relative) of its final value. With
``--errors`` it also prints the four symmetry errors of Section 3 (per-vertex
RMS, mm) with and without residuals at ``alpha^2 = 0.01``.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from ladders import symmetry_errors  # noqa: E402
from ladders.study.cohort.synthetic_lv import make_synthetic_cohort  # noqa: E402
from ladders.study.running.pipeline import StudyConfig, make_space  # noqa: E402
from manifolds import ResidualAugmented  # noqa: E402
from manifolds.errors import ConvergenceWarning  # noqa: E402


def _registration_row(space, t, s) -> str:
    start = time.perf_counter()
    reg = space.register(t, s)
    seconds = time.perf_counter() - start
    h = np.asarray(reg.history)
    near = int(np.argmax(h <= h.min() * (1 + 1e-3)))
    return (
        f"objective {reg.objective:10.5g}  rms {reg.rms_error:7.4f} mm  iters {reg.n_iter:5d}  "
        f"converged {reg.converged!s:5}  {seconds:6.2f} s  within 1e-3 after {near} iters"
    )


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-iter", type=int, default=1000)
    parser.add_argument("--alpha2", default="0.01,1,100")
    parser.add_argument("--ftol", type=float, default=None, help="L-BFGS-B ftol (default 1e-11)")
    parser.add_argument("--errors", action="store_true")
    parser.add_argument("--sigma", type=float, default=20.0)
    parser.add_argument(
        "--control-points", default="grid", choices=("grid", "vertices", "dense", "finegrid")
    )
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore", ConvergenceWarning)
    cohort = make_synthetic_cohort(n_subjects=1, n_vertices=241, seed=0)
    t, s, s2 = cohort.atlas, cohort.subjects[0].ed, cohort.subjects[0].es
    extra = {} if args.ftol is None else {"ftol": args.ftol}
    for a2 in (float(a) for a in args.alpha2.split(",")):
        for optimise in (False, True):
            config = StudyConfig.build(
                sigma=args.sigma,
                control_points=args.control_points,
                stopping="objective",
                max_iter=args.max_iter,
                optimize_control_points=optimise,
                **extra,
            )
            space = make_space(config, t, a2)
            label = "optimised" if optimise else "fixed    "
            print(f"alpha^2 = {a2:g}  {label}  {_registration_row(space, t, s)}")
            if args.errors and a2 == 0.01:
                for residuals in (True, False):
                    errs = symmetry_errors(ResidualAugmented(space, residuals), t, s, s2)
                    values = ", ".join(f"{k} {v:.4f}" for k, v in errs.as_dict().items())
                    print(f"    {'residual' if residuals else 'none    '}: {values}")


if __name__ == "__main__":
    main()
