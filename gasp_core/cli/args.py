"""Command-line argument checks: argparse types and a parser whose errors are one ``gasp: error:`` line.

The CLI's own errors (:mod:`gasp_core.cli.main`) are one line, ``gasp: error: ...``, exit status 2;
argparse by default prints a usage block and ``gasp simulate: error: ...``. :class:`GaspArgumentParser`
makes a bad argument read like every other bad input.
"""
from __future__ import annotations

import argparse
import re
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


def grid_size(text: str) -> int:
    """argparse type: a grid's ``n_grid``, an integer in the scene's range
    (:data:`gasp_core.scene.values.N_GRID_RANGE`, 8-1024; ``gasp info --n-grid``).

    Raises
    ------
    argparse.ArgumentTypeError
        For text that is not an integer or one outside the range; the message quotes it and names the range.
    """
    from gasp_core.scene.values import N_GRID_RANGE
    lo, hi = N_GRID_RANGE
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer in [{lo}, {hi}], got {text!r}") from None
    if not lo <= value <= hi:
        raise argparse.ArgumentTypeError(f"expected an integer in [{lo}, {hi}] (as a scene's domain.n_grid), "
                                         f"got {text!r}")
    return value


#: The most frames a report's rendered strip takes (``--strip-frames``): each is a 256-pixel column of every run's row,
#: rendered once per run; more than the run's frames already reads as every frame (round 102: 100000000 was taken).
MAX_STRIP_FRAMES = 100


def strip_count(text: str) -> int:
    """argparse type: frames per rendered strip, an integer in ``[0, MAX_STRIP_FRAMES]`` (``--strip-frames``; 0: none).

    Raises
    ------
    argparse.ArgumentTypeError
        For text that is not an integer or one outside the range; the message quotes it and names the range.
    """
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer in [0, {MAX_STRIP_FRAMES}], got {text!r}") from None
    if not 0 <= value <= MAX_STRIP_FRAMES:
        raise argparse.ArgumentTypeError(f"expected an integer in [0, {MAX_STRIP_FRAMES}] (frames per strip; 0: "
                                         f"none), got {text!r}")
    return value


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0 (``--rho``, ``--timeout``).

    Raises
    ------
    argparse.ArgumentTypeError
        For 0, a negative or non-finite number, or text that is not a number; the message quotes it.
    """
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}") from None
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"expected a positive finite number, got {text!r}")
    return value


_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}


def length(text: str) -> float:
    """argparse type: a length in metres from ``"1.7m"``, ``"170cm"``, ``"1700mm"`` or ``"1.7"`` (metres).

    Raises
    ------
    argparse.ArgumentTypeError
        Text that is not a positive number with an optional unit m, cm or mm; the message quotes it.
    """
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(m|cm|mm)?\s*", text)
    if not m or not float(m.group(1)) > 0:
        raise argparse.ArgumentTypeError(f"expected a positive length such as 1.7m, 170cm or 1700mm, got {text!r}")
    metres = float(m.group(1)) * _UNITS[m.group(2) or "m"]
    if not 1e-6 <= metres <= 1e6:       # the scene's own limits on positions and sizes (1e400 was inf)
        raise argparse.ArgumentTypeError(f"expected a length from 1e-6 m to 1e6 m, got {text!r}")
    return metres


class GaspArgumentParser(argparse.ArgumentParser):
    """An ArgumentParser whose usage errors are one line on stderr, exit status 2.

    ``gasp: error: <what argparse says> (see '<prog> -h')``; sub-parsers made through
    ``add_subparsers`` inherit the class.
    """

    def error(self, message: str) -> NoReturn:
        sys.stderr.write(f"gasp: error: {message} (see '{self.prog} -h')\n")
        sys.exit(2)


def add_export_parser(sub, func) -> argparse.ArgumentParser:
    """``gasp export RUN --format F -o OUT [--overwrite] [--split-pieces] [--no-crack-faces] [--allow-missing]``
    (:func:`gasp_core.run.export.export_run`), calling ``func(args)``."""
    from pathlib import Path
    from gasp_core.gs.registry import output_formats
    ex = sub.add_parser("export", help="write an existing run's frames in another format (glTF, OpenUSD, ...)")
    ex.add_argument("run", type=Path, help="a run folder written by gasp simulate")
    ex.add_argument("--format", required=True, choices=output_formats(),
                    help="glb: a folder of KHR_gaussian_splatting GLB files, one per object and frame; glb_sequence: "
                         "one .glb that plays the run; usd: one .usdc with every frame time-sampled; the others as "
                         "gasp simulate --format (docs/formats.md)")
    ex.add_argument("-o", "--output", type=Path, required=True,
                    help="the folder (per-frame formats) or the one file (glb_sequence: .glb; usd: .usdc, .usd, .usda) to "
                         "write (required)")
    ex.add_argument("--overwrite", action="store_true", help="replace an existing output (default: refuse)")
    ex.add_argument("--split-pieces", action="store_true",
                    help="glb, usd: each piece of a broken (brittle) body its own node or prim, so the pieces can be "
                         "taken apart in a 3D editor or a game engine (docs/fracture.md; default: one per "
                         "object)")
    ex.add_argument("--no-crack-faces", dest="crack_faces", action="store_false",
                    help="leave a broken (brittle) body's crack faces out of the export (default: the faces shown at "
                         "each frame go in: a second GLB node, rows after the object's in the other per-frame "
                         "formats, a time-sampled prim in USD; docs/fracture.md)")
    ex.add_argument("--allow-missing", action="store_true",
                    help="export a damaged run whose brittle object lacks some frames' pieces or crack-face files, "
                         "those frames unsplit and without faces (default: refuse, naming every missing file)")
    ex.set_defaults(func=func)
    return ex
