"""Signals before the command's own handlers: a stop during start-up is one line and exit 130.

``gasp simulate`` installs its stop handlers (:mod:`gasp_core.run.stop`) once its arguments are parsed;
before that, while Python imports the command, a SIGTERM killed the process with status 143 and no
line, and Ctrl-C printed an import traceback. :func:`install` (called by :mod:`gasp_core.cli`'s
``__init__`` when the process is the ``gasp`` command, never when a library or a test imports GASP)
makes SIGTERM, SIGINT and SIGHUP print ``gasp: interrupted by SIGTERM; no partial output was kept``
and exit 130 at once; nothing has been written at that point. The stop handlers replace these while a
command runs and put them back after it, so a signal while the process ends is said the same way.
"""
from __future__ import annotations

import os
import signal
import sys


def _exit(signum, _frame) -> None:
    os.write(2, f"gasp: interrupted by {signal.Signals(signum).name}; no partial output was kept\n".encode())
    os._exit(130)


def is_command_line() -> bool:
    """True when this process is the ``gasp`` command: the console script, or ``python -m gasp_core ...``
    (while ``-m`` imports the package ``sys.argv[0]`` is ``"-m"``; once runpy runs ``gasp_core/__main__.py``,
    which imports this module, it is that file's path)."""
    first = sys.argv[0] if sys.argv else ""
    if os.path.basename(first) == "gasp" or first == "-m":
        return True
    return os.path.basename(first) == "__main__.py" and os.path.basename(os.path.dirname(first)) == "gasp_core"


_SIGNALS = tuple(s for s in (getattr(signal, n, None) for n in ("SIGTERM", "SIGINT", "SIGHUP")) if s is not None)
_INSTALLED = []


def install() -> None:
    """Exit 130 with one line on SIGTERM, SIGINT or SIGHUP (main thread of the ``gasp`` command only)."""
    for sig in _SIGNALS:
        if signal.getsignal(sig) is not signal.SIG_IGN:
            signal.signal(sig, _exit)
            _INSTALLED.append(sig)


def finished() -> None:
    """The command has said its last line: from now on these signals are ignored, so that one arriving while
    Python shuts down (when it puts the default handlers back) does not turn the exit status into 143."""
    for sig in _INSTALLED:
        signal.signal(sig, signal.SIG_IGN)
