"""Hostile files for the bounded-work tests (issue 41): tiny files whose splats all sit at one point, and a
``.spz`` of many small gzip members. Each is built from its format's bytes, in bounded memory (the
payloads are zeros, streamed through the compressor), in a second or two.

* :func:`spz_v4_one_point`: an NGSP v4 (zstd) ``.spz`` of ``n`` points, every section zeros (13 M: 8 KB).
* :func:`spz_gzip_one_point`: a gzip (version 3) ``.spz`` of ``n`` points, zeros (2 M: about 40 KB).
* :func:`sog_one_point`: a version-2 ``.sog`` bundle of ``side * side`` splats, every image one colour
  (4096 x 4096 = 16.8 M: a few KB).
* :func:`ply_coincident`: a 3DGS PLY of ``n`` Gaussians at the origin (200,000: 12 MB).
* :func:`spz_many_members`: a gzip ``.spz`` whose first member is a valid 1,000-point stream and whose
  further members each hold 1 MiB of zeros (``members`` MiB in all, about 1 KB each).
"""
from __future__ import annotations

import io
import json
import struct
import zipfile
import zlib
from pathlib import Path

import numpy as np

_ZEROS = b"\0" * 2**20


def _zstd_zeros(n_bytes: int) -> bytes:
    import zstandard
    c = zstandard.ZstdCompressor(level=3).compressobj(size=n_bytes)
    out, left = [], n_bytes
    while left:
        k = min(left, len(_ZEROS))
        out.append(c.compress(_ZEROS[:k]))
        left -= k
    out.append(c.flush())
    return b"".join(out)


def spz_v4_one_point(path: Path, n: int = 13_000_000) -> Path:
    """An NGSP v4 ``.spz`` declaring ``n`` points (SH degree 0), every section zeros."""
    sections = [9 * n, n, 3 * n, 3 * n, 4 * n]
    streams = [_zstd_zeros(s) for s in sections]
    head = struct.pack("<IIIBBBBI", 0x5053474E, 4, n, 0, 12, 0, len(sections), 32) + b"\0" * 12
    toc = b"".join(struct.pack("<QQ", len(z), s) for z, s in zip(streams, sections))
    path.write_bytes(head + toc + b"".join(streams))
    return path


def _gzip_member(data_chunks) -> bytes:
    c = zlib.compressobj(9, zlib.DEFLATED, 31)
    return b"".join([c.compress(x) for x in data_chunks] + [c.flush()])


def _zeros(n_bytes: int):
    while n_bytes > 0:
        k = min(n_bytes, len(_ZEROS))
        yield _ZEROS[:k]
        n_bytes -= k


def spz_gzip_one_point(path: Path, n: int = 2_000_000) -> Path:
    """A gzip ``.spz`` (version 3, SH degree 0) of ``n`` points, every byte after the header zero."""
    head = struct.pack("<IIIBBBB", 0x5053474E, 3, n, 0, 12, 0, 0)
    path.write_bytes(_gzip_member([head, *_zeros(20 * n)]))
    return path


def spz_many_members(path: Path, members: int = 1000) -> Path:
    """A gzip ``.spz`` of a valid 1,000-point first member, then ``members`` members of 1 MiB of zeros each."""
    n = 1000
    rng = np.random.default_rng(0)
    body = rng.integers(0, 256, 20 * n, dtype=np.uint8).tobytes()
    head = struct.pack("<IIIBBBB", 0x5053474E, 3, n, 0, 12, 0, 0)
    zero = _gzip_member([_ZEROS])
    path.write_bytes(_gzip_member([head, body]) + zero * members)
    return path


def _webp(side: int, rgba) -> bytes:
    from PIL import Image
    buf = io.BytesIO()
    Image.new("RGBA", (side, side), tuple(rgba)).save(buf, "WEBP", lossless=True)
    return buf.getvalue()


def sog_one_point(path: Path, side: int = 4096) -> Path:
    """A version-2 ``.sog`` of ``side * side`` splats, every image one colour: all at one point."""
    codebook = np.linspace(-5, 1, 256).tolist()
    meta = {"version": 2, "count": side * side,
            "means": {"mins": [0, 0, 0], "maxs": [0, 0, 0], "files": ["means_l.webp", "means_u.webp"]},
            "scales": {"codebook": codebook, "files": ["scales.webp"]},
            "quats": {"files": ["quats.webp"]},
            "sh0": {"codebook": codebook, "files": ["sh0.webp"]}}
    img = _webp(side, (128, 128, 128, 255))
    quat = _webp(side, (128, 128, 128, 252))     # smallest-three: the largest component w, the rest 0
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("meta.json", json.dumps(meta))
        for name in ("means_l.webp", "means_u.webp", "scales.webp", "sh0.webp"):
            z.writestr(name, img)
        z.writestr("quats.webp", quat)
    return path


def ply_coincident(path: Path, n: int = 200_000) -> Path:
    """A 3DGS PLY of ``n`` equal Gaussians at the origin (scale 1 mm, opaque)."""
    from gasp_core.gs.gaussians import Gaussians
    from gasp_core.gs.io import write_gaussians
    g = Gaussians(means=np.zeros((n, 3)), scales=np.full((n, 3), 1e-3), rotations=np.tile([1.0, 0, 0, 0], (n, 1)),
                  opacities=np.full(n, 4.0, np.float32), sh_dc=np.zeros((n, 3), np.float32))
    write_gaussians(path, g)
    return path
