"""Helpers shared by the Gaussian Splatting readers (:mod:`gasp_core.gs.io`): PLY parsing and checks."""
from __future__ import annotations

import re
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
            check_count(path, _header_vertices(f.read(65536)), "its header")   # before the file is mapped
            f.seek(0)
            ply = PlyData.read(f, mmap="c")
            _one_point(path, ply)   # on the mapped file, before its copy
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
#: :func:`refuse_one_point_means`: one blob that the grid cannot resolve, whose count only costs work (2 M of them
#: read from a 39 KB ``.spz`` took 20 s and 1.9 GB through ``gasp info``). Fewer are a legal tiny object.
MAX_AT_ONE_POINT = 1000


def refuse_one_point_means(path, means) -> None:
    """Refuse more than :data:`MAX_AT_ONE_POINT` centres all equal: ``means`` an (n, 3) array or three columns (x, y,
    z), any float dtype, a reader's view of its mapped file (so a 512 MB ``.splat`` or a 1 GB PLY of zeros is refused
    in a second, not after 10 s and 3 GB building its Gaussians). A column with a NaN is left to the readers' own
    checks.

    Raises
    ------
    SceneError
        One line naming the file, the count and the point.
    """
    cols = [means[:, i] for i in range(3)] if isinstance(means, np.ndarray) and means.ndim == 2 else list(means)
    if len(cols[0]) <= MAX_AT_ONE_POINT:
        return
    for c in cols:
        lo, hi = c.min(), c.max()
        if not (np.isfinite(lo) and np.isfinite(hi)) or hi > lo:
            return
    x = ", ".join(f"{float(c[0]) + 0.0:.6g}" for c in cols)   # + 0.0: no "-0"
    reject_file(path, f"all {len(cols[0]):,} Gaussians lie at one point ({x}): a degenerate file, no object to "
                "describe or simulate")


def _header_vertices(head: bytes) -> int:
    """The ``element vertex N`` count of a PLY header's first bytes (0 when it says none)."""
    m = re.search(rb"^element\s+vertex\s+(\d+)", head.split(b"end_header", 1)[0], re.MULTILINE)
    return int(m.group(1)) if m else 0


def _one_point(path: Path, ply: PlyData) -> None:
    """:func:`refuse_one_point_means` on a PLY's vertex x, y, z columns, where it has them."""
    v = next((el for el in ply.elements if el.name == "vertex"), None)
    names = v.data.dtype.names or () if v is not None else ()
    if {"x", "y", "z"} <= set(names):
        refuse_one_point_means(path, [v.data[c] for c in "xyz"])


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


