"""Analytic validation of the ladders and symmetry estimators (``symladders validate``).

Runs the generic algorithms on spaces where the answer is known:

* closed-form symmetric spaces (S^2, S^5, H^3, SPD(3)): one-rung pole ladder
  against exact parallel transport, transvectivity at round-off;
* convergence orders measured as log-log slopes: Schild's ladder with
  ``scaling_exponent`` 1 and 2, pole ladder on the non-symmetric warped
  surface against the ODE transport reference;
* transvectivity on the warped surface against the size ``h`` of the vectors
  (order ``h^4``);
* the Poincare half-plane (ODE geodesics) against the closed-form hyperbolic plane.

The result is printed as a table and written to an output folder: a JSON file
of all numbers, a Markdown table and a log-log convergence plot (PNG).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from manifolds.hyperbolic import Hyperbolic
from manifolds.hypersphere import Hypersphere
from manifolds.poincare_half_plane import PoincareHalfPlane
from manifolds.spd import SPDMatrices
from manifolds.warped_surface import WarpedSurface

from ..convergence import ConvergenceCurve, ladder_convergence, loglog_slope
from ..pole_ladder import pole_ladder
from ..schild_ladder import schild_ladder
from ..symmetry_errors import transvectivity_error
from ..transvection_expansion import transvection_expansion

__all__ = ["ValidationReport", "run_validation", "plot_convergence"]


@dataclass
class ValidationReport:
    """Numbers produced by :func:`run_validation`."""

    exactness: dict = field(default_factory=dict)
    curves: list = field(default_factory=list)
    transvectivity: dict = field(default_factory=dict)
    half_plane: dict = field(default_factory=dict)
    seconds: float = 0.0

    def as_dict(self) -> dict:
        return {
            "exactness": self.exactness,
            "curves": [
                {
                    "label": c.label,
                    "n_rungs": c.n_rungs.tolist(),
                    "errors": c.errors.tolist(),
                    "slope": c.slope,
                }
                for c in self.curves
            ],
            "transvectivity": self.transvectivity,
            "half_plane": self.half_plane,
            "seconds": self.seconds,
        }

    def to_markdown(self) -> str:
        lines = ["## One-rung pole ladder and transvectivity on symmetric spaces", ""]
        lines += ["| space | max rel. error pole ladder vs transport | max transvectivity |"]
        lines += ["|---|---|---|"]
        for name, row in self.exactness.items():
            lines.append(f"| {name} | {row['pole_ladder']:.2e} | {row['transvectivity']:.2e} |")
        lines += ["", "## Convergence orders (log-log slopes)", ""]
        lines += ["| scheme | space | n | errors | slope |", "|---|---|---|---|---|"]
        for c in self.curves:
            errs = ", ".join(f"{e:.2e}" for e in c.errors)
            ns = ", ".join(str(int(n)) for n in c.n_rungs)
            scheme, _, space = c.label.partition(" on ")
            lines.append(f"| {scheme} | {space} | {ns} | {errs} | {c.slope:+.2f} |")
        t = self.transvectivity
        if t:
            lines += ["", "## Transvectivity on the warped surface (non-symmetric)", ""]
            lines += [
                "| h | transvectivity error | rel. error of the nabla R leading term "
                "| same, paper's printed form |",
                "|---|---|---|---|",
            ]
            rows = zip(
                t["h"],
                t["errors"],
                t["nabla_r_rel_error"],
                t["nabla_r_rel_error_printed_form"],
                strict=True,
            )
            lines += [f"| {h:g} | {e:.3e} | {r:.2e} | {p:.2e} |" for h, e, r, p in rows]
            lines += [
                "",
                f"Measured order in h: {t['slope']:.2f} (expected 4). Leading term "
                "u' - u'' = 1/12 [10 (nabla_v R)(u,v)u + 2 (nabla_u R)(u,v)v].",
            ]
        if self.half_plane:
            lines += ["", "## Poincare half-plane (ODE) vs closed-form hyperbolic plane", ""]
            lines += [f"Max distance discrepancy: {self.half_plane['max_dist_error']:.2e}"]
        lines += ["", f"Total time: {self.seconds:.1f} s"]
        return "\n".join(lines)


def _exactness(rng: np.random.Generator, n_trials: int) -> dict:
    spaces = {
        "S^2": Hypersphere(2),
        "S^5": Hypersphere(5),
        "H^3": Hyperbolic(3),
        "SPD(3)": SPDMatrices(3),
    }
    out = {}
    for name, space in spaces.items():
        worst_ladder = worst_trans = 0.0
        for _ in range(n_trials):
            s = space.random_point(rng)
            t = space.exp(s, space.random_tangent(s, rng, scale=0.8))
            u = space.random_tangent(s, rng, scale=0.5)
            s2 = space.exp(s, u)
            exact = space.parallel_transport(s, t, u)
            ladder = pole_ladder(space, s, t, u)
            rel = np.linalg.norm(ladder - exact) / np.linalg.norm(exact)
            worst_ladder = max(worst_ladder, float(rel))
            worst_trans = max(worst_trans, float(transvectivity_error(space, t, s, s2)))
        out[name] = {"pole_ladder": worst_ladder, "transvectivity": worst_trans}
    return out


def _curves(rng: np.random.Generator, quick: bool) -> list[ConvergenceCurve]:
    curves = []
    ns = (4, 8, 16, 32) if quick else (4, 8, 16, 32, 64)
    for name, space in (("S^2", Hypersphere(2)), ("SPD(3)", SPDMatrices(3))):
        s = space.random_point(rng)
        t = space.exp(s, space.random_tangent(s, rng, scale=1.0))
        u = space.random_tangent(s, rng, scale=0.7)
        exact = space.parallel_transport(s, t, u)
        for a in (1.0, 2.0):
            curves.append(
                ladder_convergence(
                    space, schild_ladder, s, t, u, exact, ns, a, f"Schild a={a:g} on {name}"
                )
            )
    warped = WarpedSurface()
    s = np.array([0.5, 0.0])
    t = warped.exp(s, np.array([0.6, 0.8]))
    u = np.array([-0.3, 0.4])
    exact = warped.parallel_transport(s, t, u)
    ns_w = (1, 2, 4, 8) if quick else (1, 2, 4, 8, 16)
    curves.append(
        ladder_convergence(warped, pole_ladder, s, t, u, exact, ns_w, 1.0, "pole a=1 on warped")
    )
    return curves


def _transvectivity_warped(quick: bool) -> dict:
    warped = WarpedSurface()
    m = np.array([0.5, 0.0])
    a, b = np.array([0.6, 0.8]), np.array([-0.28, 0.96])
    hs = (0.2, 0.1, 0.05) if quick else (0.2, 0.1, 0.05, 0.025)
    printed = np.array([10.0, -1.0, -4.0, 0.0])  # u' - u'' as printed in the paper
    errors, rel_derived, rel_printed = [], [], []
    for h in hs:
        t = m
        s = warped.exp(t, h * a / warped.norm(t, a))
        s2 = warped.exp(s, h * b / warped.norm(s, b))
        errors.append(float(transvectivity_error(warped, t, s, s2)))
        expansion = transvection_expansion(warped, t, s, s2)
        measured = expansion.pole_deviation - expansion.opposite_deviation
        rel_derived.append(expansion.relative_error("transvectivity"))
        rel_printed.append(
            float(np.linalg.norm(expansion.terms @ printed - measured) / np.linalg.norm(measured))
        )
    return {
        "h": list(hs),
        "errors": errors,
        "slope": loglog_slope(hs, errors),
        "nabla_r_rel_error": rel_derived,
        "nabla_r_rel_error_printed_form": rel_printed,
    }


def _half_plane(rng: np.random.Generator, n_trials: int) -> dict:
    space = PoincareHalfPlane()
    worst = 0.0
    for _ in range(n_trials):
        p = space.random_point(rng)
        q = space.exp(p, space.random_tangent(p, rng, scale=0.8))
        closed = np.arccosh(1.0 + np.sum((p - q) ** 2) / (2.0 * p[1] * q[1]))
        worst = max(worst, abs(float(space.dist(p, q)) - float(closed)))
    return {"max_dist_error": worst}


def _log_ticks(ax, axis: str, values) -> None:
    """Major ticks at ``values`` only, labelled plainly; no minor labels (they overlap)."""
    from matplotlib.ticker import FixedLocator, NullFormatter, NullLocator

    which = ax.xaxis if axis == "x" else ax.yaxis
    which.set_major_locator(FixedLocator(sorted(values)))
    which.set_major_formatter(lambda v, _: f"{v:g}")
    which.set_minor_locator(NullLocator())
    which.set_minor_formatter(NullFormatter())


def plot_convergence(curves: list[ConvergenceCurve], transvectivity: dict):
    """The validation figure: (a) ladders against exact transport, (b) transvectivity.

    Returns the matplotlib figure (:func:`run_validation` saves it as ``convergence.png``).
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    for c in curves:
        axes[0].loglog(c.n_rungs, c.errors, "o-", label=f"{c.label} (slope {c.slope:+.2f})")
    _log_ticks(axes[0], "x", {int(n) for c in curves for n in c.n_rungs})
    axes[0].set_title("(a) Ladders against exact parallel transport", fontsize=11)
    axes[0].set_xlabel("number of rungs n")
    axes[0].set_ylabel("relative error vs exact transport")
    axes[0].legend(
        fontsize=7,
        title="a: scaling exponent of the rungs\n(vector scaled by 1/n^a, transported\n"
        "n times, scaled back by n^a)",
        title_fontsize=7,
    )
    axes[0].grid(True, which="major", alpha=0.3)
    if transvectivity:
        h, e = transvectivity["h"], transvectivity["errors"]
        axes[1].loglog(h, e, "s-", label=f"warped surface (slope {transvectivity['slope']:.2f})")
        ref = e[0] * (np.asarray(h) / h[0]) ** 4
        axes[1].loglog(h, ref, "k--", label="h^4")
        _log_ticks(axes[1], "x", h)
        axes[1].set_title("(b) Transvectivity on the warped surface", fontsize=11)
        axes[1].set_xlabel("size h of the vectors")
        axes[1].set_ylabel("transvectivity error")
        axes[1].legend(fontsize=8)
        axes[1].grid(True, which="major", alpha=0.3)
    fig.tight_layout()
    return fig


def _plot(curves: list[ConvergenceCurve], transvectivity: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plot_convergence(curves, transvectivity)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def run_validation(output_dir: str | Path, seed: int = 0, quick: bool = False) -> ValidationReport:
    """Run the analytic validation and write ``validation.json``, ``validation.md`` and ``convergence.png``.

    Parameters
    ----------
    output_dir : path
        Folder created if needed.
    seed : int
        Seed of the random configurations.
    quick : bool
        Fewer trials and rungs (used by the tests).
    """
    start = time.perf_counter()
    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    report = ValidationReport()
    report.exactness = _exactness(rng, 5 if quick else 20)
    report.curves = _curves(rng, quick)
    report.transvectivity = _transvectivity_warped(quick)
    report.half_plane = _half_plane(rng, 2 if quick else 5)
    report.seconds = time.perf_counter() - start
    (out / "validation.json").write_text(json.dumps(report.as_dict(), indent=2))
    (out / "validation.md").write_text(report.to_markdown() + "\n")
    _plot(report.curves, report.transvectivity, out / "convergence.png")
    return report
