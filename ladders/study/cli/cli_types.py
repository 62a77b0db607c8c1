"""Argument types and error reporting of the ``symladders`` command line.

Every flag is checked when the command line is parsed, before any work starts,
and a bad value is reported as one line on standard error naming the flag,
what was expected and what was given. Exit statuses of ``symladders``:

* ``0``: success;
* ``2``: invalid input (a flag, a mesh folder, an output folder, a scheduler);
* ``3``: internal error: one line says so and where the full traceback was
  written (``symladders-error.log`` in the output folder, or a temporary file
  when the output folder cannot be written);
* ``130``: interrupted (Ctrl-C);
* ``141``: standard output was closed by its reader (``symladders study | head``):
  the command ends quietly, as standard tools do on SIGPIPE.
"""

from __future__ import annotations

import argparse
import difflib
import math
import os
import re
import socket
import tempfile
import traceback
from pathlib import Path
from urllib.parse import urlsplit

from ..running.preflight import check_sigma

__all__ = [
    "EXIT_USAGE",
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_BROKEN_PIPE",
    "UsageError",
    "OneLineParser",
    "DefaultsFormatter",
    "positive_int",
    "nonnegative_int",
    "jobs_count",
    "positive_float",
    "output_folder",
    "existing_folder",
    "existing_file",
    "nonnegative_float",
    "checks_files",
    "scheduler_address",
    "log_internal_error",
    "check_sigma",
]

EXIT_USAGE = 2
EXIT_INTERNAL = 3
EXIT_INTERRUPTED = 130
EXIT_BROKEN_PIPE = 141
ERROR_LOG = "symladders-error.log"


class UsageError(Exception):
    """Invalid command-line input: reported in one line, exit status 2."""


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (``prog: error: message``).

    Instead of printing the usage and exiting, :meth:`error` raises
    :class:`UsageError`, which the entry point reports on standard error. A
    mistyped subcommand is answered with the closest one. Options must be
    spelled in full (``allow_abbrev=False``: ``--mesh`` is not ``--meshes``).
    Subcommand parsers created by ``add_subparsers`` inherit the class.
    """

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        wrong = re.match(r"argument (\w+): invalid choice: '([^']*)' \(choose from (.*)\)", message)
        commands = self._subcommands()
        if wrong and wrong.group(1) == "command" and commands:
            close = difflib.get_close_matches(wrong.group(2), commands, n=1, cutoff=0.5)
            if close:
                raise UsageError(
                    f"{self.prog}: error: unknown command {wrong.group(2)!r}; did you mean "
                    f"{close[0]!r}? (see {self.prog} {close[0]} --help)"
                )
            message = f"unknown command {wrong.group(2)!r}, choose from {', '.join(commands)}"
        raise UsageError(f"{self.prog}: error: {message} (see {self.prog} --help)")

    def _subcommands(self) -> list[str]:
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                return list(action.choices)
        return []


class DefaultsFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Help with each option's default, except where there is none to show
    (``None`` or a ``False`` switch) or the help text already gives it."""

    def _get_help_string(self, action) -> str:
        if action.default is None or action.default is False or "%(default)" in (action.help or ""):
            return action.help or ""
        return super()._get_help_string(action)


def checks_files(syntax):
    """Mark an argparse type that looks at the file system or the network with ``syntax``,
    the check of its value's form alone (``type.syntax``): a command written in the docs,
    with placeholders for its files, is parsed with it (tests/test_docs_commands.py)."""

    def mark(function):
        function.syntax = syntax
        return function

    return mark


def _path_syntax(text: str) -> Path:
    if not str(text).strip():
        raise argparse.ArgumentTypeError("expected a path, got an empty string")
    return Path(text)


def _integer(text: str) -> int:
    try:
        return int(str(text).strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None


def positive_int(text: str) -> int:
    """An integer ``>= 1``."""
    value = _integer(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer (>= 1), got {text!r}")
    return value


def nonnegative_int(text: str) -> int:
    """An integer ``>= 0`` (e.g. a seed)."""
    value = _integer(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}")
    return value


def jobs_count(text: str) -> int:
    """``-1`` (all cores) or a positive number of workers."""
    value = _integer(text)
    if value != -1 and value < 1:
        raise argparse.ArgumentTypeError(
            f"expected -1 (all cores) or a positive integer, got {text!r}"
        )
    return value


def positive_float(text: str) -> float:
    """A finite number ``> 0``."""
    try:
        value = float(str(text).strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a finite positive number, got {text!r}")
    return value


def nonnegative_float(text: str) -> float:
    """A finite number ``>= 0``."""
    try:
        value = float(str(text).strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}") from None
    if not 0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text!r}")
    return value


@checks_files(lambda text: str(_path_syntax(text)) and str(text))
def output_folder(text: str) -> str:
    """A writable folder, or a path where one can be created (not a file).

    Nothing is created here: the first existing ancestor must be a writable folder.
    """
    if not str(text).strip():
        raise argparse.ArgumentTypeError("expected a folder path, got an empty string")
    path = Path(text).expanduser()
    if path.exists():
        if not path.is_dir():
            raise argparse.ArgumentTypeError(f"expected a folder, got the file {text!r}")
        if not os.access(path, os.W_OK | os.X_OK):
            raise argparse.ArgumentTypeError(f"expected a writable folder, got {text!r}")
        return str(text)
    parent = path.absolute().parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise argparse.ArgumentTypeError(
            f"expected a folder that can be created, got {text!r} ({parent} is a file)"
        )
    if not os.access(parent, os.W_OK | os.X_OK):
        raise argparse.ArgumentTypeError(
            f"expected a folder that can be created, got {text!r} ({parent} is not writable)"
        )
    return str(text)


@checks_files(_path_syntax)
def existing_file(text: str) -> Path:
    """An argparse type: a path to an existing file (not a folder)."""
    path = Path(text).expanduser()
    if not path.is_file():
        what = "a folder" if path.is_dir() else "no such file"
        raise argparse.ArgumentTypeError(f"expected a file, got {text!r} ({what})")
    return path


@checks_files(_path_syntax)
def existing_folder(text: str) -> Path:
    """An existing folder (e.g. of meshes)."""
    path = Path(text).expanduser()
    if not path.is_dir():
        what = "a file" if path.exists() else "no such folder"
        raise argparse.ArgumentTypeError(f"expected an existing folder, got {text!r} ({what})")
    return path


def _host_port(text: str) -> tuple[str, int]:
    url = urlsplit(text if "://" in text else f"tcp://{text}")
    try:
        host, port = url.hostname, url.port
    except ValueError:
        host, port = None, None
    if url.scheme not in ("tcp", "tls") or not host or port is None:
        raise argparse.ArgumentTypeError(
            f"expected a scheduler address such as tcp://host:8786, got {text!r}"
        )
    return host, port


@checks_files(lambda text: _host_port(text) and text)
def scheduler_address(text: str, timeout: float = 3.0) -> str:
    """A reachable Dask scheduler address ``[tcp://]host:port``.

    The address is parsed and a TCP connection is attempted (``timeout``
    seconds), so that a typo or a stopped scheduler is reported at once.
    """
    host, port = _host_port(text)
    try:
        with socket.create_connection((host, port), timeout=timeout):
            pass
    except OSError as exc:
        raise argparse.ArgumentTypeError(
            f"cannot reach the Dask scheduler at {text!r} ({exc.strerror or exc}); is it running?"
        ) from None
    return text


def log_internal_error(exc: BaseException, output: str | None) -> Path:
    """Write the traceback of ``exc`` to a log file and return its path.

    The log goes to ``symladders-error.log`` in ``output`` when that folder
    exists (or can be created) and is writable, else to a temporary file.
    """
    text = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
    if output:
        try:
            folder = Path(output)
            folder.mkdir(parents=True, exist_ok=True)
            path = folder / ERROR_LOG
            path.write_text(text)
            return path
        except OSError:
            pass
    fd, name = tempfile.mkstemp(prefix="symladders-error-", suffix=".log")
    with os.fdopen(fd, "w") as fh:
        fh.write(text)
    return Path(name)
