"""The weighted Fréchet (Karcher) mean of points on any space with ``exp`` and ``log``.

The mean ``x`` of points ``p_i`` with weights ``w_i`` (summing to one) is a zero
of the mean logarithm, ``G(x) = sum_i w_i Log_x(p_i) = 0``: on a Riemannian
manifold, minus half the gradient of the Fréchet function
``F(x) = sum_i w_i d(x, p_i)^2``; on an affine connection space, the definition
of the exponential barycentre. The Karcher iteration

    x <- Exp_x(step * G(x))

converges (linearly; in one step on a flat space) from a start close enough to
the mean. It stops when ``|G(x)|`` falls below ``tol``, measured with the
space's norm at ``x`` when it has one (``space.norm``) and with the array norm
of the tangent otherwise. Nothing here is specific to a space: on the LDDMM
landmark space ``Log`` is a registration and the mean is the atlas of the
shapes (:mod:`ladders.study.preparation.atlas`). The logarithms of one iteration
are independent of each other: a caller may compute them its own way (``map_logs``,
e.g. in parallel processes), the iteration being the same.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from manifolds import Connection, ManifoldError
from manifolds.validation import check_array, check_float, check_int

__all__ = ["FrechetMeanResult", "frechet_mean"]


@dataclass
class FrechetMeanResult:
    """Outcome of :func:`frechet_mean`.

    Attributes
    ----------
    mean : array, shape ``point_shape``
    converged : bool
        ``|G(mean)| <= tol``.
    n_iter : int
        Exponential steps taken.
    gradient_norms : list of float
        ``|G(x)|`` at every iterate, the start first.
    variances : list of float
        ``sum_i w_i |Log_x(p_i)|^2`` at every iterate (the Fréchet function on a
        Riemannian manifold), in the norm used for ``gradient_norms``.
    message : str
    """

    mean: np.ndarray
    converged: bool
    n_iter: int
    gradient_norms: list = field(default_factory=list)
    variances: list = field(default_factory=list)
    message: str = ""


def _norm(space: Connection, point, vector) -> float:
    norm = getattr(space, "norm", None)
    if norm is not None:
        try:
            return float(norm(point, vector))
        except NotImplementedError:
            pass
    arr = getattr(vector, "momenta", vector)
    return float(np.linalg.norm(np.asarray(arr, dtype=float)))


def _is_targets(points) -> bool:
    """Whether ``points`` is a sequence of targets that are not arrays (e.g. data terms)."""
    return isinstance(points, list | tuple) and any(
        not isinstance(p, np.ndarray | list | tuple | float | int) for p in points
    )


def _check_inputs(space, points, weights):
    if not isinstance(space, Connection):
        raise TypeError(f"frechet_mean: space: expected a manifolds.Connection, got {space!r}")
    shape = tuple(space.point_shape)
    pts = (
        list(points) if _is_targets(points) else check_array(points, shape, "frechet_mean: points")
    )
    if not isinstance(pts, list) and (pts.ndim != len(shape) + 1 or pts.shape[0] == 0):
        raise ManifoldError(
            f"frechet_mean: points: expected a stack of shape (n, {', '.join(map(str, shape))}) "
            f"with n >= 1, got {pts.shape}"
        )
    n = len(pts)
    if weights is None:
        return pts, np.full(n, 1.0 / n)
    w = check_array(weights, (), "frechet_mean: weights")
    if w.shape != (n,) or (w < 0).any() or w.sum() <= 0:
        raise ManifoldError(
            f"frechet_mean: weights: expected {n} non-negative weights (one per point) with a "
            f"positive sum, got shape {w.shape} and values {np.round(w, 4).tolist()[:6]}"
        )
    return pts, w / w.sum()


def _mean_log(space: Connection, x, pts, w, map_logs=None):
    """``(sum_i w_i Log_x(p_i), [Log_x(p_i)])``: by ``map_logs`` when given, else batched
    when the space supports it, else one after the other."""
    if map_logs is not None:
        logs = list(map_logs(x, pts))
        if len(logs) != len(w):
            raise ManifoldError(
                f"frechet_mean: map_logs: returned {len(logs)} logarithms for {len(w)} points"
            )
    elif space.supports_batch and isinstance(pts, np.ndarray):
        logs = space.log(np.broadcast_to(x, pts.shape), pts)
        return np.tensordot(w, logs, axes=1), list(logs)
    else:
        logs = [space.log(x, p) for p in pts]
    total = w[0] * logs[0]
    for wi, log in zip(w[1:], logs[1:]):
        total = total + wi * log
    return total, logs


def frechet_mean(
    space: Connection,
    points,
    weights=None,
    *,
    initial=None,
    step: float = 1.0,
    tol: float = 1e-10,
    max_iter: int = 100,
    callback: Callable | None = None,
    map_logs: Callable | None = None,
) -> FrechetMeanResult:
    """Weighted Fréchet (Karcher) mean of ``points`` by the iteration ``x <- Exp_x(step G(x))``.

    Parameters
    ----------
    space : manifolds.Connection
        Any space with ``exp`` and ``log`` (batched when ``space.supports_batch``).
    points : array, shape ``(n, *point_shape)``, or a list of targets
        Points, or anything else ``space.log`` accepts as its second argument
        (e.g. :class:`~manifolds.data_terms.DataTerm` objects for the landmark
        spaces); ``initial`` is then required.
    weights : array, shape ``(n,)``, optional
        Non-negative, normalised to sum to one; uniform by default.
    initial : array, shape ``point_shape``, optional
        Start of the iteration; the first point by default.
    step : float, default 1.0
        Step along the mean logarithm (1 is the Karcher iteration).
    tol : float, default 1e-10
        Stop when ``|G(x)|`` is at most ``tol`` (in the space's norm if it has one).
    max_iter : int, default 100
    callback : callable, optional
        ``callback(iteration, x, gradient_norm)`` after every evaluation of ``G``;
        a true return value stops the iteration as converged (a criterion of the
        caller's, e.g. on the shape's displacement).
    map_logs : callable, optional
        ``map_logs(x, points)``: the sequence ``[Log_x(p_i)]``, one per point in their
        order, computed as the caller chooses (e.g. the registrations of an LDDMM
        atlas in parallel processes); by default ``space.log`` over the points, in
        one batch when the space supports it, else one after the other.

    Returns
    -------
    FrechetMeanResult
    """
    pts, w = _check_inputs(space, points, weights)
    step = check_float(step, "frechet_mean: step", minimum=0.0, strict=True)
    tol = check_float(tol, "frechet_mean: tol", minimum=0.0)
    max_iter = check_int(max_iter, "frechet_mean: max_iter", minimum=0)
    if initial is None and isinstance(pts, list):
        raise ManifoldError("frechet_mean: initial: required when the points are not arrays")
    x = pts[0].copy() if initial is None else space.check_point(initial, "initial")
    norms, variances = [], []
    for it in range(max_iter + 1):
        g, logs = _mean_log(space, x, pts, w, map_logs)
        norms.append(_norm(space, x, g))
        variances.append(float(sum(wi * _norm(space, x, v) ** 2 for wi, v in zip(w, logs))))
        if callback is not None and callback(it, x, norms[-1]):
            return FrechetMeanResult(
                x, True, it, norms, variances, f"stopped by the callback at {it}"
            )
        if norms[-1] <= tol:
            return FrechetMeanResult(x, True, it, norms, variances, f"|G| <= tol after {it}")
        if it == max_iter:
            break
        x = space.exp(x, step * g)
    return FrechetMeanResult(
        x, False, max_iter, norms, variances,
        f"|G| = {norms[-1]:.3g} > tol = {tol:g} after max_iter = {max_iter} iterations",
    )  # fmt: skip
