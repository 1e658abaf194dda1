"""A gzip ``.spz`` file checked in bounded memory before gsply decompresses it whole.

gsply's ``read_spz`` decompresses the whole gzip stream into memory before it reads the header, so a
6 MB gzip bomb reached 6.3 GB before it was refused. :func:`check_spz` streams the stream in 1 MiB
pieces, holding none of them: it reads the 16-byte header (magic ``NGSP``, version, point count, SH
degree), refuses a stream longer than the header's count needs (plus :data:`SLACK` for extensions) or
one that expands more than :data:`MAX_RATIO` times beyond :data:`FREE_BYTES` (real SPZ data compresses
about 1.5 to 3 times), and a truncated stream. An NGSP v4 file (zstd sections whose sizes gsply checks
against the header's count) is refused when that count needs more than the same ratio allows. Only then
does gsply read the file.

A gzip file may hold several members one after the other, and gsply (``gzip.decompress``) reads them all
as one stream: the check walks every member, the limits on their total. (It read only the first: a 1 MB
file of a valid member followed by a thousand members of 1 MiB of zeros each passed, and reached 2.2 GB.)
:data:`FREE_BYTES` is what a file may hold beyond :data:`MAX_RATIO` times its size whatever its ratio, so
also a bound on the Gaussians a small file can declare (about 3 M at SH degree 0; a 39 KB file of 2 M
points at one point passes, and is refused after reading by :func:`gasp_core.gs.io.refuse_one_point`).
"""
from __future__ import annotations

import struct
import zlib
from pathlib import Path

from gasp_core.gs.bound import check_count
from gasp_core.gs.ply import reject_file

NGSP = 0x5053474E
#: Bytes a stream may hold beyond its declared sections (the extensions of header flag 0x2).
SLACK = 2**20
#: Decompressed bytes per compressed byte allowed beyond :data:`FREE_BYTES`.
MAX_RATIO = 64
FREE_BYTES = 64 * 2**20
_SH_DIM = (0, 3, 8, 15)


def check_spz(path: Path) -> None:
    """Refuse (:class:`SceneError`, one line naming the file) a gzip ``.spz`` whose stream (all its gzip members
    together) is corrupt, truncated, or longer than its header's point count needs, and an NGSP v4 (zstd) file whose count
    needs more than :data:`MAX_RATIO` times its size beyond :data:`FREE_BYTES`."""
    path = Path(path)
    size = path.stat().st_size
    limit = FREE_BYTES + MAX_RATIO * size
    with open(path, "rb") as f:
        head = f.read(16)
        if head[:4] == b"NGSP" and len(head) == 16:   # v4: zstd sections of the sizes its count implies
            n, sh_degree = struct.unpack_from("<IB", head, 8)
            need = (9 + 1 + 3 + 3 + 4 + 3 * _SH_DIM[min(sh_degree, 3)]) * n
            if need > limit:
                reject_file(path, f"the header declares {n:,} points, {need:,} bytes of sections: more than "
                            f"{MAX_RATIO} times the file's {size:,} bytes can hold (a zstd bomb?)")
            check_count(path, n, "its header")
            return
        if head[:2] != b"\x1f\x8b":
            return
        f.seek(0)
        d = zlib.decompressobj(wbits=31)
        head, total, expected = b"", 0, None
        try:
            while chunk := f.read(2**20):
                out = d.decompress(chunk, 2**20)
                while True:
                    if d.eof and d.unused_data:      # the next gzip member: gsply reads it as more of the stream
                        rest = d.unused_data
                        d = zlib.decompressobj(wbits=31)
                        out += d.decompress(rest, 2**20)
                    total += len(out)
                    if expected is None and len(head) < 16:
                        head += out[:16 - len(head)]
                        if len(head) == 16:
                            expected = _expected(path, head)
                    if expected is not None and total > expected + SLACK:
                        reject_file(path, f"the gzip stream holds more than the {expected:,} bytes its header's "
                                    "count needs (a gzip bomb?)")
                    if total > limit:
                        reject_file(path, f"the gzip stream expands beyond {limit:,} bytes, {MAX_RATIO} times "
                                    "its size (a gzip bomb?)")
                    if d.eof and d.unused_data:
                        out = b""
                        continue
                    if not d.unconsumed_tail:
                        break
                    out = d.decompress(d.unconsumed_tail, 2**20)
        except zlib.error as e:
            reject_file(path, f"not a readable .spz file (corrupt gzip stream: {e})")
    if expected is None or total < expected:
        reject_file(path, f"truncated: {total:,} bytes decompressed, the header's count needs "
                    f"{expected if expected is not None else 16:,}")
    check_count(path, struct.unpack_from("<I", head, 8)[0], "its header")   # a whole stream: its count, decoded


def _expected(path: Path, head: bytes) -> int:
    """Decompressed bytes a gzip SPZ stream needs, from its 16-byte header."""
    magic, version, n, sh_degree = struct.unpack("<IIIB", head[:13])
    if magic != NGSP or version not in (1, 2, 3) or sh_degree > 3:
        reject_file(path, f"not an SPZ stream (magic 0x{magic:08x}, version {version}, SH degree {sh_degree}); "
                    "expected NGSP version 1-3, SH degree 0-3")
    rot = 4 if version >= 3 else 3
    return 16 + (9 + 1 + 3 + 3 + rot + 3 * _SH_DIM[sh_degree]) * n
