"""Writers of the web-viewer formats, made in the test from the formats' reference encoders.

``.splat``: antimatter15/splat ``convert.py`` (``process_ply_to_splat``), step for step.
``.ksplat``: mkkellogg/GaussianSplats3D ``SplatBuffer.generateFromUncompressedSplatArrays``, for one
section, compression level 0 (float32) or 1 (uint16 positions per bucket, float16), SH written
band by band and channel-major within a band; buckets of 256 splats in index order, each centred
on its splats' bounding box, block size = the largest bucket's extent.
"""
import struct

import numpy as np

SH_C0 = 0.28209479177387814


def write_splat(path, g):
    """antimatter15 convert.py: sorted by -exp(sum log-scales) sigmoid(opacity), 32 bytes per splat."""
    log_s = np.log(g.scales)
    order = np.argsort(-np.exp(log_s.sum(axis=1)) / (1 + np.exp(-g.opacities.astype(np.float64))))
    out = bytearray()
    for i in order:
        position = g.means[i].astype(np.float32)
        scales = np.exp(log_s[i]).astype(np.float32)
        rot = g.rotations[i].astype(np.float32)
        color = np.array([0.5 + SH_C0 * g.sh_dc[i, 0], 0.5 + SH_C0 * g.sh_dc[i, 1], 0.5 + SH_C0 * g.sh_dc[i, 2],
                          1 / (1 + np.exp(-g.opacities[i]))])
        out += position.tobytes() + scales.tobytes() + (color * 255).clip(0, 255).astype(np.uint8).tobytes()
        out += ((rot / np.linalg.norm(rot)) * 128 + 128).clip(0, 255).astype(np.uint8).tobytes()
    path.write_bytes(bytes(out))
    return order


def _sh_components(g):
    """(n, 3K) SH rest values in .ksplat order: per band, all red coefficients, then green, then blue."""
    k = g.sh_rest.shape[1]
    cols = []
    for lo, hi in ((0, 3), (3, 8), (8, 15)):
        if hi > k:
            break
        for c in range(3):
            cols.append(g.sh_rest[:, lo:hi, c])
    return np.concatenate(cols, axis=1) if cols else np.zeros((g.n, 0), np.float32)


def write_ksplat(path, g, level=1, bucket_size=256):
    n = g.n
    sh = _sh_components(g)
    degree = {0: 0, 9: 1, 24: 2, 45: 3}[sh.shape[1]]
    n_buckets = -(-n // bucket_size)
    full = n // bucket_size
    partial_sizes = [n - full * bucket_size] if n % bucket_size else []
    bucket = np.arange(n) // bucket_size
    centres = np.zeros((n_buckets, 3), np.float32)
    block = 1.0
    if level:
        for b in range(n_buckets):
            m = g.means[bucket == b]
            centres[b] = 0.5 * (m.min(0) + m.max(0))
        block = float(2.02 * np.abs(g.means - centres[bucket]).max())
    qrange = 1 if level == 0 else 32767
    rgba = np.clip(np.concatenate([0.5 + SH_C0 * g.sh_dc, 1 / (1 + np.exp(-g.opacities[:, None]))], 1) * 255,
                   0, 255).astype(np.uint8)
    if level == 0:
        rec = [g.means.astype("<f4"), g.scales.astype("<f4"), g.rotations.astype("<f4")]
        tail = [sh.astype("<f4")]
    else:
        step = block / 2.0 / qrange
        pos = np.clip(np.round((g.means - centres[bucket]) / step) + qrange, 0, 65535).astype("<u2")
        rec = [pos, g.scales.astype("<f2"), g.rotations.astype("<f2")]
        tail = [sh.astype("<f2")]
    body = np.concatenate([a.view(np.uint8).reshape(n, -1) for a in rec] + [rgba]
                          + [a.view(np.uint8).reshape(n, -1) for a in tail], axis=1)
    header = bytearray(4096)
    header[0], header[1] = 0, 1
    struct.pack_into("<IIII", header, 4, 1, 1, n, n)
    struct.pack_into("<H", header, 20, level)
    section = bytearray(1024)
    struct.pack_into("<IIII", section, 0, n, n, bucket_size, n_buckets)
    struct.pack_into("<f", section, 16, block)
    struct.pack_into("<H", section, 20, 12)
    struct.pack_into("<I", section, 24, qrange)
    struct.pack_into("<II", section, 32, full, len(partial_sizes))
    struct.pack_into("<H", section, 40, degree)
    data = np.asarray(partial_sizes, "<u4").tobytes() + centres.astype("<f4").tobytes() + body.tobytes()
    path.write_bytes(bytes(header) + bytes(section) + data)
