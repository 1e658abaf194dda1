"""Readers for two web-viewer formats no Python library reads: antimatter15 ``.splat`` and mkkellogg ``.ksplat``."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gasp_core.gs.gaussians import Gaussians
from gasp_core.gs.bound import check_count
from gasp_core.gs.ply import LOGIT_CLAMP, SH_C0, check_is_file, refuse_one_point_file, reject_file

_SPLAT_RECORD = 32  # bytes per splat in a .splat file
_KSPLAT_HEADER, _KSPLAT_SECTION_HEADER = 4096, 1024
#: Per compression level: bytes of centre, scale, rotation, colour, and of one SH component.
_KSPLAT_BYTES = {0: (12, 12, 16, 4, 4), 1: (6, 6, 8, 4, 2), 2: (6, 6, 8, 4, 1)}
_KSPLAT_SH = (0, 9, 24, 45)


def _logit(alpha: np.ndarray) -> np.ndarray:
    """Opacity logits (float32) of alphas in [0, 1]; 0 and 1 give -/+ :data:`LOGIT_CLAMP` as PlayCanvas does."""
    with np.errstate(divide="ignore"):
        return np.where(alpha <= 0, -LOGIT_CLAMP, np.where(alpha >= 1, LOGIT_CLAMP,
                                                           -np.log(1.0 / alpha - 1.0))).astype(np.float32)


def _unit_quats(path: Path, q: np.ndarray) -> np.ndarray:
    """``q`` (n, 4) normalised; a zero or non-finite one is refused (:class:`SceneError`)."""
    with np.errstate(invalid="ignore", over="ignore"):   # inf or NaN components: refused just below
        norm = np.linalg.norm(q, axis=1)
    bad = ~(np.isfinite(norm) & (norm > 1e-12))
    if bad.any():
        reject_file(path, f"zero or non-finite quaternion at splat {int(np.flatnonzero(bad)[0])}")
    return q / norm[:, None]


def _check_means(path: Path, means: np.ndarray) -> None:
    bad = ~np.isfinite(means).all(axis=1)
    if bad.any():
        reject_file(path, f"non-finite position (x, y, z) at splat {int(np.flatnonzero(bad)[0])}")


def read_splat(path) -> Gaussians:
    """Read an antimatter15 ``.splat`` file (the format of antimatter15/splat's viewer and ``convert.py``).

    Records of 32 bytes, no header: float32 x, y, z; float32 linear scales sx, sy, sz; uint8 R, G,
    B, A (``0.5 + SH_C0 f_dc`` and ``sigmoid(opacity)``, times 255); uint8 w, x, y, z of the unit
    quaternion as ``q * 128 + 128``.

    Returns
    -------
    Gaussians
        ``layout = "splat"``; ``sh_dc = (c / 255 - 0.5) / SH_C0``, opacity logit of ``A / 255``
        (0 and 255 give -/+40), rotations ``(b - 128) / 128`` normalised, no ``sh_rest``.

    Raises
    ------
    SceneError
        A size that is not a whole number of records, a non-finite position, a zero quaternion.
    """
    path = Path(path)
    check_is_file(path, ".splat file")
    size = path.stat().st_size
    if not size or size % _SPLAT_RECORD:
        reject_file(path, f"{size} bytes is not a whole number of {_SPLAT_RECORD}-byte .splat records; "
                    "truncated?")
    check_count(path, size // _SPLAT_RECORD, "its size")   # no header: bounded before a byte is decoded
    dtype = np.dtype([("pos", "<f4", 3), ("scale", "<f4", 3), ("rgba", "u1", 4), ("rot", "u1", 4)])
    refuse_one_point_file(path, dtype, 0, size // _SPLAT_RECORD, lambda r: r["pos"])   # before a Gaussian is built
    rec = np.memmap(path, mode="r", dtype=dtype)
    _check_means(path, rec["pos"])
    means = rec["pos"].astype(np.float64)
    rgba = rec["rgba"].astype(np.float64) / 255.0
    return Gaussians(means=means, scales=rec["scale"].astype(np.float64),
                     rotations=_unit_quats(path, (rec["rot"].astype(np.float64) - 128.0) / 128.0),
                     opacities=_logit(rgba[:, 3]), sh_dc=((rgba[:, :3] - 0.5) / SH_C0).astype(np.float32),
                     source=str(path), layout="splat")


def read_ksplat(path) -> Gaussians:
    """Read a mkkellogg GaussianSplats3D ``.ksplat`` file (version 0.1+, compression levels 0, 1 and 2).

    Layout (GaussianSplats3D ``src/loaders/SplatBuffer.js``; the same reading as playcanvas/splat-transform
    ``src/lib/readers/read-ksplat.ts``): a 4096-byte header (uint8 version major 0, minor >= 1; uint32
    section count at 4, splat count at 16; uint16 compression level at 20; float32 SH range at 36, 40),
    then one 1024-byte header per section (uint32 splats at 0, capacity at 4, bucket size at 8, bucket
    count at 12; float32 bucket block size at 16; uint16 bucket storage bytes at 20; uint32 position
    quantisation range at 24, full buckets at 32, partial buckets at 36; uint16 SH degree at 40), then
    per section: uint32 sizes of the partial buckets, float32 bucket centres, and ``capacity`` records.
    A record holds the centre (float32, or uint16 ``(v - range) * block / 2 / range + bucket centre``),
    linear scales and a w,x,y,z quaternion (float32 or float16), RGBA8 and the SH components (float32,
    float16, or uint8 in the header's range), band by band and channel-major within a band
    (``r0 r1 r2 g0 g1 g2 b0 b1 b2``, then the 5 of degree 2 per channel, then the 7 of degree 3).

    Returns
    -------
    Gaussians
        ``layout = "ksplat"``; colour and opacity as :func:`read_splat`; ``sh_rest`` (n, K, 3).

    Raises
    ------
    SceneError
        A wrong version or compression level, a file shorter than its headers say, a splat count
        that does not match the sections, a non-finite position, a zero quaternion.
    """
    path = Path(path)
    check_is_file(path, ".ksplat file")
    with open(path, "rb") as f:
        head = f.read(_KSPLAT_HEADER)
    if len(head) < _KSPLAT_HEADER:
        reject_file(path, f"{len(head)} bytes; a .ksplat file starts with a {_KSPLAT_HEADER}-byte header")
    check_count(path, int(np.frombuffer(head, "<u4", 1, 16)[0]), "its header")
    major, minor = head[0], head[1]
    n_sections = int(np.frombuffer(head, "<u4", 1, 4)[0])
    n_total = int(np.frombuffer(head, "<u4", 1, 16)[0])
    level = int(np.frombuffer(head, "<u2", 1, 20)[0])
    sh_lo, sh_hi = (float(v) for v in np.frombuffer(head, "<f4", 2, 36))
    if major != 0 or minor < 1 or level not in _KSPLAT_BYTES:   # from the header: before the file is read
        reject_file(path, f"version {major}.{minor}, compression level {level}; expected version 0.1+ and "
                    "level 0, 1 or 2 (a GaussianSplats3D .ksplat file)")
    raw = path.read_bytes()
    sh_lo, sh_hi = sh_lo or -1.5, sh_hi or 1.5
    offset = _KSPLAT_HEADER + n_sections * _KSPLAT_SECTION_HEADER
    if offset > len(raw):
        reject_file(path, f"{n_sections:,} section headers of {_KSPLAT_SECTION_HEADER} bytes; the file has "
                    f"{len(raw):,} bytes (truncated or corrupt?)")
    parts = []
    try:
        with np.errstate(invalid="ignore", over="ignore"):   # the values are checked once decoded (check_decoded)
            for s in range(n_sections):
                hdr = raw[_KSPLAT_HEADER + s * _KSPLAT_SECTION_HEADER:][:_KSPLAT_SECTION_HEADER]
                part, offset = _ksplat_section(hdr, raw, offset, level, (sh_lo, sh_hi))
                parts.append(part)
    except ValueError as e:  # a header value out of range or beyond the file, or np.frombuffer past its end
        reject_file(path, f"section {s + 1} of {n_sections}: {e} (truncated or corrupt?)")
    got = sum(len(p[0]) for p in parts)
    if got != n_total:
        reject_file(path, f"header says {n_total} splats, sections hold {got}")
    means, scales, q, rgba, sh_rest = (np.concatenate([p[i] for p in parts]) for i in range(5))
    _check_means(path, means)
    rgba = rgba / 255.0
    return Gaussians(means=means, scales=scales, rotations=_unit_quats(path, q), opacities=_logit(rgba[:, 3]),
                     sh_dc=((rgba[:, :3] - 0.5) / SH_C0).astype(np.float32), sh_rest=sh_rest,
                     source=str(path), layout="ksplat")


def _ksplat_section(hdr: bytes, raw: bytes, offset: int, level: int, sh_range: tuple[float, float]):
    """One section of a ``.ksplat`` file: ``(means, scales, quats, rgba, sh_rest)`` and the offset after it."""
    u4 = np.frombuffer(hdr, "<u4", 10)
    n, capacity, bucket_size, n_buckets = (int(v) for v in u4[:4])
    block = float(np.frombuffer(hdr, "<f4", 1, 16)[0])
    bucket_bytes = int(np.frombuffer(hdr, "<u2", 1, 20)[0])
    full, partial = int(u4[8]), int(u4[9])
    qrange = int(u4[6]) or (1 if level == 0 else 32767)
    sh_degree = int(np.frombuffer(hdr, "<u2", 1, 40)[0])
    if sh_degree >= len(_KSPLAT_SH):
        raise ValueError(f"SH degree {sh_degree} in a section header; expected 0 to 3")
    k3 = _KSPLAT_SH[sh_degree]
    cb, sb, rb, colb, shb = _KSPLAT_BYTES[level]
    record = cb + sb + rb + colb + k3 * shb
    data_at = offset + bucket_bytes * n_buckets + partial * 4
    if n > capacity or data_at + capacity * record > len(raw):
        raise ValueError(f"a section of {n} splats, capacity {capacity}, needs {data_at + capacity * record:,} "
                         f"bytes; the file has {len(raw):,}")
    if level and (full + partial > n_buckets or full * bucket_size > capacity):
        raise ValueError(f"{full} full and {partial} partial buckets of {bucket_size} splats; the section has "
                         f"{n_buckets} buckets and room for {capacity} splats")
    partial_sizes = np.frombuffer(raw, "<u4", partial, offset).astype(np.int64)
    if level and partial_sizes.sum() > capacity:
        raise ValueError(f"partial buckets of {int(partial_sizes.sum()):,} splats in all; the section has room "
                         f"for {capacity}")
    centres = np.frombuffer(raw, "<f4", n_buckets * 3, offset + partial * 4).reshape(n_buckets, 3)
    rec = np.frombuffer(raw, "u1", capacity * record, data_at).reshape(capacity, record)[:n]
    fl, hf = ("<f4", "<f4") if level == 0 else ("<u2", "<f2")
    if level == 0:
        means = rec[:, :cb].copy().view("<f4").astype(np.float64)
    else:
        bucket = np.concatenate([np.repeat(np.arange(full), bucket_size),
                                 np.repeat(np.arange(full, full + partial), partial_sizes)])[:n]
        means = (rec[:, :cb].copy().view(fl).astype(np.float64) - qrange) * (block / 2.0 / qrange) \
            + centres[bucket]
    scales = rec[:, cb:cb + sb].copy().view(hf).astype(np.float64)
    q = rec[:, cb + sb:cb + sb + rb].copy().view(hf).astype(np.float64)
    rgba = rec[:, cb + sb + rb:cb + sb + rb + colb].astype(np.float64)
    sh = rec[:, cb + sb + rb + colb:].copy()
    if level == 2:
        sh = sh_range[0] + sh.astype(np.float64) / 255.0 * (sh_range[1] - sh_range[0])
    else:
        sh = sh.view(hf).astype(np.float64)
    sh_rest = np.zeros((n, k3 // 3, 3), np.float32)
    for i in range(k3):  # band by band (3, 5, 7 coefficients), channel-major within a band
        band0, width = (0, 3) if i < 9 else (9, 5) if i < 24 else (24, 7)
        channel, coeff = divmod(i - band0, width)
        sh_rest[:, coeff + band0 // 3, channel] = sh[:, i]
    return (means, scales, q, rgba, sh_rest), data_at + capacity * record
