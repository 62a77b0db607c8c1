"""The registrations a landmark space has computed, kept (LRU) by their inputs.

``log``, ``log_with_residual``, ``register`` and the estimators of the study ask
for the same registrations several times; a space keeps the last ones, keyed by
a digest of the template, the target (or the data term's own key), the warm start
and the space's parameters (including :meth:`RegistrationSettings.key`).
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict

import numpy as np

from manifolds.data_terms import DataTerm

__all__ = ["RegistrationCache", "registration_key"]


def registration_key(params: tuple, template, target, initial_momenta, start=None):
    """Digest of a registration's inputs and the space's ``params``; None when ``target``
    is a data term without a ``key()`` (such registrations are not cached)."""
    h = hashlib.blake2b(digest_size=20)
    if isinstance(target, DataTerm):
        if not callable(getattr(target, "key", None)):
            return None
        target = np.frombuffer(f"{type(target).__name__}:{target.key()}".encode(), np.uint8)
    for arr in (template, target, initial_momenta, start):
        h.update(b"none" if arr is None else np.ascontiguousarray(arr).tobytes())
    h.update(repr(params).encode())
    return h.digest()


class RegistrationCache:
    """Least-recently-used store of registration results (``size`` of them; 0 keeps none)."""

    def __init__(self, size: int):
        self.size = int(size)
        self._items: OrderedDict = OrderedDict()

    def __len__(self) -> int:
        return len(self._items)

    def get(self, key):
        """The result stored under ``key`` (and mark it recent), or None."""
        if key is None or key not in self._items:
            return None
        self._items.move_to_end(key)
        return self._items[key]

    def put(self, key, result) -> None:
        """Store ``result`` (made read-only) under ``key``, evicting the oldest beyond ``size``."""
        for arr in (result.momenta, result.residual, result.deformed, result.control_points):
            if arr is not None:
                arr.setflags(write=False)
        if self.size <= 0 or key is None:
            return
        self._items[key] = result
        while len(self._items) > self.size:
            self._items.popitem(last=False)

    def clear(self) -> None:
        """Forget every stored registration."""
        self._items.clear()
