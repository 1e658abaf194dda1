"""A ``.sog`` file checked before gsply decodes it: every count, size and codebook against the file.

gsply's ``sogread`` trusts ``meta.json``: it reads every zip entry whole (a 3 GiB entry of zeros was
decompressed and the file accepted), indexes the codebooks with the images' 8-bit labels without
checking their length (a short codebook was read past its end: exit 0 on some runs, a wrong value
error on others), and raises whatever the zip, JSON or WebP decoder raises. :func:`sog_bytes` reads
only the entries ``meta.json`` names, each with a byte limit derived from the declared count, checks
the meta's types and ranges, each codebook's length and values, and each image's size from its WebP
header (before decoding), and hands gsply a small zip of exactly those entries. Anything wrong is one
:class:`~gasp_core.errors.SceneError` line naming the file and the field.

The declared count is bounded by the bytes that hold it too: the images' pixels, :data:`PIXEL_BYTES` per
splat, may be at most :data:`MAX_RATIO` times the images' compressed bytes beyond :data:`FREE_BYTES` (a real
capture's WebP images compress about 1.5 to 3 times). A 2 KB ``.sog`` of 16.8 M splats, every image one
colour, reached 3.2 GB and a memory error in gsply's decoding; it is refused before any image is decoded.
"""
from __future__ import annotations

import io
import json
import math
import zipfile
from pathlib import Path

from gasp_core.errors import SceneError
from gasp_core.gs.bound import check_count
from gasp_core.gs.ply import reject_file

#: Largest splat count a ``.sog`` may declare (its images would be 46k x 46k pixels).
MAX_COUNT = 2**31 - 1
#: Bytes of RGBA pixels per splat in the images every ``.sog`` holds (means low and high, quats, scales, sh0).
PIXEL_BYTES = 20
#: Pixel bytes allowed per compressed image byte beyond :data:`FREE_BYTES`.
MAX_RATIO = 64
FREE_BYTES = 64 * 2**20
#: Entries of a SOG bundle (codebook length) that an 8-bit label indexes.
CODEBOOK = 256
#: SH coefficients per channel of ``shN.bands`` 1, 2, 3.
_SH_COEFFS = {1: 3, 2: 8, 3: 15}


def _bad(path: Path, field: str, why: str):
    reject_file(path, f"meta.json {field}: {why}; not a readable .sog file")


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _numbers(path: Path, field: str, v, n_min: int, n_max: int | None = None) -> None:
    """``v`` must be a list of ``n_min``.. ``n_max`` finite numbers."""
    if not isinstance(v, list) or len(v) < n_min or (n_max is not None and len(v) > n_max) \
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v):
        size = f"{n_min}" if n_max == n_min else f"at least {n_min}"
        got = f"a list of {len(v)}" if isinstance(v, list) else type(v).__name__
        _bad(path, field, f"expected {size} finite numbers, got {got}" +
             (" (an 8-bit label indexes 256 entries)" if n_min == CODEBOOK else ""))


def _files(path: Path, meta: dict, key: str, n: int) -> list[str]:
    entry = meta.get(key)
    if not isinstance(entry, dict):
        _bad(path, key, f"expected a table, got {type(entry).__name__}")
    files = entry.get("files")
    if not isinstance(files, list) or len(files) < n or not all(isinstance(f, str) and f for f in files[:n]):
        _bad(path, f"{key}.files", f"expected {n} file name(s), got {files!r}")
    return files[:n]


def _check_meta(path: Path, meta) -> tuple[int, dict[str, int]]:
    """The splat count and ``{image name: largest pixel count}`` of a parsed ``meta.json``."""
    if not isinstance(meta, dict):
        _bad(path, "(top level)", f"expected a table, got {type(meta).__name__}")
    version = meta.get("version")
    if version not in (None, 2):
        _bad(path, "version", f"expected 2 (or none, version 1), got {version!r}")
    if version == 2:
        count = meta.get("count")
    else:   # version 1: the count is the first of means.shape
        shape = meta["means"].get("shape") if isinstance(meta.get("means"), dict) else None
        count = shape[0] if isinstance(shape, list) and shape else None
    if not _is_int(count) or not 1 <= count <= MAX_COUNT:
        _bad(path, "count" if version == 2 else "means.shape", f"expected a splat count from 1 to {MAX_COUNT}, "
             f"got {count!r}")
    pixels = 4 * count + 4096   # the images: one pixel per splat, rounded up to a multiple of 4 on each side
    images = {}
    for key, n in (("means", 2), ("quats", 1), ("scales", 1), ("sh0", 1)):
        for f in _files(path, meta, key, n):
            images[f] = pixels
    _numbers(path, "means.mins", meta["means"].get("mins"), 3, 3)
    _numbers(path, "means.maxs", meta["means"].get("maxs"), 3, 3)
    for key in ("scales", "sh0"):
        if version == 2:
            _numbers(path, f"{key}.codebook", meta[key].get("codebook"), CODEBOOK)
        else:
            _numbers(path, f"{key}.mins", meta[key].get("mins"), 3, 4)
            _numbers(path, f"{key}.maxs", meta[key].get("maxs"), 3, 4)
    if "shN" in meta:
        sh = meta["shN"]
        names = _files(path, meta, "shN", 2)
        if version == 2:
            if not _is_int(sh.get("bands")) or sh["bands"] not in _SH_COEFFS:
                _bad(path, "shN.bands", f"expected 1, 2 or 3, got {sh.get('bands')!r}")
            if not _is_int(sh.get("count")) or not 1 <= sh["count"] <= 65536:
                _bad(path, "shN.count", f"expected a palette size from 1 to 65536, got {sh.get('count')!r}")
            _numbers(path, "shN.codebook", sh.get("codebook"), CODEBOOK)
            images[names[0]] = 64 * _SH_COEFFS[sh["bands"]] * (sh["count"] // 64 + 2)
        else:
            images[names[0]] = 960 * (65536 // 64 + 2)
        images[names[1]] = pixels
    return count, images


def _image_size(path: Path, name: str, data: bytes) -> tuple[int, int]:
    """Width and height of a WebP image from its header (not decoded)."""
    from PIL import Image
    try:
        with Image.open(io.BytesIO(data)) as im:
            if im.format != "WEBP":
                raise ValueError(f"a {im.format} image")
            return im.size
    except Exception as e:   # Pillow raises many kinds for a corrupt header
        reject_file(path, f"image '{name}' is not a readable WebP image ({type(e).__name__}: {e})")


def sog_bytes(path: Path) -> bytes:
    """The checked content of the ``.sog`` bundle, folder or ``meta.json`` at ``path``, as a zip for gsply.

    Raises
    ------
    SceneError
        Not a zip, no or a malformed ``meta.json``, a field of the wrong type or range, a codebook
        shorter than 256, a named image missing, larger than its count allows, or not a WebP image; a count
        whose pixels are more than :data:`MAX_RATIO` times the images' bytes beyond :data:`FREE_BYTES`.
    """
    path = Path(path)
    if path.is_dir() or path.name == "meta.json":
        folder = path if path.is_dir() else path.parent
        names = {p.name: p for p in folder.iterdir() if p.is_file()}

        def read(name: str, limit: int) -> bytes:
            if name not in names or "/" in name:
                reject_file(path, f"image '{name}' named in meta.json is missing")
            with open(names[name], "rb") as f:
                return f.read(limit + 1)
        return _collect(path, read)
    try:
        with zipfile.ZipFile(path) as z:
            entries = {i.filename: i for i in z.infolist()}

            def read(name: str, limit: int) -> bytes:
                if name not in entries:
                    reject_file(path, f"entry '{name}' named in meta.json is missing from the zip")
                with z.open(entries[name]) as f:
                    return f.read(limit + 1)
            return _collect(path, read)
    except SceneError:
        raise               # already one line naming the file and the field
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, NotImplementedError, ValueError, OSError) as e:
        reject_file(path, f"not a readable .sog zip bundle (truncated or corrupt?): {type(e).__name__}: {e}")


def _collect(path: Path, read) -> bytes:
    """Read and check ``meta.json`` and the images it names through ``read(name, limit)``; a zip of them."""
    raw = read("meta.json", 16 * 2**20)
    if len(raw) > 16 * 2**20:
        _bad(path, "(size)", "larger than 16 MiB")
    try:
        meta = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as e:   # nested 200,000 deep: RecursionError
        _bad(path, "(text)", f"not JSON ({type(e).__name__}: {str(e)[:200]})")
    count, images = _check_meta(path, meta)
    check_count(path, count, "its meta.json count")
    out = io.BytesIO()
    held = 0
    with zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as z:
        z.writestr("meta.json", raw)
        for name, max_pixels in images.items():
            limit = 4 * max_pixels + 2**20     # a lossless WebP is never much larger than its raw RGBA
            data = read(name, limit)
            if len(data) > limit:
                reject_file(path, f"image '{name}' is larger than {limit:,} bytes, more than {count:,} splats need")
            w, h = _image_size(path, name, data)
            if w * h > max_pixels:
                reject_file(path, f"image '{name}' is {w}x{h} pixels; {count:,} splats need at most {max_pixels:,}")
            z.writestr(name, data)
            held += len(data)
    if PIXEL_BYTES * count > FREE_BYTES + MAX_RATIO * held:
        _bad(path, "count", f"{count:,} splats need {PIXEL_BYTES * count:,} bytes of pixels, more than {MAX_RATIO} "
             f"times the {held:,} bytes of its images can hold (a degenerate or bomb file?)")
    return out.getvalue()
