"""Adding a space, end to end: a subclass and a metric field, their checks, a mean and a PCA.

The space is the warped surface ``R^2`` with ``g = dx^2 + f(x)^2 dy^2``,
``f(x) = 1 + x^2`` (Gaussian curvature ``-2 / (1 + x^2)``, so ``nabla R != 0``), added
twice, by the two routes of ``docs/add_your_own_space.md``:

1. ``MyWarpedSurface``, a subclass of :class:`manifolds.RiemannianManifold` with
   ``exp`` (the geodesic ODE with hand-derived Christoffel symbols) and ``log``
   (Newton shooting), and the exact parallel transport;
2. ``metric_field_surface()``, the metric given to
   :class:`manifolds.metric_field.MetricField` (geodesics, ``log``, transport and
   curvature derived from it; its derivatives in closed form, ``metric_jet``, so
   that no automatic differentiation runs inside the geodesic ODE).

On each, the script runs the contract every space of the library meets
(:class:`manifolds.testing.ConnectionContract`, outside pytest with
:func:`manifolds.testing.run_contract`), the pole ladder's convergence against the exact
transport (:func:`ladders.ladder_convergence`: second order, a log-log slope near
``-2``), and computes the Frechet mean of a sample and its tangent PCA
(:func:`ladders.frechet_mean`, :func:`ladders.statistics.tangent_pca`). The two routes
give the same space: the script prints how far apart their means are.

Run ``python examples/add_a_space.py --output add_a_space.png``.
"""

from __future__ import annotations

import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")
import autograd.numpy as anp  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ladders import frechet_mean, ladder_convergence, pole_ladder  # noqa: E402
from ladders.statistics import tangent_pca  # noqa: E402
from manifolds.metric_field import MetricField  # noqa: E402
from manifolds.numerics.geodesic_ode import GeodesicIntegrator  # noqa: E402
from manifolds.numerics.shooting import ShootingSolver  # noqa: E402
from manifolds.riemannian import RiemannianManifold  # noqa: E402
from manifolds.testing import ConnectionContract, run_contract  # noqa: E402
from manifolds.validation import check_array  # noqa: E402


def christoffel(x):
    """``Gamma[k, i, j] = Gamma^k_ij`` of ``g = dx^2 + f(x)^2 dy^2`` with ``f = 1 + x^2``."""
    f, df = 1.0 + x[0] ** 2, 2.0 * x[0]
    gam = np.zeros((2, 2, 2))
    gam[0, 1, 1] = -f * df
    gam[1, 0, 1] = gam[1, 1, 0] = df / f
    return gam


def christoffel_jet(x):
    """``(Gamma, dGamma)`` with ``dGamma[k, i, j, l] = d_l Gamma^k_ij``."""
    f, df, d2f = 1.0 + x[0] ** 2, 2.0 * x[0], 2.0
    dgam = np.zeros((2, 2, 2, 2))
    dgam[0, 1, 1, 0] = -(df * df + f * d2f)
    dgam[1, 0, 1, 0] = dgam[1, 1, 0, 0] = d2f / f - (df / f) ** 2
    return christoffel(x), dgam


class MyWarpedSurface(RiemannianManifold):
    """``R^2`` with ``g = dx^2 + (1 + x^2)^2 dy^2`` (route 2: ``exp`` and ``log`` by hand)."""

    point_shape = (2,)

    def __init__(self):
        self.integrator = GeodesicIntegrator()  # DOP853, rtol = atol = 1e-12
        self.shooting = ShootingSolver()

    def _check(self, arr, name):
        return check_array(arr, self.point_shape, f"{self.name}: {name}")

    def exp(self, point, tangent):
        x, v = self._check(point, "point"), self._check(tangent, "tangent")
        return self.integrator.integrate(christoffel, x, v).position

    def log(self, point, other):
        x, y = self._check(point, "point"), self._check(other, "other")

        def exp_and_jacobian(v):
            sol = self.integrator.integrate(christoffel, x, v, christoffel_jet=christoffel_jet)
            return sol.position, sol.jacobian

        return self.shooting.solve(exp_and_jacobian, x, y)

    def inner(self, point, u, v):
        f = 1.0 + point[0] ** 2
        return u[0] * v[0] + f * f * u[1] * v[1]

    def random_point(self, rng, n_samples=None):
        size = (2,) if n_samples is None else (n_samples, 2)
        return rng.uniform(-1.0, 1.0, size)

    def random_tangent(self, point, rng, scale=1.0):
        f = 1.0 + point[0] ** 2
        return scale * rng.standard_normal(2) / np.array([1.0, f])

    def parallel_transport(self, point, end, tangent):
        x, w = self._check(point, "point"), self._check(tangent, "tangent")
        v = self.log(x, end)
        sol = self.integrator.integrate(christoffel, x, v, transport=w)
        return sol.transported[0]


def metric_matrix(x):
    """The same metric for :class:`MetricField` (route 1), written with autograd.numpy."""
    f = 1.0 + x[0] ** 2
    return anp.array([[1.0, 0.0], [0.0, f * f]])


def metric_jet(x, order: int):
    """``(g, dg)`` or ``(g, dg, d2g)`` in closed form, ``dg[a, b, l] = d_l g_ab``: the
    geodesics without automatic differentiation inside the ODE (the curvature still
    uses it, so a wrong jet shows as a disagreement)."""
    f, df = 1.0 + x[0] ** 2, 2.0 * x[0]
    g = np.array([[1.0, 0.0], [0.0, f * f]])
    dg = np.zeros((2, 2, 2))
    dg[1, 1, 0] = 2.0 * f * df
    if order == 1:
        return g, dg
    d2g = np.zeros((2, 2, 2, 2))
    d2g[1, 1, 0, 0] = 2.0 * (df * df + 2.0 * f)
    return g, dg, d2g


def metric_field_surface() -> MetricField:
    """The warped surface from its metric (and its closed-form jet, for speed)."""
    return MetricField(metric_matrix, dim=2, metric_jet=metric_jet)


def contract_of(space, max_examples: int):
    """The contract with tolerances that match the ODE accuracy (1e-12, shooting 1e-11)."""

    class Contract(ConnectionContract):
        rtol = 1e-8
        atol = 1e-8

    Contract.space = space
    Contract.max_examples = max_examples
    return Contract()


def check_space(space, rng, n_points: int, max_examples: int) -> dict:
    """The contract, the pole ladder's convergence, the Frechet mean and the tangent PCA."""
    contract = run_contract(contract_of(space, max_examples))
    s, t, u = np.array([-0.4, -0.3]), np.array([0.6, 0.5]), np.array([0.3, 0.4])
    curve = ladder_convergence(space, pole_ladder, s, t, u, space.parallel_transport(s, t, u),
                               n_rungs=(2, 4, 8, 16), label=type(space).__name__)  # fmt: skip
    centre = np.array([0.3, -0.2])
    points = np.stack([space.exp(centre, space.random_tangent(centre, rng, 0.4))
                       for _ in range(n_points)])  # fmt: skip
    mean = frechet_mean(space, points)
    logs = [space.log(mean.mean, p) for p in points]
    pca = tangent_pca(space, mean.mean, logs)
    return {"contract": contract, "curve": curve, "mean": mean, "pca": pca}


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default="symladders-output/add_a_space.png")
    parser.add_argument("--points", type=int, default=6, help="sample of the Frechet mean")
    parser.add_argument("--examples", type=int, default=2, help="per property of the contract")
    args = parser.parse_args(argv)

    results = {}
    for label, space in (("subclass", MyWarpedSurface()), ("metric field", metric_field_surface())):
        out = check_space(space, np.random.default_rng(0), args.points, args.examples)
        results[label] = out
        failed = {k: v for k, v in out["contract"].items() if v.startswith("failed")}
        passed = sum(v == "passed" for v in out["contract"].values())
        print(f"{label}: contract {passed} passed, {len(failed)} failed {failed or ''}")
        print(
            f"  pole ladder against the exact transport: errors "
            f"{', '.join(f'{e:.2e}' for e in out['curve'].errors)}, slope {out['curve'].slope:.2f}"
        )
        pca = out["pca"]
        print(f"  Frechet mean {out['mean'].mean} ({out['mean'].n_iter} iterations), tangent PCA "
              f"variances {np.array2string(pca.variances, precision=4)}")  # fmt: skip
    a, b = (results[k]["mean"].mean for k in results)
    results["mean_gap"] = float(np.linalg.norm(a - b))
    print(f"the two routes' means differ by {results['mean_gap']:.1e}")

    fig, ax = plt.subplots(figsize=(5, 4))
    for label in ("subclass", "metric field"):
        c = results[label]["curve"]
        ax.loglog(c.n_rungs, c.errors, "o-", label=f"{label} (slope {c.slope:.2f})")
    ax.set_xlabel("rungs")
    ax.set_ylabel("relative error against parallel transport")
    ax.set_title("Pole ladder on the warped surface")
    ax.legend()
    output = pathlib.Path(args.output)
    output.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(output, dpi=100)
    plt.close(fig)
    results["figure"] = output
    return results


if __name__ == "__main__":
    main()
