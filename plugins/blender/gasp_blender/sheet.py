"""A coarse quad sheet through a thin point set, and bilinear embedding with a normal offset. No bpy.

The sheet spans the two largest principal axes of the points (PCA) and sits on their mean; each
point is tied to its quad by bilinear weights in the sheet plane plus its signed distance ``d``
along the quad normal, so ``x = sum_k w_k V_k + d n(quad)`` holds exactly at rest.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Sheet:
    """A quad grid. ``vertices`` (n_vertices, 3) metres; ``quads`` (n_quads, 4) vertex indices
    counter-clockwise about ``normal``; ``h`` cell size, m; ``normal`` the rest normal (3,)."""

    h: float
    vertices: np.ndarray
    quads: np.ndarray
    normal: np.ndarray
    shape: tuple[int, int]


def build_sheet(x: np.ndarray, cells_across: int) -> tuple[Sheet, np.ndarray, np.ndarray, np.ndarray]:
    """The sheet of a thin point set and each point's quad, bilinear weights and normal offset.

    Returns
    -------
    sheet : Sheet
    quad : ndarray, shape (n,), int64
    w : ndarray, shape (n, 4), float64
    d : ndarray, shape (n,), float64
        Signed distance along the rest normal, metres.
    """
    x = np.asarray(x, dtype=np.float64)
    c = x.mean(axis=0)
    _, _, vt = np.linalg.svd(x - c, full_matrices=False)
    u1, u2 = vt[0], vt[1]
    n = np.cross(u1, u2)
    a, b = (x - c) @ u1, (x - c) @ u2
    ext1 = max(float(np.ptp(a)), 1e-9)
    h = ext1 / cells_across
    n1 = cells_across
    n2 = max(1, int(np.ceil(max(float(np.ptp(b)), 1e-9) / h)))
    a0, b0 = a.min(), b.min() - 0.5 * (n2 * h - np.ptp(b))
    ii, jj = np.meshgrid(np.arange(n1 + 1), np.arange(n2 + 1), indexing="ij")
    verts = c + (a0 + ii.ravel()[:, None] * h) * u1 + (b0 + jj.ravel()[:, None] * h) * u2
    vid = (ii * (n2 + 1) + jj)
    quads = np.stack([vid[:-1, :-1].ravel(), vid[1:, :-1].ravel(), vid[1:, 1:].ravel(), vid[:-1, 1:].ravel()], 1)
    s = (a - a0) / h
    t = (b - b0) / h
    i = np.clip(np.floor(s).astype(np.int64), 0, n1 - 1)
    j = np.clip(np.floor(t).astype(np.int64), 0, n2 - 1)
    fs, ft = s - i, t - j
    w = np.stack([(1 - fs) * (1 - ft), fs * (1 - ft), fs * ft, (1 - fs) * ft], axis=1)
    quad = i * n2 + j
    d = (x - c) @ n
    return Sheet(float(h), verts, quads.astype(np.int64), n, (n1 + 1, n2 + 1)), quad, w, d


def quad_normals(vertices: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Unit normal of each (possibly non-planar) quad from its two diagonals, shape (n_quads, 3)."""
    v = vertices[quads]
    nrm = np.cross(v[:, 2] - v[:, 0], v[:, 3] - v[:, 1])
    return nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)


def place(vertices: np.ndarray, sheet: Sheet, quad: np.ndarray, w: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Embedded point positions on a moved sheet, shape (n, 3)."""
    nq = quad_normals(vertices, sheet.quads)
    return np.einsum("nk,nkd->nd", w, vertices[sheet.quads[quad]]) + d[:, None] * nq[quad]
