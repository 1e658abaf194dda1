"""The PlayCanvas / SuperSplat compressed PLY (element ``chunk`` + 4 packed uint32 per splat)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from plyfile import PlyData

from gasp_core.gs.gaussians import MAX_MAGNITUDE, SH_REST_COUNT, Gaussians
from gasp_core.gs.ply import LOGIT_CLAMP, SH_C0, check_columns, numbered_names, reject_file, stack_columns


_CHUNK_REQUIRED = ("min_x", "min_y", "min_z", "max_x", "max_y", "max_z",
                   "min_scale_x", "min_scale_y", "min_scale_z",
                   "max_scale_x", "max_scale_y", "max_scale_z")
_CHUNK_COLOUR = ("min_r", "min_g", "min_b", "max_r", "max_g", "max_b")
#: Largest |colour bound| of a chunk: colours are nominally in [0, 1]; a bound far beyond would overflow the
#: float32 SH coefficient ``(c - 0.5) / SH_C0`` (a 1e38 bound did, found by tests/test_fuzz_readers.py).
MAX_COLOUR = 1e6
_PACKED = ("packed_position", "packed_rotation", "packed_scale", "packed_color")


def _unorm(v: np.ndarray, shift: int, bits: int) -> np.ndarray:
    """Unsigned-normalised field of ``bits`` bits at ``shift``: in [0, 1], float64."""
    t = (1 << bits) - 1
    return ((v >> np.uint32(shift)) & np.uint32(t)).astype(np.float64) / t


def _lerp(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    return a * (1.0 - t) + b * t


def decode_compressed(path: Path, ply: PlyData) -> Gaussians:
    """Decode a PlayCanvas / SuperSplat compressed PLY.

    Layout (one ``chunk`` row per 256 consecutive splats, all float32: min/max of position,
    of log-scale, and optionally of colour; one ``vertex`` row of four uint32 per splat):

    * ``packed_position``: x 11 bits (31..21), y 10 bits (20..11), z 11 bits (10..0), each an
      unorm lerped between the chunk's ``min_*`` and ``max_*``.
    * ``packed_rotation``: bits 31..30 = index (in w,x,y,z order) of the largest-magnitude
      component, which is dropped and rebuilt as ``sqrt(1 - a^2 - b^2 - c^2) >= 0``; bits 29..20,
      19..10, 9..0 = the other three components in w,x,y,z order, each ``(unorm - 0.5) * sqrt(2)``
      (they lie in ``[-1/sqrt2, 1/sqrt2]``). The result is renormalised here.
    * ``packed_scale``: 11/10/11 like the position, lerped in the chunk's log-scale range, then
      ``exp``.
    * ``packed_color``: R bits 31..24, G 23..16, B 15..8, alpha 7..0. Colour is lerped in the
      chunk's ``min_r..max_b`` when the chunk has those fields (else used as is);
      ``f_dc = (c - 0.5) / SH_C0``. Opacity logit ``-log(1/a - 1)``, with ``a = 0 -> -40`` and
      ``a = 1 -> +40``.
    * Optional element ``sh`` of uint8 ``f_rest_*`` (channel-major): ``(n - 0.5) * 8`` with
      ``n = 0`` for 0, ``1`` for 255, else ``(v + 0.5) / 256``.

    ``meta["chunk_bounds"]``, shape (n_chunks, 2, 3), float64: each chunk's min and max
    position, in the file's row order (splat ``i`` is in chunk ``i // 256``).

    Sources: playcanvas/engine ``src/scene/gsplat/gsplat-compressed-data.js``
    (``SplatCompressedIterator``: ``unpack111011``, ``unpack8888``, ``unpackRot``, and
    ``decompress()``: the +/-40 opacity clamp) and playcanvas/splat-transform
    ``src/lib/readers/decompress-ply.ts`` (12- or 18-float chunks, the ``sh`` element).
    """
    chunk, vertex = _checked_elements(path, ply)
    cnames = set(chunk.dtype.names or ())
    n = len(vertex)
    ci = np.arange(n) // 256

    def cget(name):
        return np.asarray(chunk[name], dtype=np.float64)[ci]

    def unpack_11_10_11(packed_name: str, lo_prefix: str, hi_prefix: str) -> np.ndarray:
        """x, y, z packed 11/10/11 bits in one uint32, each lerped in its chunk's [min, max]."""
        packed = vertex[packed_name].astype(np.uint32)
        return np.stack([_lerp(cget(f"{lo_prefix}{a}"), cget(f"{hi_prefix}{a}"), _unorm(packed, shift, bits))
                         for a, shift, bits in (("x", 21, 11), ("y", 11, 10), ("z", 0, 11))], axis=1)

    means = unpack_11_10_11("packed_position", "min_", "max_")

    q = _unpack_rotations(vertex["packed_rotation"].astype(np.uint32))

    log_s = unpack_11_10_11("packed_scale", "min_scale_", "max_scale_")

    col = vertex["packed_color"].astype(np.uint32)
    rgb = np.stack([_unorm(col, s, 8) for s in (24, 16, 8)], axis=1)
    if all(c in cnames for c in _CHUNK_COLOUR):
        rgb = np.stack([_lerp(cget(f"min_{c}"), cget(f"max_{c}"), rgb[:, j])
                        for j, c in enumerate("rgb")], axis=1)
    alpha = _unorm(col, 0, 8)
    with np.errstate(divide="ignore"):
        opac = np.where(alpha <= 0, -LOGIT_CLAMP,
                        np.where(alpha >= 1, LOGIT_CLAMP, -np.log(1.0 / alpha - 1.0)))
    sh_dc = ((rgb - 0.5) / SH_C0).astype(np.float32)

    sh_rest = _sh_rest(path, ply, n)
    return Gaussians(means=means, scales=np.exp(log_s), rotations=q,
                     opacities=opac.astype(np.float32), sh_dc=sh_dc, sh_rest=sh_rest,
                     extra={}, source=str(path), layout="compressed",
                     meta={"chunk_bounds": np.stack(
                         [np.stack([np.asarray(chunk[f"min_{a}"], np.float64) for a in "xyz"], 1),
                          np.stack([np.asarray(chunk[f"max_{a}"], np.float64) for a in "xyz"], 1)],
                         axis=1)})


def _checked_elements(path: Path, ply: PlyData) -> tuple[np.ndarray, np.ndarray]:
    """The ``chunk`` and ``vertex`` elements of a compressed PLY, after refusing (:class:`SceneError`) a missing
    element or property, a non-integer packed property, out-of-range chunk bounds or a chunk count other
    than ``ceil(n / 256)``."""
    if "chunk" not in [e.name for e in ply.elements]:
        reject_file(path, "unknown layout: packed_* vertex properties without a 'chunk' element; "
                    "expected a PlayCanvas compressed PLY")
    chunk = ply["chunk"].data
    cnames = set(chunk.dtype.names or ())
    vertex = ply["vertex"].data
    vnames = set(vertex.dtype.names or ())
    missing = [c for c in _CHUNK_REQUIRED if c not in cnames]
    if missing:
        reject_file(path, f"compressed PLY chunk element has no {', '.join(missing)}; expected "
                    f"{', '.join(_CHUNK_REQUIRED)} [+ {', '.join(_CHUNK_COLOUR)}]")
    missing = [c for c in _PACKED if c not in vnames]
    if missing:
        reject_file(path, f"compressed PLY vertex element has no {', '.join(missing)}; expected "
                    f"{', '.join(_PACKED)} (uint32)")
    for c in _PACKED:
        if vertex[c].dtype.kind not in "iu":
            reject_file(path, f"compressed PLY vertex property '{c}' has type {vertex[c].dtype}; expected uint32")
    check_columns(path, chunk, _CHUNK_REQUIRED[:6], "chunk", -MAX_MAGNITUDE, MAX_MAGNITUDE)
    check_columns(path, chunk, _CHUNK_REQUIRED[6:], "chunk", hi=math.log(MAX_MAGNITUDE),
                  expected=f"a finite log-scale <= {math.log(MAX_MAGNITUDE):.2f} (scale <= {MAX_MAGNITUDE:g})")
    check_columns(path, chunk, [c for c in _CHUNK_COLOUR if c in cnames], "chunk", -MAX_COLOUR, MAX_COLOUR)
    n = len(vertex)
    n_chunks = len(chunk)
    if n_chunks != -(-n // 256):
        reject_file(path, f"compressed PLY has {n_chunks} chunks for {n} splats; expected ceil(n/256) "
                    f"= {-(-n // 256)}")
    return chunk, vertex


def _unpack_rotations(rot: np.ndarray) -> np.ndarray:
    """Unit quaternions (n, 4) wxyz from ``packed_rotation`` (uint32): the largest component rebuilt from the
    other three (see :func:`decode_compressed`)."""
    n = len(rot)
    norm = math.sqrt(2.0)
    abc = np.stack([(_unorm(rot, s, 10) - 0.5) * norm for s in (20, 10, 0)], axis=1)
    m = np.sqrt(np.maximum(0.0, 1.0 - np.sum(abc * abc, axis=1)))
    largest = (rot >> np.uint32(30)).astype(np.int64)
    q = np.empty((n, 4))
    others = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])[largest]  # (n, 3)
    rows = np.arange(n)
    q[rows, largest] = m
    for j in range(3):
        q[rows, others[:, j]] = abc[:, j]
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return q


def _sh_rest(path: Path, ply: PlyData, n: int) -> np.ndarray:
    """``sh_rest`` (n, K, 3) float32 from the optional ``sh`` element of uint8 ``f_rest_*`` (else K = 0)."""
    sh_rest = np.zeros((n, 0, 3), dtype=np.float32)
    if "sh" in [e.name for e in ply.elements]:
        sh = ply["sh"].data
        rest_names = numbered_names(sh.dtype.names or (), "f_rest_")
        k3 = len(rest_names)
        if k3 % 3 or k3 // 3 not in SH_REST_COUNT.values() or len(sh) != n:
            reject_file(path, f"compressed PLY 'sh' element has {k3} f_rest_* x {len(sh)} rows; "
                        f"expected 9, 24 or 45 x {n}")
        check_columns(path, sh, rest_names, "sh")
        v = stack_columns(sh, rest_names)
        u = np.where(v == 0, 0.0, np.where(v == 255, 1.0, (v + 0.5) / 256.0))
        f_rest = ((u - 0.5) * 8.0).astype(np.float32)
        sh_rest = np.ascontiguousarray(f_rest.reshape(n, 3, k3 // 3).transpose(0, 2, 1))
    return sh_rest
