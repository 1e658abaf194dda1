"""Write PlayCanvas SOG (version 2): a zip of lossless WebP images and a ``meta.json``.

No Python library writes SOG (gsply 0.4.6 reads it), so this module does, following
playcanvas/splat-transform ``src/lib/writers/write-sog.ts`` field by field, with two differences:
the splats keep the input order (splat-transform sorts them along a Morton curve; the order of a
GASP frame is the input's, which the ``split`` layout relies on), and each 256-entry codebook is a
1D k-means (Lloyd iterations from quantiles) instead of splat-transform's histogram dynamic
programme. Images are ``width = ceil(sqrt(n) / 4) * 4`` by ``height = ceil(n / width / 4) * 4``
pixels, splat ``i`` at pixel ``i`` in row-major order:

* ``means_l.webp`` / ``means_u.webp``: low / high byte of ``65535 (l(x) - min) / (max - min)`` per
  axis, ``l(x) = sign(x) log(|x| + 1)``; ``meta.means.mins/maxs`` are ``l`` of the bounds.
* ``quats.webp``: smallest three of the unit quaternion (w, x, y, z; largest made positive), each
  ``255 (q sqrt2 / 2 + 1/2)``, alpha ``252 + index of the largest``.
* ``scales.webp``: codebook indices of the three log-scales; ``meta.scales.codebook``.
* ``sh0.webp``: codebook indices of ``f_dc``; alpha ``255 sigmoid(opacity)``; ``meta.sh0.codebook``.
* ``shN_centroids.webp`` / ``shN_labels.webp``: the higher SH bands as a palette (k-means over the
  ``3K`` coefficients, ``min(64, 2^floor(log2(n / 1024))) * 1024`` entries, at most ``n``), its
  values as indices of a 256-entry codebook; labels as 16-bit indices in R, G.

The SH palette is computed once per SH array and reused: GASP's frames share their SH with the
input, so a run clusters once per object.
"""
from __future__ import annotations

import io
import json
import math
import warnings
import zipfile
from pathlib import Path

import numpy as np

from gasp_core.fsutil import atomic_write
from gasp_core.errors import SceneError
from gasp_core.gs.gaussians import Gaussians

_SH_CACHE: dict = {}


def codebook_1d(values: np.ndarray, k: int = 256, iterations: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """A ``k``-entry codebook of ``values`` (any shape) and each value's index (uint8, same shape).

    1D k-means: start at ``k / 2`` quantiles and ``k / 2`` evenly spaced values (so that the tails,
    e.g. a few very bright colours, get entries too, as splat-transform's blend of rank and value
    does), then Lloyd steps (assign to the nearest of the sorted centroids, move each to its
    members' mean). The codebook is sorted ascending, float32.
    """
    v = np.asarray(values, np.float64).ravel()
    if v.size == 0:
        return np.zeros(k, np.float32), np.zeros(np.shape(values), np.uint8)
    c = np.unique(np.concatenate([np.quantile(v, (np.arange(k // 2) + 0.5) / (k // 2)),
                                  np.linspace(v.min(), v.max(), k - k // 2)]))
    for _ in range(iterations):
        labels = _nearest(c, v)
        sums = np.bincount(labels, v, len(c))
        counts = np.bincount(labels, minlength=len(c))
        c = np.unique(np.where(counts > 0, sums / np.maximum(counts, 1), c))
    book = np.full(k, c[-1], np.float32)
    book[:len(c)] = c
    return book, _nearest(book.astype(np.float64), v).astype(np.uint8).reshape(np.shape(values))


def _nearest(sorted_c: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Index of the nearest entry of an ascending array for each value of ``v``."""
    mid = 0.5 * (sorted_c[1:] + sorted_c[:-1])
    return np.searchsorted(mid, v, side="right")


def _webp(rgba: np.ndarray) -> bytes:
    """Lossless WebP of an (h, w, 4) uint8 image, transparent pixels' colour kept."""
    from PIL import Image
    buf = io.BytesIO()
    # lossless: quality is the encoder's effort; 75 gives within 1 % of 100's size at a fraction of the time
    Image.fromarray(rgba).save(buf, "WEBP", lossless=True, exact=True, quality=75, method=4)
    return buf.getvalue()


def _image(channels: list[np.ndarray], w: int, h: int, alpha=255) -> np.ndarray:
    """An (h, w, 4) uint8 image with splat ``i`` at pixel ``i``: the given channels, then 0, alpha 255."""
    img = np.zeros((w * h, 4), np.uint8)
    img[:, 3] = 255
    n = len(channels[0])
    for j, ch in enumerate(channels):
        img[:n, j] = ch
    if not isinstance(alpha, int):
        img[:n, 3] = alpha
    return img.reshape(h, w, 4)


def _means(g: Gaussians, w: int, h: int) -> tuple[dict, dict]:
    lm = np.sign(g.means) * np.log(np.abs(g.means) + 1.0)
    lo, hi = lm.min(axis=0), lm.max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    u = np.floor(65535.0 * (lm - lo) / span).astype(np.uint32)
    files = {"means_l.webp": _webp(_image([u[:, j] & 0xFF for j in range(3)], w, h)),
             "means_u.webp": _webp(_image([u[:, j] >> 8 for j in range(3)], w, h))}
    return {"mins": lo.tolist(), "maxs": hi.tolist(), "files": list(files)}, files


def _quats(g: Gaussians, w: int, h: int) -> bytes:
    q = g.rotations / np.linalg.norm(g.rotations, axis=1, keepdims=True)
    largest = np.argmax(np.abs(q), axis=1)
    rows = np.arange(g.n)
    q = q * np.where(q[rows, largest] < 0, -1.0, 1.0)[:, None] * math.sqrt(2.0)
    others = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])[largest]
    abc = np.clip(255.0 * (q[rows[:, None], others] * 0.5 + 0.5), 0, 255).astype(np.uint8)
    return _webp(_image([abc[:, 0], abc[:, 1], abc[:, 2]], w, h, alpha=(252 + largest).astype(np.uint8)))


def _sh_rest(g: Gaussians, w: int, h: int) -> tuple[dict, dict]:
    """The ``shN`` entry of ``meta.json`` and its two images (cached per SH array)."""
    key = (id(g.sh_rest), g.sh_rest.shape)
    if key in _SH_CACHE and _SH_CACHE[key][0] is g.sh_rest:
        return _SH_CACHE[key][1], _SH_CACHE[key][2]
    from scipy.cluster.vq import kmeans2
    n, k = g.sh_rest.shape[:2]
    bands = {3: 1, 8: 2, 15: 3}[k]
    flat = g.sh_rest.transpose(0, 2, 1).reshape(n, 3 * k).astype(np.float64)  # channel-major
    palette = int(min(64, 2 ** max(0, math.floor(math.log2(max(n / 1024, 1))))) * 1024)
    palette = min(palette, n)
    if palette >= n:  # a palette as large as the file: every splat its own entry
        centroids, labels = flat, np.arange(n)
    else:
        with warnings.catch_warnings():  # an empty cluster keeps its start point: harmless here
            warnings.simplefilter("ignore", UserWarning)
            centroids, labels = kmeans2(flat, palette, iter=10, minit="points", seed=0)
    book, idx = codebook_1d(centroids)
    rows = math.ceil(palette / 64)
    cimg = np.zeros((rows * 64, k, 4), np.uint8)
    cimg[..., 3] = 255
    for c in range(3):
        cimg[:palette, :, c] = idx[:, c * k:(c + 1) * k]
    cimg = cimg.reshape(rows, 64 * k, 4)
    labels = labels.astype(np.uint32)
    files = {"shN_centroids.webp": _webp(cimg),
             "shN_labels.webp": _webp(_image([labels & 0xFF, labels >> 8], w, h))}
    meta = {"count": palette, "bands": bands, "codebook": book.tolist(), "files": list(files)}
    _SH_CACHE.clear()
    _SH_CACHE[key] = (g.sh_rest, meta, files)
    return meta, files


def write_sog(path, g: Gaussians, *, overwrite: bool = False) -> Path:
    """Write ``g`` as a SOG bundle (``.sog``: a zip of ``meta.json`` and the WebP images), atomically.

    Parameters
    ----------
    path : path-like
    g : Gaussians
    overwrite : bool

    Returns
    -------
    Path

    Raises
    ------
    FileExistsError
        ``path`` exists and ``overwrite`` is false.
    ImportError
        Without Pillow (``pip install -e ".[formats]"``).
    SceneError
        ``g`` holds no Gaussians (a SOG's bounds and codebooks need one).

    Notes
    -----
    Precision: positions 16 bits per axis in ``sign(x) log(|x| + 1)`` over the object's bounds;
    log-scales and ``f_dc`` one of 256 codebook values each; opacity 8 bits; rotations 8 bits per
    component. A zero scale (``log = -inf``) is stored as ``exp(-30)``.
    """
    n = g.n
    if not n:
        raise SceneError(f"{path}: no Gaussians to write; a .sog file holds at least one")
    w = max(4, math.ceil(math.sqrt(n) / 4) * 4)
    h = max(4, math.ceil(n / w / 4) * 4)
    files: dict[str, bytes] = {}
    means_meta, means_files = _means(g, w, h)
    files.update(means_files)
    files["quats.webp"] = _quats(g, w, h)
    with np.errstate(divide="ignore"):
        log_s = np.maximum(np.log(g.scales), -30.0)
    s_book, s_idx = codebook_1d(log_s)
    files["scales.webp"] = _webp(_image([s_idx[:, j] for j in range(3)], w, h))
    c_book, c_idx = codebook_1d(g.sh_dc)
    alpha = np.clip(255.0 / (1.0 + np.exp(-g.opacities.astype(np.float64))), 0, 255).astype(np.uint8)
    files["sh0.webp"] = _webp(_image([c_idx[:, j] for j in range(3)], w, h, alpha=alpha))
    meta = {"version": 2, "asset": {"generator": "gasp"}, "count": n, "means": means_meta,
            "scales": {"codebook": s_book.tolist(), "files": ["scales.webp"]},
            "quats": {"files": ["quats.webp"]},
            "sh0": {"codebook": c_book.tolist(), "files": ["sh0.webp"]}}
    if g.sh_rest.shape[1]:
        meta["shN"], sh_files = _sh_rest(g, w, h)
        files.update(sh_files)

    def write(f):
        with zipfile.ZipFile(f, "w", zipfile.ZIP_STORED) as z:
            z.writestr("meta.json", json.dumps(meta))
            for name, data in files.items():
                z.writestr(name, data)

    return atomic_write(path, write, overwrite=overwrite)
