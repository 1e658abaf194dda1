"""Each body's smooth surface, as the contact sees it (``contact = "surface"``, ``docs/contact.md``).

A scanned body's outer points are irregular: its Gaussians' triangle vertices stand up to a few millimetres proud
of the surface they sample, jittered as the scan left them, and the fill's outer cells are shared among them
unevenly. A contact that takes its depth from those points pushes off-centre at every impact and spins the body.
The surface contact takes its depth from a smooth surface instead and lets the regular fill carry it:

- the body's surface is the implicit moving-least-squares surface of its triangles (IMLS, Kolluri 2008, "Provably
  good moving least squares"): ``f(y) = sum_i w_i(y) n_i . (y - c_i) / sum_i w_i(y)`` over the triangles' centroids
  ``c_i`` and outward unit normals ``n_i``, ``w_i = exp(-|y - c_i|^2 / eps^2)`` with ``eps = WIDTH`` median centroid
  spacings: a signed distance (m, > 0 outside) that averages the triangles' scatter over a few of them;
- the normals are oriented outward by the body's blurred volume fraction (:func:`volume_grid`: ``grad phi`` points
  into the body);
- each fill point within ``BAND`` of its own spacing of that surface gets the rest offset ``o_p`` to its nearest
  surface point (``y - f(y) n(y)``, three steps) and the particle contact's stiffness ``KAPPA E h_p`` tapered
  (``cos^2``) to 0 between ``BAND - 0.5`` and ``BAND + 0.5`` spacings deep; the deformation carries the offset
  (``x_p + F_p o_p``), so the contact meets the surface where the body has moved it.

The surface points themselves (the Gaussians' vertices) take no part in the contact: they ride on the body.
A body without triangles (points given in code) or without fill keeps the particle contact's skin per point.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

#: Depth (in fill spacings) of the middle of the band of fill points that carry the surface contact.
BAND = 1.5
#: The IMLS kernel's width per median triangle-centroid spacing.
WIDTH = 2.0
#: Largest number of cells of one body's blur grid (:func:`volume_grid`).
MAX_CELLS = 8_000_000


def body_spacing(p_vol: np.ndarray) -> float:
    """Volume-weighted mean spacing ``cbrt(sum p_vol^2 / sum p_vol)`` (m) of a body's points (its fill's spacing
    where the fill holds most of the volume); 0 without volume."""
    v = np.asarray(p_vol, dtype=np.float64)
    s = float(v.sum())
    return float(np.cbrt(float((v * v).sum()) / s)) if s > 0.0 else 0.0


def volume_grid(x: np.ndarray, p_vol: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The blurred volume fraction ``phi = sum_p p_vol K_sigma(y - x_p)`` of one body (``K_sigma`` a normalised
    Gaussian) on a regular grid: ``(phi, lo, h)``, the grid's values, corner (m) and spacing (m; ``sigma / 2``
    unless :data:`MAX_CELLS` asks for a coarser one). The points are deposited with trilinear weights, then
    ``scipy.ndimage.gaussian_filter`` adds the rest of the blur."""
    x = np.asarray(x, dtype=np.float64)
    pad = 4.0 * sigma
    lo = x.min(axis=0) - pad
    ext = x.max(axis=0) + pad - lo
    h = 0.5 * sigma
    while np.prod(np.ceil(ext / h) + 2) > MAX_CELLS:
        h *= 1.25
    shape = tuple(int(s) for s in np.ceil(ext / h) + 2)
    g = (x - lo) / h
    i0 = np.floor(g).astype(np.int64)
    f = g - i0
    grid = np.zeros(shape, dtype=np.float64)
    for c in range(8):
        o = np.array([(c >> 2) & 1, (c >> 1) & 1, c & 1])
        w = np.prod(np.where(o, f, 1.0 - f), axis=1)
        idx = i0 + o
        np.add.at(grid, (idx[:, 0], idx[:, 1], idx[:, 2]), w * p_vol)
    grid /= h ** 3
    # the trilinear deposit blurs by a tent of variance h^2 / 6 per axis: the filter makes up the rest
    sd = np.sqrt(max(sigma ** 2 - h ** 2 / 6.0, (0.5 * sigma) ** 2)) / h
    return ndimage.gaussian_filter(grid, sd, mode="constant", truncate=4.0), lo, h


def _gradient_at(grid: np.ndarray, lo: np.ndarray, h: float, y: np.ndarray) -> np.ndarray:
    c = ((y - lo) / h).T
    return np.column_stack([ndimage.map_coordinates(gr, c, order=1, mode="nearest") for gr in np.gradient(grid, h)])


def triangle_surface(tri: np.ndarray, inward: np.ndarray, width: float = WIDTH):
    """The IMLS surface of a body's triangles.

    Parameters
    ----------
    tri : ndarray, shape (t, 3, 3), float64
        The triangles' vertices (m), t >= 2.
    inward : ndarray, shape (t, 3)
        A vector into the body at each triangle's centroid (orients the normals).
    width : float
        The kernel's width per median centroid spacing.

    Returns
    -------
    callable
        ``f(y) -> (dist, normal, ok)`` at points ``y`` (m, shape (k, 3)): the signed distance (m, > 0 outside),
        the unit outward normal, and whether a triangle lies within three kernel widths (else ``dist`` is 0).
    """
    c = tri.mean(axis=1)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    n *= -np.where((n * inward).sum(axis=1) >= 0.0, 1.0, -1.0)[:, None]
    tree = cKDTree(c)
    eps = width * max(float(np.median(tree.query(c, k=2)[0][:, 1])), 1e-12)

    def f(y):
        pairs = cKDTree(y).sparse_distance_matrix(tree, 3.0 * eps, output_type="coo_matrix")
        w = np.exp(-(pairs.data / eps) ** 2)
        ws = np.bincount(pairs.row, w, len(y))
        val = np.bincount(pairs.row, w * ((y[pairs.row] - c[pairs.col]) * n[pairs.col]).sum(axis=1), len(y))
        nrm = np.column_stack([np.bincount(pairs.row, w * n[pairs.col, k], len(y)) for k in range(3)])
        nrm /= np.maximum(np.linalg.norm(nrm, axis=1), 1e-300)[:, None]
        ok = ws > 1e-12
        return np.where(ok, val / np.maximum(ws, 1e-300), 0.0), nrm, ok
    return f


def surface_carriers(tri: np.ndarray, fill_x: np.ndarray, fill_vol: np.ndarray, all_x: np.ndarray,
                     all_vol: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The fill points of one body that carry its surface contact, with their rest offsets and band weights.

    Parameters
    ----------
    tri : ndarray, shape (t, 3, 3)
        The body's triangles (m).
    fill_x, fill_vol : ndarray, shapes (m, 3) and (m,)
        Its fill points (m) and their volumes (m^3).
    all_x, all_vol : ndarray
        All its material points and volumes (they orient the triangles' normals).

    Returns
    -------
    offset : ndarray, shape (m, 3)
        From each fill point to its nearest point of the smooth surface (m; 0 outside the band).
    weight : ndarray, shape (m,)
        The band's taper in [0, 1] (0: the point does not touch).
    """
    phi, lo, h = volume_grid(all_x, all_vol, body_spacing(all_vol))
    f = triangle_surface(tri, _gradient_at(phi, lo, h, tri.mean(axis=1)))
    hp = np.cbrt(fill_vol)
    offset = np.zeros_like(fill_x)
    weight = np.zeros(len(fill_x))
    # only points near the surface can be in the band: those within BAND + 1 spacings of a triangle's centroid
    near = cKDTree(tri.mean(axis=1)).query(fill_x, k=1)[0] < (BAND + 1.0) * hp + 1e-12
    rows = np.flatnonzero(near)
    if not len(rows):
        return offset, weight
    y0 = fill_x[rows]
    d0, _, ok = f(y0)
    y = y0.copy()
    for _ in range(3):
        val, nrm, _ = f(y)
        y = y - val[:, None] * nrm
    t = np.clip(-d0 / hp[rows] - BAND + 0.5, 0.0, 1.0)
    w = np.where(ok, np.cos(0.5 * np.pi * t) ** 2, 0.0)
    offset[rows] = np.where((w > 0.0)[:, None], y - y0, 0.0)
    weight[rows] = w
    return offset, weight
