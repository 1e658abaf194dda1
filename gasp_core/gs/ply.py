"""Helpers shared by the Gaussian Splatting readers (:mod:`gasp_core.gs.io`): PLY parsing and checks."""
from __future__ import annotations

import re
import warnings
from pathlib import Path
from typing import NoReturn

import numpy as np
from plyfile import PlyData, PlyListProperty

from gasp_core.errors import SceneError
from gasp_core.gs.bound import check_count


#: Degree-0 real spherical harmonic, ``1 / (2 sqrt(pi))``; colour = ``0.5 + SH_C0 * f_dc``.
SH_C0 = 0.28209479177387814

#: Opacity logit that PlayCanvas's decoder gives to an alpha byte of 0 (-) or 255 (+).
LOGIT_CLAMP = 40.0


def reject_file(path, msg: str) -> NoReturn:
    """Raise the :class:`SceneError` ``"<path>: <msg>"`` (a reader's one-line refusal of a file)."""
    raise SceneError(f"{path}: {msg}")


# --------------------------------------------------------------------------------------------
# PLY reading


def read_ply(path) -> PlyData:
    """Parse a PLY file fully into memory; any parse error -> SceneError naming the file."""
    path = Path(path)
    check_is_file(path, "Gaussian Splatting file")
    try:
        with open(path, "rb") as f:
            # plyfile's mmap=False path parses row by row (seconds per 45k-vertex file); map the file
            # copy-on-write instead and copy the arrays out, so the file can be replaced afterwards
            head = f.read(65536)
            check_count(path, _header_vertices(head), "its header")   # before the file is mapped
            _check_ascii_body(path, head, f)
            f.seek(0)
            ply = PlyData.read(f, mmap="c")
            _one_point(path, ply)   # on the mapped file, before its copy
            _check_rows_after(path, head, ply)
            for el in ply.elements:
                el.data = np.array(el.data)
    except SceneError:
        raise
    except Exception as exc:  # plyfile raises PlyHeaderParseError, PlyElementParseError, ...
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        reject_file(path, f"not a readable PLY file (truncated or corrupt?): {msg}")
    for el in ply.elements:
        if el.name in ("vertex", "chunk", "sh"):
            lists = [p.name for p in el.properties if isinstance(p, PlyListProperty)]
            if lists:
                reject_file(path, f"element '{el.name}' property '{lists[0]}' is a list; expected scalar "
                            "properties (one number per splat)")
    return ply


#: More Gaussians than this all at one point (equal centres) are a degenerate file, refused by
#: :func:`refuse_one_point_means` and :func:`refuse_one_point_file`: one blob that the grid cannot resolve, whose count only costs work (2 M of them
#: read from a 39 KB ``.spz`` took 20 s and 1.9 GB through ``gasp info``). Fewer are a legal tiny object.
MAX_AT_ONE_POINT = 1000


def refuse_one_point_means(path, means: np.ndarray) -> None:
    """Refuse more than :data:`MAX_AT_ONE_POINT` centres, shape (n, 3), all equal (a column with a NaN is left to the
    readers' own checks).

    Raises
    ------
    SceneError
        One line naming the file, the count and the point.
    """
    if len(means) > MAX_AT_ONE_POINT and not _spread(means.min(axis=0), means.max(axis=0)):
        _one_point_error(path, len(means), means[0])


def refuse_one_point_file(path, dtype: np.dtype, offset: int, n: int, centres) -> None:
    """:func:`refuse_one_point_means` read from the file in chunks of 64 MB (records of ``dtype`` from byte
    ``offset``, ``centres(records) -> (k, 3)``), before a reader builds anything: a 512 MB ``.splat`` or a 2 GB PLY
    of zeros is refused in seconds with the memory of one chunk, not after 10 s and 3 GB or more building its
    Gaussians. A file whose centres differ stops at its first chunk."""
    if n <= MAX_AT_ONE_POINT:
        return
    step, lo, hi, first = max(1, (64 << 20) // dtype.itemsize), None, None, None
    with open(path, "rb") as f:
        f.seek(offset)
        for start in range(0, n, step):
            c = np.asarray(centres(np.fromfile(f, dtype=dtype, count=min(step, n - start))), dtype=np.float64)
            if len(c) == 0:
                return   # shorter than its records: the reader says so
            first = c[0] if first is None else first
            lo = c.min(axis=0) if lo is None else np.minimum(lo, c.min(axis=0))
            hi = c.max(axis=0) if hi is None else np.maximum(hi, c.max(axis=0))
            if _spread(lo, hi):
                return
    _one_point_error(path, n, first)


def _spread(lo, hi) -> bool:
    """Whether the centres' range is more than one point, or not finite (left to the readers' checks)."""
    return not (np.isfinite(lo).all() and np.isfinite(hi).all()) or bool((hi > lo).any())


def _one_point_error(path, n: int, point) -> NoReturn:
    x = ", ".join(f"{float(v) + 0.0:.6g}" for v in point)   # + 0.0: no "-0"
    reject_file(path, f"all {n:,} Gaussians lie at one point ({x}): a degenerate file, no object to describe or "
                "simulate")


def _one_point(path: Path, ply: PlyData) -> None:
    """:func:`refuse_one_point_file` on a mapped PLY's vertex x, y, z, where it has them."""
    v = next((el for el in ply.elements if el.name == "vertex"), None)
    d = v.data if v is not None else None
    if isinstance(d, np.memmap) and d.offset is not None and {"x", "y", "z"} <= set(d.dtype.names or ()):
        refuse_one_point_file(path, d.dtype, d.offset, len(d), lambda r: np.stack([r["x"], r["y"], r["z"]], 1))


#: An ASCII PLY's first body line must end within this many bytes (a row of numbers is far shorter).
ASCII_LINE_MAX = 1 << 20
_ASCII_ROW = re.compile(rb"[0-9eEinfaINFA+\-. \t\r]*")


def _check_ascii_body(path: Path, head: bytes, f) -> None:
    """An ASCII PLY's body starts with a row of numbers ending within :data:`ASCII_LINE_MAX` bytes: a 2 GB body of
    NUL bytes took plyfile 45 s and 19 GB before its error. Binary PLYs and headers without ``end_header`` in
    ``head`` are left to plyfile."""
    if not re.search(rb"^format\s+ascii", head, re.MULTILINE) or b"end_header" not in head:
        return
    f.seek(head.index(b"end_header") + len(b"end_header"))
    body = f.read(ASCII_LINE_MAX + 2).lstrip(b"\r\n")
    line = body.split(b"\n", 1)[0]
    if len(line) > ASCII_LINE_MAX:
        reject_file(path, f"an ASCII PLY whose first row is longer than {ASCII_LINE_MAX:,} bytes: not a row of numbers "
                    "(truncated or corrupt?)")
    if body and not _ASCII_ROW.fullmatch(line):
        reject_file(path, "an ASCII PLY whose first row is not numbers (binary data under an ASCII header?)")


def _check_rows_after(path: Path, head: bytes, ply: PlyData) -> None:
    """Warn when a binary PLY of fixed-size rows holds at least one more row of its last element than its header
    counts: the header's count is read and the rows after it left out, which was silent. A warning, not a refusal:
    a file cut short by its header on purpose reads as before (the bundled ``pc_short.ply`` counts 100 of 156).
    Fewer bytes than one row (a newline a tool added) say nothing; ASCII PLYs and elements with lists are left alone."""
    if ply.text or not ply.elements or b"end_header" not in head:
        return
    if any(isinstance(p, PlyListProperty) for el in ply.elements for p in el.properties):
        return
    start = head.index(b"end_header") + len(b"end_header")
    start += 2 if head[start:start + 2] == b"\r\n" else 1
    last = ply.elements[-1]
    row = last.data.dtype.itemsize
    extra = Path(path).stat().st_size - start - sum(el.count * el.data.dtype.itemsize for el in ply.elements)
    if row and extra >= row:
        what = "vertices" if last.name == "vertex" else f"'{last.name}' rows"
        warnings.warn(f"{path}: its header says {last.count:,} {what} but the file holds {last.count + extra // row:,} "
                      f"({row} bytes each): reading the {last.count:,} the header counts, leaving out the rest",
                      stacklevel=2)


def _header_vertices(head: bytes) -> int:
    """The ``element vertex N`` count of a PLY header's first bytes (0 when it says none)."""
    m = re.search(rb"^element\s+vertex\s+(\d+)", head.split(b"end_header", 1)[0], re.MULTILINE)
    return int(m.group(1)) if m else 0


def check_is_file(path: Path, what: str) -> None:
    """Refuse a directory or a path that is not a regular file (:class:`SceneError`) or a missing path
    (:class:`FileNotFoundError`); ``what`` names the file expected."""
    if path.is_dir():
        reject_file(path, f"is a directory; expected a {what}")
    if path.exists() and not path.is_file():   # a FIFO, a device (/dev/zero), a socket: reading could hang
        reject_file(path, f"is not a regular file (a pipe, device or socket); expected a {what}")
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such {what}")


def check_columns(path, data: np.ndarray, names, element: str = "vertex", lo: float = -np.inf,
                  hi: float = np.inf, allow_neg_inf: bool = False, expected: str | None = None,
                  allow_pos_inf: bool = False) -> None:
    """Every value of the named columns finite (or -inf / +inf if allowed) and in ``[lo, hi]``; NaN never.

    Raises SceneError naming the file, the property, the value and the first bad row.
    """
    for nm in names:
        col = np.asarray(data[nm])
        if col.dtype.kind not in "fiub":
            reject_file(path, f"{element} property '{nm}' has type {col.dtype}; expected a number")
        if col.dtype.kind != "f":
            continue
        ok = np.isfinite(col) & (col >= lo) & (col <= hi)
        if allow_neg_inf:
            ok |= np.isneginf(col)
        if allow_pos_inf:
            ok |= np.isposinf(col)
        if not ok.all():
            i = int(np.flatnonzero(~ok)[0])
            rng = "a finite number" if (lo, hi) == (-np.inf, np.inf) else f"a finite number in [{lo:g}, {hi:g}]"
            rng = expected or rng
            reject_file(path, f"{element} property '{nm}' = {float(col[i])!r} at {element} {i}; expected {rng}")


def column(vertex: np.ndarray, name: str) -> np.ndarray:
    """Property ``name`` of a PLY element's structured array, as a plain array (file dtype)."""
    return np.asarray(vertex[name])


def stack_columns(vertex: np.ndarray, names, dtype=np.float64) -> np.ndarray:
    """Properties ``names`` of a PLY element side by side, shape (n, len(names)), ``dtype``."""
    return np.stack([np.asarray(vertex[n], dtype=dtype) for n in names], axis=1)


def numbered_names(names, prefix: str) -> list[str]:
    """``prefix0, prefix1, ...`` present in ``names``, in numeric order."""
    found = []
    for n in names:
        if n.startswith(prefix) and n[len(prefix):].isdigit():
            found.append((int(n[len(prefix):]), n))
    found.sort()
    return [n for _, n in found]


def require_columns(path, names, wanted, what: str) -> None:
    """Refuse (:class:`SceneError`) a vertex element without every property of ``wanted``; ``what`` says what
    was expected."""
    missing = [w for w in wanted if w not in names]
    if missing:
        reject_file(path, f"vertex element has no {', '.join(missing)} properties; expected {what}")


