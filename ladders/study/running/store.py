"""Crash-safe storage of a study's results: one JSON file per (subject, alpha^2).

Layout of an output folder::

    results/<config>/config.json                  settings shared by the files below
    results/<config>/<subject>/alpha2=<a>.json    one result per subject and alpha^2

``<config>`` is a hash of every setting the results depend on except the
alpha^2 sweep (kernel width, control points, integrator, atlas, faces, ...),
so extending the sweep reuses the finished pairs while a run with other
settings writes into its own folder and never touches earlier results.

Each file is written to a temporary name in the same folder, flushed to disk
and renamed over the final name (atomic on POSIX and Windows), with the
permissions the user's umask gives. A file is reused only if it parses, carries
the expected parameter hash and has every field of :data:`RESULT_SCHEMA`;
otherwise the pair is recomputed. Before computing a pair a run creates a
claim file with ``O_CREAT | O_EXCL`` holding its host, process id and the
process's start time, so two runs into one folder never compute the same pair
twice; the claim of a process that no longer exists on the same host (or whose
pid now belongs to a process started later) is taken over.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import socket
import tempfile
import time
from pathlib import Path

import numpy as np

from ..errors import CohortError

__all__ = [
    "atomic_write_text",
    "array_digest",
    "config_hash",
    "validate_subject_name",
    "RESULT_SCHEMA",
    "check_result",
    "missing_fields",
    "PairStore",
]

#: Fields a successful pair result must hold: top-level numbers, then per-variant numbers.
RESULT_SCHEMA = {
    "numbers": ("registration_error", "rkhs_norm", "inverse_consistency", "n_registrations"),
    "flags": ("converged",),
    "variants": {
        "residual": (
            "midpoint_distance", "centrality", "involutivity", "transvectivity", "ase"
        ),
        "no_residual": (
            "midpoint_distance", "centrality", "involutivity", "transvectivity", "ase"
        ),
        "fanning": ("ase",),
    },
    "maps": ("subject", "residual", "no_residual", "fanning"),
}  # fmt: skip


_UNREADABLE_CLAIM_S = 60.0  # an unreadable claim older than this is abandoned


def _umask() -> int:
    """The process's umask, read without changing it where the OS allows."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except OSError:
        pass
    mask = os.umask(0o022)  # no read-only query elsewhere: set and restore
    os.umask(mask)
    return mask


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically (temporary file, fsync, rename).

    The file gets mode ``0o666 & ~umask``, like a file opened for writing
    (the temporary file is created ``0o600``).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask())
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


def validate_subject_name(name) -> str:
    """Return ``name`` if it is usable as a file name inside the output folder.

    Raises
    ------
    CohortError
        (a ``ValueError``) If ``name`` is not a non-empty string, is ``.`` or ``..``, starts with a
        dot, or holds a path separator or a NUL character.
    """
    bad = (
        not isinstance(name, str)
        or not name.strip()
        or name.startswith(".")
        or any(c in name for c in ("/", "\\", "\0"))
    )
    if bad:
        raise CohortError(
            "subjects: a subject name must be a non-empty file name without path "
            f"separators, NUL or a leading dot ('.', '..'), got {name!r}"
        )
    return name


def _finite(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def missing_fields(data) -> list[str]:
    """Fields of :data:`RESULT_SCHEMA` that a pair result lacks (or holds with a bad value)."""
    if not isinstance(data, dict):
        return ["<not a JSON object>"]
    if data.get("status") == "failed":
        return [] if isinstance(data.get("error"), str) else ["error"]
    if data.get("status") != "ok":
        return ["status"]
    missing = [k for k in RESULT_SCHEMA["numbers"] if not _finite(data.get(k))]
    missing += [k for k in RESULT_SCHEMA["flags"] if not isinstance(data.get(k), bool)]
    for variant, names in RESULT_SCHEMA["variants"].items():
        node = data.get(variant)
        node = node if isinstance(node, dict) else {}
        missing += [f"{variant}.{n}" for n in names if not _finite(node.get(n))]
    maps = data.get("las")
    maps = maps if isinstance(maps, dict) else {}
    missing += [f"las.{k}" for k in RESULT_SCHEMA["maps"] if not isinstance(maps.get(k), list)]
    return missing


def check_result(data) -> bool:
    """Whether a stored pair result has every field of :data:`RESULT_SCHEMA`."""
    return not missing_fields(data)


def _process_start(pid: int) -> str | None:
    """Start time of a process (Linux ``/proc``), to tell a reused pid from the claimant."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as fh:
            return fh.read().rsplit(")", 1)[1].split()[19]
    except (OSError, IndexError):
        return None


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # exists, owned by someone else
    except OSError:
        return False
    return True


class PairStore:
    """Results of one configuration: a JSON file per (subject, alpha^2).

    Parameters
    ----------
    folder : path
        The study's output folder.
    config_id : str
        Hash of the settings shared by all pairs (see :func:`config_hash`); the
        files live in ``folder/results/<config_id>/``.
    """

    def __init__(self, folder: str | Path, config_id: str):
        self.root = Path(folder) / "results" / config_id
        self.config_id = config_id
        self.root.mkdir(parents=True, exist_ok=True)

    def path(self, name: str, alpha2: float) -> Path:
        return self.root / validate_subject_name(name) / f"alpha2={float(alpha2)!r}.json"

    def load(self, name: str, alpha2: float, params_hash: str) -> dict | None:
        """The stored result of a pair if it is complete and has ``params_hash``."""
        path = self.path(name, alpha2)
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None  # missing or unreadable: recompute
        if not check_result(data) or data.get("params_hash") != params_hash:
            return None
        return data

    def save(self, name: str, alpha2: float, params_hash: str, result: dict) -> None:
        result = dict(result, subject=name, alpha2=float(alpha2), params_hash=params_hash)
        atomic_write_text(self.path(name, alpha2), json.dumps(result, indent=1))

    # Claims -------------------------------------------------------------------
    def _claim_path(self, name: str, alpha2: float) -> Path:
        p = self.path(name, alpha2)
        return p.with_name(p.name + ".claim")

    def claim(self, name: str, alpha2: float) -> bool:
        """Claim a pair for this process; ``False`` if a live process holds it."""
        path = self._claim_path(name, alpha2)
        path.parent.mkdir(parents=True, exist_ok=True)
        pid = os.getpid()
        body = json.dumps({"host": socket.gethostname(), "pid": pid, "start": _process_start(pid)})
        for _ in range(2):
            try:
                fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666)
            except FileExistsError:
                if not self.claim_is_stale(name, alpha2):
                    return False
                path.unlink(missing_ok=True)  # holder died: take the pair over
                continue
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(body)
            return True
        return False

    def claim_is_stale(self, name: str, alpha2: float) -> bool:
        """Whether the pair's claim (if any) belongs to a dead process on this host."""
        path = self._claim_path(name, alpha2)
        try:
            holder = json.loads(path.read_text(encoding="utf-8"))
            host, pid = holder["host"], int(holder["pid"])
        except FileNotFoundError:
            return True
        except (OSError, ValueError, KeyError, TypeError):
            # Being written right now, or its writer died before writing: wait a while.
            try:
                return time.time() - path.stat().st_mtime > _UNREADABLE_CLAIM_S
            except OSError:
                return True
        if host != socket.gethostname():
            return False  # cannot check another host's processes
        if not _pid_alive(pid):
            return True
        start = holder.get("start")  # a live pid with another start time was reused
        return start is not None and _process_start(pid) not in (None, start)

    def release(self, name: str, alpha2: float) -> None:
        self._claim_path(name, alpha2).unlink(missing_ok=True)
