"""Coarse voxel cages around point sets, and trilinear embedding. Pure numpy/scipy; no bpy.

A cage is a voxel grid of cell size ``h``: the cells holding a point, closed and hole-filled, with
their corners as vertices and, as springs, the 12 cell edges, the 12 face diagonals and the 4 body
diagonals of every occupied cell (shared ones once). The cage's bottom face passes through the
lowest point (world z up), so the cage touches a ground where the body does. Every point is tied to the 8 corners of its
cell by trilinear weights.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import product

import numpy as np
from scipy import ndimage

#: Corner offsets of a cell, shape (8, 3), in the order of the trilinear weights.
CORNERS = np.array(list(product((0, 1), repeat=3)), dtype=np.int64)


def _pairs() -> np.ndarray:
    """Corner index pairs of the cell edges (12), face diagonals (12) and body diagonals (4)."""
    out = []
    for a in range(8):
        for b in range(a + 1, 8):
            out.append((a, b))
    return np.array(out, dtype=np.int64)  # all 28 pairs = 12 + 12 + 4


CELL_PAIRS = _pairs()


@dataclass
class Cage:
    """A voxel cage.

    Attributes
    ----------
    h : float
        Cell size, metres.
    origin : ndarray, shape (3,)
        World position of grid node (0, 0, 0), metres.
    occupied : ndarray, shape (nx, ny, nz), bool
    cells : ndarray, shape (n_cells, 3), int64
    vertices : ndarray, shape (n_vertices, 3), float64
        Metres.
    cell_vertices : ndarray, shape (n_cells, 8), int64
        Vertex index of each cell corner (order :data:`CORNERS`).
    edges : ndarray, shape (n_edges, 2), int64
        Springs (unique vertex pairs).
    """

    h: float
    origin: np.ndarray
    occupied: np.ndarray
    cells: np.ndarray
    vertices: np.ndarray
    cell_vertices: np.ndarray
    edges: np.ndarray


def build_cage(x: np.ndarray, h: float, close_iters: int = 1) -> Cage:
    """Voxelise points with cell size ``h``, close and fill, and list corners and springs.

    Raises
    ------
    ValueError
        Empty ``x`` or ``h`` not positive and finite.
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 3 or len(x) == 0:
        raise ValueError(f"build_cage: x must have shape (n>0, 3), got {x.shape}")
    if not (np.isfinite(h) and h > 0):
        raise ValueError(f"build_cage: cell size must be positive and finite, got {h}")
    lo, hi = x.min(axis=0), x.max(axis=0)
    ext = hi - lo
    n = np.floor(ext / h).astype(np.int64) + 1
    pad = close_iters + 1
    origin = lo - 0.5 * (n * h - ext) - pad * h
    # the lowest point lies on the cage's bottom face: the cage, which is what collides, then
    # meets the ground where the body does (z up)
    origin[2] = lo[2] - pad * h
    shape = tuple(int(v) for v in n + 2 * pad)
    idx = np.clip(np.floor((x - origin) / h).astype(np.int64), 0, np.array(shape) - 1)
    occ = np.zeros(shape, dtype=bool)
    occ[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    if close_iters > 0:
        occ |= ndimage.binary_closing(occ, structure=np.ones((3, 3, 3), bool), iterations=close_iters)
    occ = ndimage.binary_fill_holes(occ)
    cells = np.argwhere(occ).astype(np.int64)
    node_shape = np.array(shape) + 1
    corner_nodes = cells[:, None, :] + CORNERS[None]                      # (nc, 8, 3)
    flat = np.ravel_multi_index(corner_nodes.reshape(-1, 3).T, node_shape)
    used, inverse = np.unique(flat, return_inverse=True)
    cell_vertices = inverse.reshape(-1, 8).astype(np.int64)
    vertices = origin + np.stack(np.unravel_index(used, node_shape), axis=1) * h
    e = cell_vertices[:, CELL_PAIRS].reshape(-1, 2)
    edges = np.unique(np.sort(e, axis=1), axis=0)
    return Cage(float(h), origin, occ, cells, vertices, cell_vertices, edges)


def embed(cage: Cage, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cell and trilinear weights of each point.

    Returns
    -------
    cell : ndarray, shape (n,), int64
        Row of ``cage.cells``.
    w : ndarray, shape (n, 8), float64
        Weights (sum 1) on ``cage.cell_vertices[cell]``; a point outside every occupied cell is
        tied to the nearest occupied cell with extrapolated weights.
    """
    x = np.asarray(x, dtype=np.float64)
    shape = np.array(cage.occupied.shape)
    rel = (x - cage.origin) / cage.h
    c = np.clip(np.floor(rel).astype(np.int64), 0, shape - 1)
    inside = cage.occupied[c[:, 0], c[:, 1], c[:, 2]]
    if not inside.all():
        _, near = ndimage.distance_transform_edt(~cage.occupied, return_indices=True)
        o = c[~inside]
        c[~inside] = np.stack([near[k][o[:, 0], o[:, 1], o[:, 2]] for k in range(3)], axis=1)
    cell_id = np.full(cage.occupied.shape, -1, dtype=np.int64)
    cell_id[tuple(cage.cells.T)] = np.arange(len(cage.cells))
    cell = cell_id[c[:, 0], c[:, 1], c[:, 2]]
    u = rel - c
    w = np.ones((len(x), 8))
    for k, corner in enumerate(CORNERS):
        for d in range(3):
            w[:, k] *= u[:, d] if corner[d] else 1.0 - u[:, d]
    return cell, w


def interpolate(values: np.ndarray, cage: Cage, cell: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Embedded point values ``sum_k w_k values[cell_vertices[cell, k]]``, shape (n, 3)."""
    return np.einsum("nk,nkd->nd", w, values[cage.cell_vertices[cell]])


def lump(cage: Cage, cell: np.ndarray, w: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Per-point quantities ``q`` (n,) summed onto cage vertices by the weights, shape (n_vertices,)."""
    out = np.zeros(len(cage.vertices))
    np.add.at(out, cage.cell_vertices[cell].ravel(), (w * q[:, None]).ravel())
    return out
