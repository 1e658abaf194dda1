"""Command-line argument checks: argparse types and a parser whose errors are one ``gasp: error:`` line.

The CLI's own errors (:mod:`gasp_core.cli.main`) are one line, ``gasp: error: ...``, exit status 2;
argparse by default prints a usage block and ``gasp simulate: error: ...``. :class:`GaspArgumentParser`
makes a bad argument read like every other bad input.
"""
from __future__ import annotations

import argparse
import sys
from typing import NoReturn


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1 (``--frames``).

    Raises
    ------
    argparse.ArgumentTypeError
        For ``0``, a negative number or text that is not an integer; the message quotes it.
    """
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer (>= 1), got {text!r}")
    return value


class GaspArgumentParser(argparse.ArgumentParser):
    """An ArgumentParser whose usage errors are one line on stderr, exit status 2.

    ``gasp: error: <what argparse says> (see '<prog> -h')``; sub-parsers made through
    ``add_subparsers`` inherit the class.
    """

    def error(self, message: str) -> NoReturn:
        sys.stderr.write(f"gasp: error: {message} (see '{self.prog} -h')\n")
        sys.exit(2)
