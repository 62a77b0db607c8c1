"""Trust-region Gauss-Newton with matrix-free Steihaug-Toint conjugate gradients.

For a least-squares objective ``f(x) = ||r(x)||^2 + reg(x)`` the Gauss-Newton
model ``m(p) = f + g.p + 1/2 p.H p``, with ``H = 2 J^T J + H_reg``, is minimised
inside a trust region of radius ``Delta`` by conjugate gradients (Steihaug-Toint:
stop at the boundary, or along a direction of non-positive curvature). ``H v``
is one tangent-linear and one adjoint pass of the flow
(``problem.gauss_newton_product``); the variables are the preconditioned ones, so
CG runs on the preconditioned system. The inner solve is inexact: it stops when
the model's residual falls below ``eta ||g||`` with the Eisenstat-Walker forcing
``eta = min(0.5, sqrt(||g|| / ||g_0||))`` (loose far from the solution, tight near it).
A step is accepted when the actual decrease is at least ``1e-4`` of the predicted
one; the radius shrinks by 4 on poor agreement (ratio below 1/4) and doubles on
good agreement at the boundary (above 3/4).
"""

from __future__ import annotations

import numpy as np

from .blas import limit_blas_threads
from .options import SolverOptions
from .result import OptimizationResult
from .stopping import StoppingRule

__all__ = ["minimize_gauss_newton", "steihaug_cg"]

ACCEPT = 1e-4
SHRINK, GROW = 0.25, 0.75


def steihaug_cg(hess_product, g, radius, eta, max_iter):
    """Approximate minimiser of ``g.p + 1/2 p.H p`` with ``||p|| <= radius``.

    Parameters
    ----------
    hess_product : callable ``v -> H v``
    g : array
    radius : float
        Trust-region radius (``inf`` for none).
    eta : float
        Relative tolerance on the model's residual ``||H p + g|| <= eta ||g||``.
    max_iter : int

    Returns
    -------
    p : array
    predicted : float
        Predicted decrease ``-(g.p + 1/2 p.H p)`` (non-negative).
    n_products : int
    reason : str
    """
    p = np.zeros_like(g)
    r = g.copy()  # gradient of the model at p
    d = -r
    rr = float(r @ r)
    tol = eta * np.sqrt(rr)
    reason = "max iterations"
    n = 0
    while n < max_iter:
        n += 1
        hd = hess_product(d)
        dhd = float(d @ hd)
        if dhd <= 0.0:
            p = p + _to_boundary(p, d, radius) * d
            reason = "negative curvature"
            break
        a = rr / dhd
        if np.linalg.norm(p + a * d) >= radius:
            p = p + _to_boundary(p, d, radius) * d
            reason = "boundary"
            break
        p = p + a * d
        r = r + a * hd
        rr_new = float(r @ r)
        if np.sqrt(rr_new) <= tol:
            reason = "converged"
            break
        d = -r + (rr_new / rr) * d
        rr = rr_new
    hp = hess_product(p) if reason in ("boundary", "negative curvature") else r - g
    n += reason in ("boundary", "negative curvature")
    predicted = -(float(g @ p) + 0.5 * float(p @ hp))
    return p, max(predicted, 0.0), n, reason


def _to_boundary(p, d, radius) -> float:
    """``tau >= 0`` with ``||p + tau d|| = radius`` (or 1 for an infinite radius)."""
    if not np.isfinite(radius):
        return 1.0
    pd, dd, pp = float(p @ d), float(d @ d), float(p @ p)
    return (-pd + np.sqrt(max(pd * pd + dd * (radius * radius - pp), 0.0))) / dd


def minimize_gauss_newton(
    problem, x0, options: SolverOptions | None = None, rule: StoppingRule | None = None
):
    """Minimise ``problem`` (which provides ``gauss_newton_product``) from ``x0``.

    Parameters
    ----------
    problem : SolverProblem with ``gauss_newton_product(x, v)``
    x0 : array
    options : SolverOptions, optional
        ``max_inner`` (CG iterations per step) and ``blas_threads``.
    rule : StoppingRule, optional
        Tolerances and iteration limit (outer iterations; default ``StoppingRule()``).

    Returns
    -------
    OptimizationResult
    """
    options = SolverOptions() if options is None else options
    rule = StoppingRule() if rule is None else rule
    x = np.asarray(x0, dtype=float).ravel().copy()
    with limit_blas_threads(options.blas_threads):
        f, g = problem.value_and_gradient(x)
        n_evals, history = 1, [f]
        rule.start(problem, x, f)
        g0 = max(float(np.linalg.norm(g)), 1e-300)
        radius = np.inf
        converged, message, n_iter = False, "iteration limit", 0
        while n_iter < rule.max_iter:
            gn = float(np.linalg.norm(g))
            if gn == 0.0:
                converged, message = True, "zero gradient"
                break
            eta = min(0.5, np.sqrt(gn / g0))
            here = x.copy()
            p, pred, _, _ = steihaug_cg(
                lambda v, at=here: problem.gauss_newton_product(at, v),
                g,
                radius,
                eta,
                options.max_inner,
            )
            if pred <= 0.0:
                converged = rule.accepts_stall(problem, x, g)
                message = "no predicted decrease"
                break
            f_new = problem.value(x + p)
            n_evals += 1
            ratio = (f - f_new) / pred
            step = float(np.linalg.norm(p))
            if ratio < SHRINK:
                radius = SHRINK * step
            elif ratio > GROW and step >= 0.99 * radius:
                radius = 2.0 * radius
            elif not np.isfinite(radius):
                radius = 2.0 * step
            if ratio < ACCEPT:
                if radius < 1e-12 * max(1.0, float(np.linalg.norm(x))):
                    converged = rule.accepts_stall(problem, x, g)
                    message = "trust region collapsed"
                    break
                continue
            x = x + p
            f, g = problem.value_and_gradient(x)
            n_iter += 1
            history.append(f)
            why = rule.met(problem, x, f, g)
            if why is not None:
                converged, message = True, why
                break
    return OptimizationResult(
        x=x,
        fun=f,
        grad=g,
        n_iter=n_iter,
        n_evals=n_evals,
        history=history,
        converged=converged,
        message=message,
        trace=list(rule.trace),
    )
