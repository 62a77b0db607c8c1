"""Adapters that bring spaces of other libraries into :mod:`manifolds`.

* :mod:`manifolds.interop.geomstats`: a geomstats manifold and its metric (or
  connection) as a :class:`manifolds.Connection` or
  :class:`manifolds.RiemannianManifold`; needs the optional extra ``geomstats``.

``import manifolds`` never imports this subpackage, and this subpackage imports an
adapter (and its third-party library) only when one of its names is first used, so
the extras stay optional.
"""

from __future__ import annotations

import importlib

__all__ = ["GeomstatsConnection", "GeomstatsManifold", "from_geomstats"]

_LAZY = {name: "geomstats" for name in __all__}


def __getattr__(name: str):
    if name in _LAZY:
        module = importlib.import_module(f"{__name__}.{_LAZY[name]}")
        return getattr(module, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
