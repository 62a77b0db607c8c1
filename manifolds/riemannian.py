"""Riemannian manifolds: a connection (the Levi-Civita one) plus an inner product."""

from __future__ import annotations

from abc import abstractmethod

import numpy as np

from .connection import Connection

__all__ = ["RiemannianManifold"]


class RiemannianManifold(Connection):
    """A manifold with a Riemannian metric and its Levi-Civita connection.

    Subclasses implement :meth:`inner` in addition to the four methods of
    :class:`Connection`; :meth:`norm` and :meth:`dist` derive from it.
    """

    @abstractmethod
    def inner(self, point, u, v):
        """Inner product ``<u, v>_point``.

        Parameters
        ----------
        point : array, shape ``(..., *point_shape)``
        u, v : arrays of tangent vectors at ``point``

        Returns
        -------
        array, shape ``(...)``
        """

    def norm(self, point, v):
        """Riemannian norm ``sqrt(<v, v>_point)``."""
        return np.sqrt(np.maximum(self.inner(point, v, v), 0.0))

    def squared_dist(self, a, b):
        """Squared geodesic distance ``|Log_a(b)|^2_a``."""
        v = self.log(a, b)
        return self.inner(a, v, v)

    def dist(self, a, b):
        """Geodesic distance ``|Log_a(b)|_a``."""
        return np.sqrt(np.maximum(self.squared_dist(a, b), 0.0))
