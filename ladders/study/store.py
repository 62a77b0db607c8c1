"""Crash-safe storage of a study's results: one JSON file per subject, written atomically.

A subject's file is written to a temporary name in the same folder, flushed to
disk and renamed over the final name (an atomic operation on POSIX and
Windows), so a run killed at any moment leaves either the complete file or no
file. Each file records the hash of the parameters it was computed with; a
rerun skips the subjects whose file exists with the same hash.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path

import numpy as np

__all__ = ["atomic_write_text", "array_digest", "config_hash", "SubjectStore"]


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically (temporary file, fsync, rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def array_digest(arr) -> str:
    """A short hash of an array's dtype, shape and bytes."""
    arr = np.ascontiguousarray(arr)
    h = hashlib.sha256(f"{arr.dtype.str}{arr.shape}".encode())
    h.update(arr.tobytes())
    return h.hexdigest()[:16]


def config_hash(params: dict) -> str:
    """A short stable hash of JSON-serialisable parameters."""
    blob = json.dumps(params, sort_keys=True, default=str).encode()
    return hashlib.sha256(blob).hexdigest()[:16]


class SubjectStore:
    """Per-subject JSON results under ``folder/subjects/``.

    Parameters
    ----------
    folder : path
        The study's output folder.
    params_hash : str
        Hash of the parameters that determine the results (see :func:`config_hash`).
    """

    def __init__(self, folder: str | Path, params_hash: str):
        self.folder = Path(folder) / "subjects"
        self.params_hash = params_hash
        self.folder.mkdir(parents=True, exist_ok=True)

    def path(self, name: str) -> Path:
        return self.folder / f"{name}.json"

    def load(self, name: str) -> dict | None:
        """The stored result of ``name`` if it exists with the current parameters."""
        path = self.path(name)
        if not path.exists():
            return None
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError):
            return None  # unreadable: recompute (atomic writes make this rare)
        if data.get("params_hash") != self.params_hash:
            return None
        return data

    def save(self, name: str, result: dict) -> None:
        result = dict(result, params_hash=self.params_hash)
        atomic_write_text(self.path(name), json.dumps(result, indent=1))

    def done(self, names) -> set[str]:
        """Names among ``names`` already computed with the current parameters."""
        return {n for n in names if self.load(n) is not None}
