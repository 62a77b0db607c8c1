"""The kernel backends: one registry and one ``"auto"`` rule for every kernel sum.

Both the landmark kernels (:class:`manifolds.lddmm.GaussianKernel`) and the surface
data terms (:mod:`manifolds.data_terms`) resolve their ``backend`` argument here:

* ``"numpy"``: the reference, blocked numpy sums (always available);
* ``"numba"``: the compiled, fused loops (available when numba imports; a dependency);
* ``"auto"``: the first available backend of :data:`AUTO_ORDER` (numba, then numpy).

:func:`register_backend` adds one (a GPU backend would register here with its own
availability check); a backend's sums are then looked up by the modules that
implement them.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable

from ..errors import ManifoldError

__all__ = [
    "AUTO_ORDER",
    "available_backends",
    "backend_available",
    "numba_available",
    "register_backend",
    "resolve_backend",
]


def numba_available() -> bool:
    """Whether the compiled backend can be used (``numba`` importable)."""
    return importlib.util.find_spec("numba") is not None


_REGISTRY: dict[str, Callable[[], bool]] = {"numpy": lambda: True, "numba": numba_available}
#: Backends ``"auto"`` tries, in order.
AUTO_ORDER: list[str] = ["numba", "numpy"]


def register_backend(
    name: str, available: Callable[[], bool], auto_rank: int | None = None
) -> None:
    """Register a backend ``name`` with its availability check.

    ``auto_rank`` puts it at that position of :data:`AUTO_ORDER` (None: ``"auto"``
    never chooses it).
    """
    if not isinstance(name, str) or not name or name == "auto":
        raise ManifoldError(f"register_backend: name: expected a new backend name, got {name!r}")
    _REGISTRY[name] = available
    if auto_rank is not None and name not in AUTO_ORDER:
        AUTO_ORDER.insert(int(auto_rank), name)


def backend_available(name: str) -> bool:
    """Whether the registered backend ``name`` can run here."""
    return name in _REGISTRY and bool(_REGISTRY[name]())


def available_backends() -> list[str]:
    """The registered backends that can run here."""
    return [name for name in _REGISTRY if backend_available(name)]


def resolve_backend(requested: str, owner: str = "backend") -> str:
    """The backend that runs for ``requested`` (``"auto"`` or a registered name).

    Raises
    ------
    ManifoldError
        An unknown name, or a backend that cannot run here (named with ``owner``).
    """
    if requested == "auto":
        return next(name for name in AUTO_ORDER if backend_available(name))
    if requested not in _REGISTRY:
        raise ManifoldError(
            f"{owner}: expected 'auto' or one of {sorted(_REGISTRY)}, got {requested!r}"
        )
    if not backend_available(requested):
        raise ManifoldError(f"{owner}: the {requested!r} backend cannot run here (not installed)")
    return requested
