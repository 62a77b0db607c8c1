"""geomstats spaces as :class:`manifolds.Connection` objects (optional extra ``geomstats``).

A geomstats space (``geomstats.geometry.hypersphere.Hypersphere(2)``,
``SPDMatrices(3)``, ...) carries its metric or connection in ``space.metric``.
:func:`from_geomstats` wraps both so that everything in :mod:`ladders` (pole and
Schild ladders, fanning, the symmetry errors of the paper, convergence studies)
runs on it. The wrapper converts the argument order: here the base point comes
first, ``exp(point, tangent)`` and ``log(point, other)``; geomstats puts it last,
``metric.exp(tangent_vec, base_point)`` and ``metric.log(point, base_point)``.

Randomness goes through an explicit :class:`numpy.random.Generator`, never
through geomstats' global generator: a random tangent vector is a
Generator-drawn ambient Gaussian projected by ``space.to_tangent``; a random
point is the exponential of a random tangent vector at a reference point.

Compatibility with current numpy: geomstats 2.8 imports ``numpy.trapz``, which
numpy 2.4 removed in favour of ``numpy.trapezoid`` (same function). When
``numpy.trapz`` is missing, importing this module defines it as an alias of
``numpy.trapezoid`` before importing geomstats; nothing else is changed. Only
geomstats' numpy backend is supported (``GEOMSTATS_BACKEND=numpy``, its default).
"""

from __future__ import annotations

import os

import numpy as np

from ..connection import Connection
from ..errors import ManifoldError
from ..riemannian import RiemannianManifold

__all__ = ["GeomstatsConnection", "GeomstatsManifold", "from_geomstats"]

_EXTRA_HINT = "install it with: pip install 'symladders[geomstats]'"

if os.environ.get("GEOMSTATS_BACKEND", "numpy") != "numpy":
    raise ImportError(
        "manifolds.interop.geomstats supports only geomstats' numpy backend, but "
        f"GEOMSTATS_BACKEND={os.environ['GEOMSTATS_BACKEND']!r}; unset it or set it to 'numpy'"
    )
if not hasattr(np, "trapz") and hasattr(np, "trapezoid"):
    np.trapz = np.trapezoid  # noqa: NPY201 (removed in numpy 2.4, imported by geomstats 2.8)
try:
    from geomstats.geometry.connection import Connection as _GsConnection
    from geomstats.geometry.riemannian_metric import RiemannianMetric as _GsMetric
except ModuleNotFoundError as exc:
    raise ModuleNotFoundError(
        f"manifolds.interop.geomstats needs the optional package geomstats; {_EXTRA_HINT} ({exc})",
        name=exc.name,
    ) from exc


def _default_base_point(space) -> np.ndarray:
    """A deterministic point of ``space``: its identity, or a canonical projection.

    Tries ``space.identity``, then ``space.projection`` of ``e_0 = (1, 0, ..., 0)``
    (vector spaces) or of the identity matrix (square matrix spaces).
    """
    shape = tuple(space.shape)
    candidates = []
    identity = getattr(space, "identity", None)
    if identity is not None:
        candidates.append(lambda: np.asarray(identity, dtype=float))
    if hasattr(space, "projection"):
        if len(shape) == 1:
            canonical = np.zeros(shape)
            canonical[0] = 1.0
        elif len(shape) == 2 and shape[0] == shape[1]:
            canonical = np.eye(shape[0])
        else:
            canonical = None
        if canonical is not None:
            candidates.append(lambda: np.asarray(space.projection(canonical), dtype=float))
    for make in candidates:
        try:
            point = make()
        except (NotImplementedError, ValueError, TypeError, AttributeError):
            continue
        if point.shape == shape and np.isfinite(point).all() and bool(space.belongs(point)):
            return point
    raise ManifoldError(
        f"base_point: no default reference point found for {type(space).__name__} "
        "(neither an identity nor a projection of a canonical element); pass base_point"
    )


class GeomstatsConnection(Connection):
    """A geomstats space and its affine connection as a :class:`manifolds.Connection`.

    Parameters
    ----------
    space : geomstats.geometry.manifold.Manifold
        The geomstats space; gives ``point_shape`` (``space.shape``), ``belongs``,
        ``is_tangent`` and ``to_tangent``.
    connection : geomstats.geometry.connection.Connection, optional
        Defaults to ``space.metric``. Must implement ``exp`` and ``log``.
    base_point : array, shape ``point_shape``, optional
        Reference point of :meth:`random_point`; by default the identity of a Lie
        group or the projection of a canonical element (see
        :func:`_default_base_point`).
    spread : float, default 1.0
        Typical geodesic distance of :meth:`random_point` from ``base_point``.
    is_symmetric : bool, default False
        Declare the connection locally symmetric (``nabla R = 0``).
    atol : float, default 1e-8
        Tolerance of the membership checks (passed to geomstats).

    Notes
    -----
    Leading batch axes are broadcast and flattened into geomstats' single batch
    axis, so every method accepts arrays of shape ``(..., *point_shape)``.
    """

    supports_batch = True

    def __init__(
        self,
        space,
        connection=None,
        base_point=None,
        spread: float = 1.0,
        is_symmetric: bool = False,
        atol: float = 1e-8,
    ):
        if not hasattr(space, "shape") or not hasattr(space, "belongs"):
            raise TypeError(f"space: expected a geomstats manifold, got {type(space).__name__}")
        connection = getattr(space, "metric", None) if connection is None else connection
        if not isinstance(connection, _GsConnection):
            raise TypeError(
                "connection: expected a geomstats Connection or RiemannianMetric (by default "
                f"space.metric), got {type(connection).__name__}; equip the space with a metric"
            )
        if not np.isfinite(spread) or spread <= 0:
            raise ManifoldError(f"spread: expected a positive number, got {spread!r}")
        self.space = space
        self.connection = connection
        self.point_shape = tuple(int(s) for s in space.shape)
        self.dim = int(space.dim)
        self.spread = float(spread)
        self.is_symmetric = bool(is_symmetric)
        self.atol = float(atol)
        if base_point is None:
            base_point = _default_base_point(space)
        self.base_point = self.check_point(base_point, "base_point")

    @property
    def name(self) -> str:
        return f"{type(self).__name__}[{type(self.space).__name__}]"

    # ------------------------------------------------------------- batching
    def _call(self, fn, *arrays, trailing: tuple[int, ...] | None = None):
        """``fn(*arrays)`` with leading batch axes broadcast and flattened to one axis.

        ``trailing`` is the shape of one output (``point_shape`` by default, ``()``
        for scalars).
        """
        trailing = self.point_shape if trailing is None else trailing
        nd = len(self.point_shape)
        batch = np.broadcast_shapes(*(np.shape(a)[: np.ndim(a) - nd] for a in arrays))
        if batch == ():
            out = fn(*arrays)
            return np.asarray(out, dtype=float if trailing else None).reshape(trailing)
        flat = [
            np.broadcast_to(a, batch + self.point_shape).reshape((-1, *self.point_shape))
            for a in arrays
        ]
        out = np.asarray(fn(*flat))
        if trailing:
            out = out.astype(float, copy=False)
        return out.reshape(batch + trailing)

    # ------------------------------------------------------------- membership
    def belongs(self, point, atol: float | None = None):
        """Shape and finiteness, then geomstats' ``space.belongs`` within ``atol``."""
        ok = super().belongs(point)
        if not np.any(ok):
            return ok
        tol = self.atol if atol is None else atol
        arr = np.where(np.asarray(ok)[(...,) + (None,) * len(self.point_shape)], point, 0.0)
        inside = self._call(lambda p: self.space.belongs(p, atol=tol), arr, trailing=())
        return np.logical_and(ok, inside)

    def is_tangent(self, point, vector, atol: float | None = None):
        """Shape and finiteness, then geomstats' ``space.is_tangent`` within ``atol``."""
        ok = super().belongs(vector)
        if not np.any(ok):
            return ok
        tol = self.atol if atol is None else atol
        arr = np.where(np.asarray(ok)[(...,) + (None,) * len(self.point_shape)], vector, 0.0)
        tangent = self._call(
            lambda v, p: self.space.is_tangent(v, p, atol=tol), arr, point, trailing=()
        )
        return np.logical_and(ok, tangent)

    # ------------------------------------------------------------- connection
    def exp(self, point, tangent):
        """``Exp_point(tangent)``, i.e. geomstats' ``connection.exp(tangent, point)``."""
        x = self.check_point(point, "point")
        v = self.check_tangent(x, tangent, "tangent")
        return self._call(lambda v_, x_: self.connection.exp(v_, x_), v, x)

    def log(self, point, other):
        """``Log_point(other)``, i.e. geomstats' ``connection.log(other, point)``."""
        x = self.check_point(point, "point")
        y = self.check_point(other, "other")
        return self._call(lambda y_, x_: self.connection.log(y_, x_), y, x)

    def has_exact_transport(self) -> bool:
        """Whether geomstats provides a closed-form ``parallel_transport`` here."""
        method = getattr(type(self.connection), "parallel_transport", None)
        return method is not None and method is not _GsConnection.parallel_transport

    def parallel_transport(self, point, end, tangent):
        """Geomstats' closed-form transport of ``tangent`` from ``point`` to ``end``."""
        if not self.has_exact_transport():
            return super().parallel_transport(point, end, tangent)
        x = self.check_point(point, "point")
        y = self.check_point(end, "end")
        v = self.check_tangent(x, tangent, "tangent")
        return self._call(
            lambda v_, x_, y_: self.connection.parallel_transport(v_, x_, end_point=y_), v, x, y
        )

    # ------------------------------------------------------------- sampling
    def _size(self, point, vector):
        """Size used to normalise random tangents: the Frobenius norm here."""
        axes = tuple(range(-len(self.point_shape), 0))
        return np.sqrt((np.asarray(vector) ** 2).sum(axis=axes))

    def random_tangent(self, point, rng: np.random.Generator, scale: float = 1.0):
        """Tangent vector(s) at ``point`` with ``E|v|^2 = scale^2``, drawn with ``rng``.

        The direction is ``space.to_tangent`` of a standard Gaussian ambient
        array; the length is ``scale sqrt(chi^2_dim / dim)`` (the norm of an
        isotropic Gaussian of the intrinsic dimension), in the metric norm when
        there is one, else the Frobenius norm.
        """
        x = self.check_point(point, "point")
        if not np.isfinite(scale) or scale < 0:
            raise ManifoldError(f"{self.name}: scale must be finite and >= 0, got {scale!r}")
        batch = x.shape[: x.ndim - len(self.point_shape)]  # check_point checked the trailing axes
        ambient = rng.standard_normal(x.shape)
        direction = self._call(lambda g, p: self.space.to_tangent(g, p), ambient, x)
        length = scale * np.sqrt((rng.standard_normal((*batch, self.dim)) ** 2).mean(axis=-1))
        factor = length / np.maximum(self._size(x, direction), np.finfo(float).tiny)
        return direction * np.reshape(factor, batch + (1,) * len(self.point_shape))

    def random_point(self, rng: np.random.Generator, n_samples: int | None = None):
        """``Exp_b(v)`` with ``b = base_point`` and ``v = random_tangent(b, rng, spread)``."""
        base = self.base_point
        if n_samples is not None:
            if isinstance(n_samples, bool) or int(n_samples) != n_samples or n_samples < 1:
                raise ManifoldError(
                    f"{self.name}: n_samples must be a positive integer, got {n_samples!r}"
                )
            base = np.broadcast_to(base, (int(n_samples), *self.point_shape))
        return self.exp(base, self.random_tangent(base, rng, scale=self.spread))


class GeomstatsManifold(GeomstatsConnection, RiemannianManifold):
    """A geomstats space with a Riemannian metric as a :class:`manifolds.RiemannianManifold`.

    Same parameters as :class:`GeomstatsConnection`; ``connection`` (by default
    ``space.metric``) must be a geomstats ``RiemannianMetric``. ``inner``,
    ``norm``, ``squared_dist`` and ``dist`` call the metric's own methods (closed
    forms where geomstats has them).
    """

    def __init__(self, space, connection=None, **kwargs):
        metric = getattr(space, "metric", None) if connection is None else connection
        if not isinstance(metric, _GsMetric):
            raise TypeError(
                "connection: expected a geomstats RiemannianMetric (by default space.metric), "
                f"got {type(metric).__name__}; use GeomstatsConnection for a connection only"
            )
        super().__init__(space, metric, **kwargs)

    @property
    def metric(self):
        """The wrapped geomstats ``RiemannianMetric``."""
        return self.connection

    def inner(self, point, u, v):
        """``<u, v>_point`` from ``metric.inner_product(u, v, point)``."""
        x = self.check_point(point, "point")
        a = self.check_tangent(x, u, "u")
        b = self.check_tangent(x, v, "v")
        return self._call(
            lambda a_, b_, x_: self.metric.inner_product(a_, b_, x_), a, b, x, trailing=()
        )

    def squared_dist(self, a, b):
        """Squared geodesic distance from ``metric.squared_dist``."""
        x = self.check_point(a, "a")
        y = self.check_point(b, "b")
        return self._call(lambda x_, y_: self.metric.squared_dist(x_, y_), x, y, trailing=())

    def dist(self, a, b):
        """Geodesic distance from ``metric.dist``."""
        x = self.check_point(a, "a")
        y = self.check_point(b, "b")
        return self._call(lambda x_, y_: self.metric.dist(x_, y_), x, y, trailing=())

    def _size(self, point, vector):
        return self.norm(point, vector)


def from_geomstats(space, connection=None, **kwargs) -> GeomstatsConnection:
    """Wrap a geomstats space: a :class:`GeomstatsManifold` when its metric is Riemannian.

    Parameters
    ----------
    space : geomstats manifold
        For example ``geomstats.geometry.hypersphere.Hypersphere(2)``.
    connection : geomstats Connection or RiemannianMetric, optional
        Defaults to ``space.metric``.
    **kwargs
        ``base_point``, ``spread``, ``is_symmetric``, ``atol`` of
        :class:`GeomstatsConnection`.

    Returns
    -------
    GeomstatsConnection
        A :class:`GeomstatsManifold` (a :class:`manifolds.RiemannianManifold`) when
        the connection is a Riemannian metric, else a :class:`GeomstatsConnection`.
    """
    metric = getattr(space, "metric", None) if connection is None else connection
    if isinstance(metric, _GsMetric):
        return GeomstatsManifold(space, metric, **kwargs)
    return GeomstatsConnection(space, metric, **kwargs)
