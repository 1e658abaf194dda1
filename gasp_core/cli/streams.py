"""Stdout cut short: a reader that stops reading, a closed stdout, a full device (issue 41).

Stdout carries the command's report (``gasp simulate --json``'s events, the ``wrote N frames`` line), never its
result: a run's result is its output folder. So a failure to write stdout never loses a run. The reporter stops
writing to stdout at the first failure and keeps it (:attr:`gasp_core.run.report.Reporter.stdout_error`), and
then :func:`finish` says it:

- a broken pipe (the reader went away: ``gasp simulate --json | head -n 1``): the run stops at the end of the
  frame in flight as a stopped run does (``gasp_core.run.pipeline``: its frames and checkpoint kept in its partial
  folder for ``--resume``; its one line on stderr says where), no error is said, and the exit status is 141
  (128 + SIGPIPE), what a shell reports for a Unix tool killed by SIGPIPE. Python ignores SIGPIPE and raises
  ``BrokenPipeError`` instead; setting SIGPIPE back to its default would kill the process in the middle of a
  frame's files, so it is not done (Python docs, 'Note on SIGPIPE').
- anything else (stdout closed, ``>&-``; a full device, ``> /dev/full``): the run goes on to its end, then one
  line ``gasp: error: cannot write to stdout: <cause>`` (naming the output folder) and exit status 2.

A command that failed on its own keeps its line and its exit status. Either way ``/dev/null`` is then put on
file descriptor 1, so that the interpreter's last flush of ``sys.stdout`` at exit does not raise again
(``Exception ignored ... BrokenPipeError``), as the Python docs' note on SIGPIPE does.
"""
from __future__ import annotations

import errno
import io
import os
import sys

#: Exit status after a broken pipe on stdout: 128 + SIGPIPE (13), as a shell reports a tool killed by SIGPIPE.
BROKEN_PIPE_STATUS = 141


class ClosedStdout(io.TextIOBase):
    """``sys.stdout`` of a command started with stdout closed (Python sets it to None): every write raises
    ``OSError(EBADF)`` saying so, which the reporter keeps and :func:`finish` says; flush does nothing."""

    def writable(self) -> bool:
        return True

    def write(self, s: str) -> int:
        raise OSError(errno.EBADF, "it is closed (the command was started without one, e.g. with >&-)")

    def flush(self) -> None:
        pass


def _is_open(fd: int) -> bool:
    try:
        os.fstat(fd)
        return True
    except OSError:
        return False


def guard_closed() -> None:
    """Started with stdout closed (``sys.stdout`` None): put ``/dev/null`` on file descriptor 1, so that no file the
    run opens gets it (an engine's banner written to fd 1 would land in a frame file), and make ``sys.stdout`` a
    :class:`ClosedStdout`. Nothing otherwise."""
    if sys.stdout is not None:
        return
    if not _is_open(1):
        fd = os.open(os.devnull, os.O_WRONLY)
        if fd != 1:
            os.dup2(fd, 1)
            os.close(fd)
    sys.stdout = ClosedStdout()


def _flush_stdout() -> OSError | None:
    """Flush ``sys.stdout`` (a ``print`` still in its buffer); the error, if it fails."""
    try:
        if sys.stdout is not None:
            sys.stdout.flush()
    except OSError as e:
        return e
    except ValueError:         # closed by someone else: nothing more can be written or lost
        return None
    return None


def _quiet_stdout() -> None:
    """``/dev/null`` on stdout's file descriptor: what is left in ``sys.stdout``'s buffer goes nowhere at exit."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, fd)
    finally:
        os.close(devnull)


def describe(error: OSError) -> str:
    """``error`` (a failed write to stdout) in words: ``cannot write to stdout: <cause>``."""
    return f"cannot write to stdout: {error.strerror or error}"


def finish(reporter, code: int) -> int:
    """After the command: say a failure to write stdout (see the module docstring) and return the exit status.

    Parameters
    ----------
    reporter : Reporter
        The command's reporter; its ``stdout_error`` (the first failed write, or None) and ``output`` (the
        result's folder, or None).
    code : int
        The command's own exit status.

    Returns
    -------
    int
        141 after a broken pipe (the run finished, or stopped by it: 130); else ``code`` when the command failed on
        its own or stdout took everything, and 2 after any other failure (its one ``gasp: error:`` line on stderr).
    """
    error = getattr(reporter, "stdout_error", None) or _flush_stdout()
    if error is None:
        return code
    _quiet_stdout()
    if isinstance(error, BrokenPipeError) and code in (0, 130):   # finished, or stopped by the broken pipe itself
        return BROKEN_PIPE_STATUS
    if code != 0:
        return code
    output = getattr(reporter, "output", None)
    kept = f"; the command itself finished: its output is in '{output}'" if output else ""
    print(f"gasp: error: {describe(error)}{kept}", file=sys.stderr)
    return 2
