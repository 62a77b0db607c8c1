"""The options the ``symladders`` commands share, each defined once: one type, format, help
and default wherever it appears.

* ``--output/-o``: what the command writes (a folder; ``atlas``: the atlas's file);
* ``--jobs/-j N``, ``--no-progress``, ``--backend {loky,dask}`` and ``--scheduler ADDRESS``:
  every command that runs a batch of subjects or images (:func:`add_batch_arguments`);
  :func:`parallel_backend` runs the batch on the chosen backend;
* ``--seed``, ``--permutations``, ``--compare A,B``: the statistics' draws and groups;
* ``--cut-planes TABLE``: the cut-plane table (:mod:`ladders.study.imaging.plane_table`),
  read by :func:`read_cut_planes`;
* ``--alpha2``: the regularisation alpha^2 (eq. 3), comma-separated values.

A table that cannot be used becomes a one-line usage error naming the flag, the file,
the line and the column (:func:`table_usage_error`).
"""

from __future__ import annotations

import argparse
import contextlib
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..meshes.mesh_io import WRITE_EXTENSIONS
from ..recommendations import RECOMMENDED_ALPHA2
from .cli_types import (
    UsageError,
    existing_file,
    jobs_count,
    nonnegative_int,
    output_folder,
    positive_int,
    scheduler_address,
)

__all__ = [
    "MESH_FORMATS",
    "JOBS_DEFAULT",
    "PERMUTATIONS_DEFAULT",
    "RECOMMENDED_ALPHA2",
    "add_output",
    "add_jobs",
    "add_no_progress",
    "add_backend_arguments",
    "add_batch_arguments",
    "add_seed",
    "add_permutations",
    "add_compare",
    "add_cut_planes",
    "add_alpha2",
    "alpha2_values",
    "group_pair",
    "parallel_backend",
    "read_cut_planes",
    "table_usage_error",
]

#: The mesh formats a command writes (``--ext``).
MESH_FORMATS = tuple(sorted(ext.lstrip(".") for ext in WRITE_EXTENSIONS))
#: Workers of a batch by default: one per core.
JOBS_DEFAULT = -1
#: Permutations per test by default.
PERMUTATIONS_DEFAULT = 10000


def add_output(p, default: str | None, what: str, *, file_type=None) -> None:
    """``--output/-o``: the folder the command writes (``what`` says what it holds), or with
    ``file_type`` (an argparse type) a file."""
    p.add_argument("--output", "-o", type=file_type or output_folder, default=default,
                   metavar="FILE" if file_type else "FOLDER", help=what)  # fmt: skip


def add_jobs(p) -> None:
    """``--jobs/-j N``: workers of the batch (-1: one per core)."""
    p.add_argument("--jobs", "-j", type=jobs_count, default=JOBS_DEFAULT, metavar="N",
                   help="workers of the batch: subjects or images at a time (-1: one per "
                        "core)")  # fmt: skip


def add_no_progress(p) -> None:
    """``--no-progress``: no progress report."""
    p.add_argument("--no-progress", action="store_true",
                   help="no progress report (bar or line per item)")  # fmt: skip


def add_backend_arguments(p) -> None:
    """``--backend {loky,dask}`` and ``--scheduler ADDRESS`` (see :func:`parallel_backend`)."""
    p.add_argument("--backend", choices=("loky", "dask"), default="loky",
                   help="where the batch's workers run: 'loky', processes on this machine; "
                        "'dask', a Dask cluster (--scheduler; pip install "
                        "'symladders[cluster]')")  # fmt: skip
    p.add_argument("--scheduler", type=scheduler_address, default=None, metavar="ADDRESS",
                   help="address of a running Dask scheduler, e.g. tcp://host:8786 (with "
                        "--backend dask); default: a local cluster for the command")  # fmt: skip


def add_batch_arguments(p) -> None:
    """The flags of a command that runs a batch of subjects or images: ``--jobs``,
    ``--no-progress``, ``--backend`` and ``--scheduler``."""
    add_jobs(p)
    add_no_progress(p)
    add_backend_arguments(p)


def add_seed(p) -> None:
    """``--seed``: the seed of every random draw of the command."""
    p.add_argument("--seed", type=nonnegative_int, default=0, metavar="INT",
                   help="seed of every random draw of the command")  # fmt: skip


def add_permutations(p) -> None:
    """``--permutations``: permutations per test."""
    p.add_argument("--permutations", type=positive_int, default=PERMUTATIONS_DEFAULT, metavar="N",
                   help="permutations per test (of the group labels, or of the model's "
                        "residuals)")  # fmt: skip


def group_pair(text: str) -> tuple[str, str]:
    """``A,B``: two names (e.g. groups), A compared against B."""
    names = tuple(t.strip() for t in str(text).split(","))
    if len(names) != 2 or not all(names) or names[0] == names[1]:
        raise argparse.ArgumentTypeError(f"expected two different group names as A,B, got {text!r}")
    return names


def add_compare(p) -> None:
    """``--compare A,B``: the two groups compared."""
    p.add_argument("--compare", type=group_pair, default=None, metavar="A,B",
                   help="the two groups to compare, A against B (B the reference); needed when "
                        "the groups table has more than two")  # fmt: skip


def add_cut_planes(p) -> None:
    """``--cut-planes TABLE``: the cut-plane table (:mod:`~ladders.study.imaging.plane_table`)."""
    p.add_argument("--cut-planes", type=existing_file, default=None, metavar="TABLE",
                   help="CSV table with the columns image,x,y,z,nx,ny,nz and optionally frame: "
                        "a plane (a point and its normal, world mm) beyond which the surface is "
                        "removed, e.g. the valve plane; image: the image's file name or path, or a "
                        "series' subject; frame (0-based): that frame of a series only, empty or "
                        "absent: every frame")  # fmt: skip


def alpha2_values(text: str) -> tuple[float, ...]:
    """``A[,B...]``: positive finite alpha^2 values, comma-separated."""
    try:
        values = tuple(float(v) for v in str(text).split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated positive numbers, got {text!r}"
        ) from None
    if not values or any(not np.isfinite(v) or v <= 0 for v in values):
        raise argparse.ArgumentTypeError(f"expected positive finite numbers, got {text!r}")
    return values


def add_alpha2(p, default, what: str) -> None:
    """``--alpha2 A[,B...]``: alpha^2 values of eq. 3 (``what`` says which are used)."""
    p.add_argument("--alpha2", type=alpha2_values, default=default, metavar="A[,B...]",
                   help=what)  # fmt: skip


@contextlib.contextmanager
def parallel_backend(args, command: str) -> Iterator[None]:
    """Run the batches of the block on ``args.backend``: nothing to set up for 'loky'; for
    'dask', a :class:`dask.distributed.Client` (of ``args.scheduler``, else a local
    cluster) with joblib's Dask backend, so that every ``run_batch`` of the block sends
    its items to the cluster. The client is closed at the end of the block.

    Raises
    ------
    UsageError
        ``--scheduler`` without ``--backend dask``, or Dask not installed.
    """
    if args.backend != "dask":
        if getattr(args, "scheduler", None):
            raise UsageError(f"symladders {command}: error: --scheduler: needs --backend dask")
        yield
        return
    try:
        from dask.distributed import Client
        from joblib import parallel_config
    except ImportError:
        raise UsageError(
            f"symladders {command}: error: --backend dask: needs the optional extra: "
            "pip install 'symladders[cluster]'"
        ) from None
    client = Client(args.scheduler) if args.scheduler else Client(processes=True)
    try:
        with parallel_config(backend="dask"):
            yield
    finally:
        client.close()


def table_usage_error(command: str, flag: str, exc: Exception) -> UsageError:
    """A table's refusal (:class:`ladders.tables.TableError`) as the command's one-line
    usage error naming the flag."""
    return UsageError(f"symladders {command}: error: {flag}: {exc}")


def read_cut_planes(path: Path | None, command: str, names: dict | None = None) -> dict | None:
    """``{image: {frame or "all": plane}}`` of ``--cut-planes`` (None without it).

    ``names`` maps every name an image may be given by to its frame count (None: a 3-D
    image); with it, a row of an image not given or a frame beyond its series is refused.

    Raises
    ------
    UsageError
        One line naming ``--cut-planes``, the file, the line and the column.
    """
    from ladders.tables import TableError

    from ..imaging.plane_table import check_plane_table, planes_by_image, read_plane_table

    if path is None:
        return None
    try:
        table = read_plane_table(path)
        if names is not None:
            check_plane_table(table, names)
    except TableError as exc:
        raise table_usage_error(command, "--cut-planes", exc) from None
    return planes_by_image(table)
