"""The unit hypersphere ``S^n`` embedded in ``R^{n+1}``, with closed-form geometry.

A constant-curvature (``K = +1``) symmetric space used to validate the generic
algorithms of :mod:`ladders`: there the pole ladder is exact (paper, eq. 4 has
``nabla R = 0``) and the transvectivity error of eq. 8 vanishes up to round-off.
"""

from __future__ import annotations

import numpy as np

from .constant_curvature import ConstantCurvatureQuadric, ratio
from .errors import CutLocusError, NotTangentError
from .validation import check_float, check_n_samples, check_rng

__all__ = ["Hypersphere"]


def _dot(a, b):
    """Euclidean inner product over the last axis, broadcasting the leading axes."""
    return np.einsum("...i,...i->...", a, b)


class Hypersphere(ConstantCurvatureQuadric):
    """Unit sphere ``S^n = {x in R^{n+1} : |x| = 1}`` with the round metric.

    Points have shape ``(..., n + 1)``; tangent vectors at ``x`` are the vectors
    ``v`` with ``<x, v> = 0``. All maps have closed forms:

    * ``Exp_x(v) = cos|v| x + sin|v| / |v| v``;
    * ``Log_x(y) = atan2(|w|, <x, y>) w / |w|`` with ``w = y - <x, y> x``, computed
      from ``d = y - x`` so that nearby points keep full relative accuracy;
    * transport from ``x`` to ``y``: ``u - 2 <y, u> / |x + y|^2 (x + y)``;
    * symmetry ``s_m(z) = 2 <m, z> m - z`` and midpoint ``(a + b) / |a + b|``.

    ``Log`` is undefined at antipodal points (the cut locus): :meth:`log`,
    :meth:`midpoint` and :meth:`parallel_transport` raise :class:`CutLocusError`
    when ``|x + y| <= cut_locus_tol`` (``|x + y|`` is, to first order, the geodesic
    distance of ``y`` to the antipode of ``x``).

    Curvature convention: ``R(u, v) w = nabla_u nabla_v w - nabla_v nabla_u w -
    nabla_[u,v] w`` and sectional curvature ``<R(u, v) v, u> / (|u|^2 |v|^2 -
    <u, v>^2)``; here ``R(u, v) w = <v, w> u - <u, w> v`` (``K = +1``).

    Parameters
    ----------
    n : int
        Intrinsic dimension (``S^2`` is the usual sphere in ``R^3``).
    """

    sectional_curvature = 1.0
    cut_locus_tol = 1e-8
    form = staticmethod(_dot)

    # ------------------------------------------------------------------ checks
    def _on_manifold(self, arr, tol):
        """``| |x|^2 - 1 | <= tol``; a NaN or infinite entry fails it too."""
        return np.abs(_dot(arr, arr) - 1.0) <= tol

    def _tangent_ok(self, x, v, tol):
        """``|<x, v>| <= tol (1 + |v|)``."""
        return np.abs(_dot(x, v)) <= tol * (1.0 + np.sqrt(_dot(v, v)))

    def _tangent(self, x, v, name: str = "tangent"):
        """Check tangency of ``v`` at ``x``; return ``v`` projected and ``|v|^2``.

        The projection only removes the round-off normal component allowed by
        the tolerance, so that ``Exp`` stays on the sphere to machine precision.
        """
        xv = _dot(x, v)
        vv = _dot(v, v)
        if not (np.abs(xv) <= self.atol * (1.0 + np.sqrt(vv))).all():
            raise NotTangentError(
                f"{self.name}: {name} is not tangent at the point: |<point, {name}>| up to "
                f"{np.max(np.abs(xv)):.3g} (tolerance {self.atol:g})"
            )
        return v - xv[..., None] * x, np.maximum(vv - xv * xv, 0.0)

    def _check_cut(self, at_cut, what: str, first: str = "point", second: str = "other"):
        """Raise :class:`CutLocusError` if any entry of the boolean ``at_cut`` is set."""
        if np.any(at_cut):
            raise CutLocusError(
                f"{self.name}: {what} is undefined: {second} is antipodal to {first} "
                f"(|{first} + {second}| <= {self.cut_locus_tol:g}, the cut locus)"
            )

    # ------------------------------------------------------------------ closed forms
    def _exp(self, x, v, vv):
        t = np.sqrt(vv)
        return np.cos(t)[..., None] * x + ratio(np.sin(t), t)[..., None] * v

    def _project(self, x):
        """Normalise to unit length where the closed forms drifted off by more than round-off."""
        nn = _dot(x, x)
        drift = np.abs(nn - 1.0) > 4.0 * np.finfo(float).eps
        return np.where(drift[..., None], x / np.sqrt(nn)[..., None], x)

    def _log(self, x, y):
        d = y - x
        xd = _dot(x, d)
        w = d - xd[..., None] * x
        wn = np.sqrt(_dot(w, w))
        c = 1.0 + xd
        # Near the antipode |w| ~ |x + y| and <x, y> < 0.
        self._check_cut((wn <= self.cut_locus_tol) & (c < 0.0), "log")
        return ratio(np.arctan2(wn, c), wn)[..., None] * w

    def dist(self, a, b):
        """Great-circle distance ``2 atan2(|a - b|, |a + b|)``, accurate at 0 and pi."""
        a = self._point(a, "a")
        b = self._point(b, "b")
        self._batch(a=a, b=b)
        diff, tot = b - a, b + a
        return 2.0 * np.arctan2(np.sqrt(_dot(diff, diff)), np.sqrt(_dot(tot, tot)))

    def midpoint(self, a, b):
        """Geodesic midpoint ``(a + b) / |a + b|`` (paper, Section 2.3)."""
        a, b = self._point(a, "a"), self._point(b, "b")
        self._batch(a=a, b=b)
        s = a + b
        sn = np.sqrt(_dot(s, s))
        self._check_cut(sn <= self.cut_locus_tol, "midpoint", "a", "b")
        return s / sn[..., None]

    def _transport(self, x, y, u):
        """``u - 2 <y, u> / |x + y|^2 (x + y)``, undefined at antipodal points."""
        s = x + y
        ss = _dot(s, s)
        self._check_cut(ss <= self.cut_locus_tol**2, "parallel_transport", "point", "end")
        return u - (2.0 * _dot(y, u) / ss)[..., None] * s

    # ------------------------------------------------------------------ sampling
    def random_point(self, rng: np.random.Generator, n_samples: int | None = None):
        """Uniform point(s) on the sphere, shape ``(n + 1,)`` or ``(n_samples, n + 1)``."""
        n_samples = check_n_samples(n_samples)
        size = self.point_shape if n_samples is None else (n_samples, *self.point_shape)
        g = check_rng(rng).standard_normal(size)
        return g / np.linalg.norm(g, axis=-1, keepdims=True)

    def random_tangent(self, point, rng: np.random.Generator, scale: float = 1.0):
        """Gaussian tangent vector(s) at ``point`` with ``E|v|^2 = scale^2``."""
        x = self._point(point, "point")
        check_rng(rng)
        scale = check_float(scale, f"{self.name}: scale", minimum=0.0)
        g = rng.standard_normal(x.shape) * (scale / np.sqrt(self.dim))
        return g - _dot(x, g)[..., None] * x
