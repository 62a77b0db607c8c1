"""Running ``symladders`` in-process, with its outputs captured."""

import contextlib
import io

from ladders.study.cli import main


def run_cli(*argv) -> tuple[int, str, str]:
    """``symladders ARGV``: exit status, standard output, standard error."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main([str(a) for a in argv])
    return status, out.getvalue(), err.getvalue()
