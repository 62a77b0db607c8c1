"""Claims on a (subject, ``alpha^2``) pair, so that two runs into one folder share the work.

Before computing a pair a run creates ``<result file>.claim`` with
``O_CREAT | O_EXCL``, holding its host, process id and the process's start
time. Another run that finds the claim waits for the result instead of
computing it again; the claim of a process that no longer exists on the same
host (or whose process id now belongs to a process started later) is stale and
taken over. A plain file lock gives the mutual exclusion but not the rest:
waiting for another run's result and reusing it, and telling a dead holder from
a live one across hosts sharing the folder (``docs/study.md``).
"""

from __future__ import annotations

import json
import os
import socket
import time
from pathlib import Path

__all__ = ["Claim"]

_UNREADABLE_CLAIM_S = 60.0  # an unreadable claim older than this is abandoned


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


class Claim:
    """The claim file of one pair, next to its result file ``path``."""

    def __init__(self, result_path: Path):
        self.path = result_path.with_name(result_path.name + ".claim")

    def acquire(self) -> bool:
        """Claim the pair for this process; ``False`` if a live process holds it."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        pid = os.getpid()
        body = json.dumps({"host": socket.gethostname(), "pid": pid, "start": _process_start(pid)})
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666)
            except FileExistsError:
                if not self.is_stale():
                    return False
                self.path.unlink(missing_ok=True)  # holder died: take the pair over
                continue
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(body)
            return True
        return False

    def is_stale(self) -> bool:
        """Whether the claim (if any) belongs to a dead process on this host."""
        try:
            holder = json.loads(self.path.read_text(encoding="utf-8"))
            host, pid = holder["host"], int(holder["pid"])
        except FileNotFoundError:
            return True
        except (OSError, ValueError, KeyError, TypeError):
            # Being written right now, or its writer died before writing: wait a while.
            try:
                return time.time() - self.path.stat().st_mtime > _UNREADABLE_CLAIM_S
            except OSError:
                return True
        if host != socket.gethostname():
            return False  # cannot check another host's processes
        if not _pid_alive(pid):
            return True
        start = holder.get("start")  # a live pid with another start time was reused
        return start is not None and _process_start(pid) not in (None, start)

    def release(self) -> None:
        """Remove the claim file."""
        self.path.unlink(missing_ok=True)
