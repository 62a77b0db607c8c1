"""Hyperbolic space ``H^n`` in the hyperboloid model, with closed-form geometry.

A constant-curvature (``K = -1``) symmetric space used to validate the generic
algorithms of :mod:`ladders` (pole ladder exact, paper eq. 4 with ``nabla R = 0``;
zero transvectivity error, eq. 8).
"""

from __future__ import annotations

import numpy as np

from .constant_curvature import ConstantCurvatureQuadric, ratio
from .errors import NotTangentError
from .validation import check_float, check_n_samples, check_rng

__all__ = ["Hyperbolic", "minkowski_inner"]


def _two_product(a, b):
    """``a * b = p + e`` exactly (Dekker's splitting, no fused multiply-add needed)."""
    p = a * b
    split = 134217729.0  # 2**27 + 1
    t = split * a
    ah = t - (t - a)
    al = a - ah
    t = split * b
    bh = t - (t - b)
    bl = b - bh
    return p, al * bl - (((p - ah * bh) - al * bh) - ah * bl)


def minkowski_inner(a, b):
    """Minkowski product ``<a, b>_L = -a_0 b_0 + sum_i a_i b_i`` over the last axis.

    Parameters
    ----------
    a, b : array, shape ``(..., n + 1)`` (leading axes broadcast)

    Returns
    -------
    array, shape ``(...)``
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return np.einsum("...i,...i->...", a, b) - 2.0 * a[..., 0] * b[..., 0]


def minkowski_inner_compensated(a, b):
    """:func:`minkowski_inner` summed with error-free transformations (about 4x slower).

    Far from the origin the terms are of size ``e^(2 r)`` while the product of
    two points at distance ``d`` is ``-cosh d``: the plain sum loses ``e^(2 r)``
    ulps. Here products and sums are compensated (Ogita, Rump and Oishi's
    ``Dot2``), so the result is as accurate as if computed in twice the working
    precision. Used by the symmetry, where that error is multiplied by the
    coordinates again.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    s, c = _two_product(-a[..., 0], b[..., 0])
    for i in range(1, a.shape[-1]):
        p, q = _two_product(a[..., i], b[..., i])
        t = s + p
        bp = t - s
        c = c + (q + ((s - (t - bp)) + (p - bp)))
        s = t
    return s + c


class Hyperbolic(ConstantCurvatureQuadric):
    """Hyperbolic space ``H^n = {x in R^{n+1} : <x, x>_L = -1, x_0 > 0}``.

    Points have shape ``(..., n + 1)``; tangent vectors at ``x`` satisfy
    ``<x, v>_L = 0`` and the metric is the restriction of ``<., .>_L``
    (positive definite on tangent spaces). Closed forms, with ``|v|_L =
    sqrt(<v, v>_L)``:

    * ``Exp_x(v) = cosh|v|_L x + sinh|v|_L / |v|_L v``;
    * ``Log_x(y) = theta / sinh(theta) w`` with ``w = y + <x, y>_L x``,
      ``sinh(theta) = |w|_L`` and ``theta = log1p(|w|_L - <x, y - x>_L)``
      (``= arccosh(-<x, y>_L)``, but accurate for nearby points);
    * transport ``u + <y, u>_L / (1 - <x, y>_L) (x + y)``;
    * symmetry ``s_m(z) = -2 <m, z>_L m - z``, midpoint ``(a + b) / |a + b|_L``.

    There is no cut locus. Curvature convention: ``R(u, v) w = nabla_u nabla_v w
    - nabla_v nabla_u w - nabla_[u,v] w``, sectional curvature ``<R(u, v) v, u> /
    (|u|^2 |v|^2 - <u, v>^2)``; here ``R(u, v) w = -(<v, w> u - <u, w> v)``
    (``K = -1``).

    Membership uses a tolerance relative to the size of the point,
    ``| <x, x>_L + 1 | <= atol x_0^2``, since the hyperboloid coordinates grow
    like ``e^dist``.

    Parameters
    ----------
    n : int
        Intrinsic dimension.
    """

    sectional_curvature = -1.0
    form = staticmethod(minkowski_inner)
    accurate_form = staticmethod(minkowski_inner_compensated)

    # ------------------------------------------------------------------ checks
    def _on_manifold(self, arr, tol):
        """``|<x, x>_L + 1| <= tol x_0^2`` and ``x_0 > 0`` (a NaN entry fails it)."""
        x0 = arr[..., 0]
        return (np.abs(minkowski_inner(arr, arr) + 1.0) <= tol * (x0 * x0)) & (x0 > 0)

    def _tangent_ok(self, x, v, tol):
        """``|<x, v>_L| <= tol (1 + |x| |v|)`` (Euclidean norms)."""
        scale = 1.0 + np.sqrt(np.einsum("...i,...i->...", x, x) * np.einsum("...i,...i->...", v, v))
        return np.abs(minkowski_inner(x, v)) <= tol * scale

    def _tangent(self, x, v, name: str = "tangent"):
        """Check tangency of ``v`` at ``x``; return ``v`` projected and ``|v|_L^2``."""
        if not np.all(self._tangent_ok(x, v, self.atol)):
            raise NotTangentError(
                f"{self.name}: {name} is not tangent at the point: |<point, {name}>_L| up to "
                f"{np.max(np.abs(minkowski_inner(x, v))):.3g} (tolerance {self.atol:g})"
            )
        v = v + minkowski_inner(x, v)[..., None] * x
        return v, np.maximum(minkowski_inner(v, v), 0.0)

    # ------------------------------------------------------------------ closed forms
    def _exp(self, x, v, vv):
        t = np.sqrt(vv)
        return np.cosh(t)[..., None] * x + ratio(np.sinh(t), t)[..., None] * v

    def _project(self, x):
        """Recompute ``x_0 = sqrt(1 + |x_space|^2) > 0`` where the point drifted off.

        Far from the origin the closed forms leave the hyperboloid by a
        round-off error that grows like the coordinates. A point whose
        ``|<x, x>_L + 1|`` exceeds ``1e-13 x_0^2`` is put back on the upper sheet
        from its spatial part; points within that (round-off near the origin)
        are returned unchanged, since moving them would only add error.
        """
        space = x[..., 1:]
        x0 = np.sqrt(1.0 + np.einsum("...i,...i->...", space, space))
        drift = np.abs(minkowski_inner(x, x) + 1.0) > 1e-13 * x0 * x0
        if not np.any(drift):
            return x
        return np.where(drift[..., None], np.concatenate([x0[..., None], space], axis=-1), x)

    def _log(self, x, y):
        d = y - x
        xd = minkowski_inner(x, d)
        w = d + xd[..., None] * x
        wn = np.sqrt(np.maximum(minkowski_inner(w, w), 0.0))
        theta = np.log1p(wn - xd)
        return ratio(theta, wn)[..., None] * w

    def dist(self, a, b):
        """Distance ``2 asinh(|b - a|_L / 2)``, accurate for nearby points."""
        a = self._point(a, "a")
        b = self._point(b, "b")
        self._batch(a=a, b=b)
        d = b - a
        return 2.0 * np.arcsinh(0.5 * np.sqrt(np.maximum(minkowski_inner(d, d), 0.0)))

    def midpoint(self, a, b):
        """Geodesic midpoint ``(a + b) / sqrt(-<a + b, a + b>_L)`` (paper, Section 2.3)."""
        a, b = self._point(a, "a"), self._point(b, "b")
        self._batch(a=a, b=b)
        s = a + b
        return self._project(s / np.sqrt(-minkowski_inner(s, s))[..., None])

    def _transport(self, x, y, u):
        """``u + <y, u>_L / (1 - <x, y>_L) (x + y)``."""
        coef = minkowski_inner(y, u) / (1.0 - minkowski_inner(x, y))
        return u + coef[..., None] * (x + y)

    # ------------------------------------------------------------------ sampling
    def random_point(self, rng: np.random.Generator, n_samples: int | None = None):
        """Point(s) ``(sqrt(1 + |z|^2), z)`` with ``z`` standard Gaussian in ``R^n``."""
        n_samples = check_n_samples(n_samples)
        size = (self.dim,) if n_samples is None else (n_samples, self.dim)
        z = check_rng(rng).standard_normal(size)
        x0 = np.sqrt(1.0 + np.einsum("...i,...i->...", z, z))
        return np.concatenate([x0[..., None], z], axis=-1)

    def random_tangent(self, point, rng: np.random.Generator, scale: float = 1.0):
        """Gaussian tangent vector(s) at ``point`` with ``E|v|_L^2 = scale^2``.

        An isotropic Gaussian vector is drawn at the origin ``e_0 = (1, 0, ..., 0)``
        and carried to ``point`` by parallel transport, an isometry.
        """
        x = self._point(point, "point")
        check_rng(rng)
        scale = check_float(scale, f"{self.name}: scale", minimum=0.0)
        g = np.zeros(x.shape)
        g[..., 1:] = rng.standard_normal((*x.shape[:-1], self.dim)) * (scale / np.sqrt(self.dim))
        # Transport from the origin e_0 to x is an isometry onto T_x H^n.
        e0 = np.zeros(self.point_shape)
        e0[0] = 1.0
        coef = minkowski_inner(x, g) / (1.0 - minkowski_inner(e0, x))
        return g + coef[..., None] * (e0 + x)
