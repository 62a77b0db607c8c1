"""Content fingerprints of files and folders, with a cache keyed by size and modification time.

A step of ``symladders run`` is reused when the fingerprint of what it reads and of what
it wrote are those recorded when it last ran. A fingerprint is the SHA-256 of the
sorted relative paths and contents of the files (links followed), so that a file
rewritten with the same bytes (a table written again) leaves it unchanged; a file
whose size and modification time are those of the cache is not read again.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from ..files import file_sha256

__all__ = ["Fingerprints"]


class Fingerprints:
    """Fingerprints of paths, sharing one cache of file hashes.

    Parameters
    ----------
    cache : dict, optional
        ``{absolute path: [size, mtime_ns, sha256]}`` from an earlier run (updated).
    """

    def __init__(self, cache: dict | None = None):
        self.cache = {} if cache is None else dict(cache)

    def file(self, path: Path) -> str:
        """The SHA-256 of a file's bytes (from the cache when its size and time match)."""
        stat = os.stat(path)  # follows links
        key = str(Path(path).absolute())
        cached = self.cache.get(key)
        if cached is not None and cached[0] == stat.st_size and cached[1] == stat.st_mtime_ns:
            return cached[2]
        digest = file_sha256(path)
        self.cache[key] = [stat.st_size, stat.st_mtime_ns, digest]
        return digest

    def paths(self, paths, exclude: tuple = ()) -> str | None:
        """The fingerprint of files and folders (recursively), None when one is missing.

        ``exclude``: file names left out (e.g. a log written beside the results).
        """
        h = hashlib.sha256()
        for root in paths:
            root = Path(root)
            if root.is_file():
                h.update(f"{root.name}\0{self.file(root)}\n".encode())
                continue
            if not root.is_dir():
                return None
            for path in sorted(root.rglob("*")):
                if not path.is_file() or path.name in exclude:
                    continue
                rel = path.relative_to(root).as_posix()
                h.update(f"{root.name}/{rel}\0{self.file(path)}\n".encode())
        return h.hexdigest()
