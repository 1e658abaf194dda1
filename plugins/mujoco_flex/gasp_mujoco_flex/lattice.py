"""Coarse conforming tetrahedral lattices around point sets, and barycentric embedding.

Pure numpy/scipy; no MuJoCo. The lattice is a voxel grid of cell size ``h`` whose occupied cells
(those that hold a point, then closed and hole-filled) are each split into the six Kuhn
(Freudenthal) tetrahedra that share the cell diagonal from corner (0,0,0) to (1,1,1). All cells use
the same split, so neighbouring cells share whole faces (the triangulation is conforming).
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import permutations

import numpy as np
from scipy import ndimage

#: The six axis orders of the Kuhn simplices. Tetrahedron k of a cell with order (a, b, c) has the
#: corners 0, e_a, e_a + e_b, e_a + e_b + e_c and holds the local points with u_a >= u_b >= u_c.
KUHN_ORDERS = np.array(list(permutations(range(3))), dtype=np.int64)  # (6, 3)


def _kuhn_corners() -> np.ndarray:
    """Corner offsets of the 6 Kuhn tetrahedra, shape (6, 4, 3), int64."""
    out = np.zeros((6, 4, 3), dtype=np.int64)
    for k, order in enumerate(KUHN_ORDERS):
        c = np.zeros(3, dtype=np.int64)
        for j, axis in enumerate(order):
            c = c.copy()
            c[axis] = 1
            out[k, j + 1] = c
    return out


KUHN_CORNERS = _kuhn_corners()


@dataclass
class Lattice:
    """A conforming tetrahedral lattice over a voxel grid.

    Attributes
    ----------
    h : float
        Cell size, metres.
    origin : ndarray, shape (3,), float64
        World position of grid node (0, 0, 0), metres.
    occupied : ndarray, shape (nx, ny, nz), bool
        Occupied cells.
    vertices : ndarray, shape (n_vertices, 3), float64
        Lattice vertex positions, metres.
    tets : ndarray, shape (n_tets, 4), int64
        Vertex indices of each tetrahedron (6 per occupied cell, in cell order then Kuhn order).
    cells : ndarray, shape (n_cells, 3), int64
        Integer index of each occupied cell (cell ``i`` owns tets ``6 i .. 6 i + 5``).
    """

    h: float
    origin: np.ndarray
    occupied: np.ndarray
    vertices: np.ndarray
    tets: np.ndarray
    cells: np.ndarray

    @property
    def tet_volume(self) -> float:
        """Volume of one tetrahedron, m^3 (every Kuhn tet has volume h^3 / 6)."""
        return self.h ** 3 / 6.0

    @property
    def volume(self) -> float:
        """Total lattice volume, m^3."""
        return len(self.cells) * self.h ** 3

    def matched_masses(self, rho: float, mass: float, com: np.ndarray, floor: float = 0.25,
                       cap: float = 4.0) -> np.ndarray:
        """Lumped vertex masses reweighted to the points' total mass and centre of mass, kg, shape (n_vertices,).

        The lattice's own masses (:meth:`vertex_masses`, uniform ``rho``) are multiplied by an affine
        density factor ``f(x) = (M / M0) (1 + beta . (x - c0))``. With ``M0``, ``c0`` the lattice's
        mass and centre of mass and ``S = sum_v m0_v r_v r_v^T`` (``r_v = x_v - c0``), the first
        moment condition ``sum_v m0_v f_v r_v = M (com - c0)`` gives ``beta = M0 S^-1 (com - c0)``, so
        the total is ``M`` and the centre of mass is ``com`` exactly. The factor is kept in
        ``[floor, cap]`` times ``M / M0`` (then rescaled to ``M``): MuJoCo's implicit solve needs no
        vertex much lighter than its neighbours (point-lumped masses, which leave light vertices, were
        ill-conditioned). A centre of mass too far off for that range is only approached.

        Parameters
        ----------
        rho : float
            Lattice density, kg/m^3 (only the shape of the distribution matters).
        mass : float
            Points' total mass ``sum rho p_vol``, kg.
        com : ndarray, shape (3,)
            Points' centre of mass, metres.
        """
        return matched_masses(self.vertex_masses(rho), self.vertices, mass, com, floor, cap)

    def vertex_masses(self, rho: float) -> np.ndarray:
        """Lumped vertex masses ``rho * V_tet / 4`` summed over incident tets, kg, shape (n_vertices,)."""
        m = np.zeros(len(self.vertices))
        np.add.at(m, self.tets.ravel(), rho * self.tet_volume / 4.0)
        return m


def matched_masses(m0: np.ndarray, at: np.ndarray, mass: float, com: np.ndarray, floor: float = 0.25,
                   cap: float = 4.0) -> np.ndarray:
    """Masses ``m0`` at ``at`` (shape (k,), (k, 3)) times the affine factor of :meth:`Lattice.matched_masses`:
    total ``mass`` (kg) and centre of mass ``com`` (m) where ``[floor, cap]`` allows, shape (k,)."""
    M0 = float(m0.sum())
    c0 = m0 @ at / M0
    r = at - c0
    S = (m0[:, None] * r).T @ r
    beta = M0 * np.linalg.lstsq(S, np.asarray(com, np.float64) - c0, rcond=1e-12)[0]
    m = m0 * np.clip(1.0 + r @ beta, floor, cap)
    return m * (float(mass) / float(m.sum()))


def build_lattice(x: np.ndarray, h: float, close_iters: int = 1) -> Lattice:
    """Voxelise points, close and fill the interior, and split each cell into 6 tetrahedra.

    Parameters
    ----------
    x : ndarray, shape (n, 3), float64
        Points of one body, metres.
    h : float
        Cell size, metres (> 0).
    close_iters : int
        Iterations of the binary closing applied before ``binary_fill_holes`` (bridges gaps between
        surface samples so a hollow shell encloses its interior).

    Returns
    -------
    Lattice

    Raises
    ------
    ValueError
        If ``x`` is empty or ``h`` is not positive and finite.
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 3 or len(x) == 0:
        raise ValueError(f"build_lattice: x must have shape (n>0, 3), got {x.shape}")
    if not (np.isfinite(h) and h > 0):
        raise ValueError(f"build_lattice: cell size h must be positive and finite, got {h}")
    lo, hi = x.min(axis=0), x.max(axis=0)
    ext = hi - lo
    n = np.floor(ext / h).astype(np.int64) + 1             # cells per axis that cover [lo, hi]
    pad = close_iters + 1                                   # room for the closing
    origin = lo - 0.5 * (n * h - ext) - pad * h             # centre the body in its cells
    shape = tuple(int(v) for v in n + 2 * pad)
    idx = np.floor((x - origin) / h).astype(np.int64)
    idx = np.clip(idx, 0, np.array(shape) - 1)
    occ = np.zeros(shape, dtype=bool)
    occ[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    if close_iters > 0:
        occ |= ndimage.binary_closing(occ, structure=np.ones((3, 3, 3), bool), iterations=close_iters)
    occ = ndimage.binary_fill_holes(occ)

    cells = np.argwhere(occ).astype(np.int64)                        # (nc, 3)
    corner_nodes = cells[:, None, None, :] + KUHN_CORNERS[None]      # (nc, 6, 4, 3)
    node_shape = np.array(shape) + 1
    flat = np.ravel_multi_index(corner_nodes.reshape(-1, 3).T, node_shape)
    used, inverse = np.unique(flat, return_inverse=True)
    tets = inverse.reshape(-1, 4).astype(np.int64)
    node_ijk = np.stack(np.unravel_index(used, node_shape), axis=1)
    vertices = origin + node_ijk * h
    return Lattice(h=float(h), origin=origin, occupied=occ, vertices=vertices, tets=tets, cells=cells)


def embed_points(lat: Lattice, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Containing tetrahedron and barycentric weights of each point.

    Parameters
    ----------
    lat : Lattice
    x : ndarray, shape (n, 3), float64
        Points, metres.

    Returns
    -------
    tet : ndarray, shape (n,), int64
        Index into ``lat.tets``.
    w : ndarray, shape (n, 4), float64
        Barycentric weights (sum 1); ``x == (w[:, :, None] * lat.vertices[lat.tets[tet]]).sum(1)``.
        Points in an occupied cell get weights in [0, 1]; a point in an empty cell is embedded in the
        nearest occupied cell's tetrahedron with extrapolated (possibly negative) weights.

    Notes
    -----
    In a cell with local coordinates ``u`` sorted so that ``u_a >= u_b >= u_c``, the Kuhn tet of
    order (a, b, c) holds the point with weights ``(1 - u_a, u_a - u_b, u_b - u_c, u_c)``.
    """
    x = np.asarray(x, dtype=np.float64)
    shape = np.array(lat.occupied.shape)
    rel = (x - lat.origin) / lat.h
    cell = np.clip(np.floor(rel).astype(np.int64), 0, shape - 1)
    inside = lat.occupied[cell[:, 0], cell[:, 1], cell[:, 2]]
    if not inside.all():  # nearest occupied cell, by the Euclidean distance transform of the empty cells
        _, near = ndimage.distance_transform_edt(~lat.occupied, return_indices=True)
        c = cell[~inside]
        cell[~inside] = np.stack([near[k][c[:, 0], c[:, 1], c[:, 2]] for k in range(3)], axis=1)
    # cell index -> row in lat.cells
    cell_id = np.full(lat.occupied.shape, -1, dtype=np.int64)
    cell_id[tuple(lat.cells.T)] = np.arange(len(lat.cells))
    cid = cell_id[cell[:, 0], cell[:, 1], cell[:, 2]]
    u = rel - cell                                            # local coordinates (in [0,1] inside)
    order = np.argsort(-np.clip(u, 0.0, 1.0), axis=1, kind="stable")   # (n, 3): u_a >= u_b >= u_c
    # Kuhn order index of each row
    key = order[:, 0] * 9 + order[:, 1] * 3 + order[:, 2]
    lut = np.full(27, -1, dtype=np.int64)
    for k, o in enumerate(KUHN_ORDERS):
        lut[o[0] * 9 + o[1] * 3 + o[2]] = k
    k = lut[key]
    tet = cid * 6 + k
    ua = np.take_along_axis(u, order, axis=1)
    w = np.stack([1.0 - ua[:, 0], ua[:, 0] - ua[:, 1], ua[:, 1] - ua[:, 2], ua[:, 2]], axis=1)
    return tet, w


def interpolate(vertices: np.ndarray, tets: np.ndarray, tet: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Embedded point values ``sum_j w_j * vertices[tets[tet, j]]``, shape (n, 3)."""
    return np.einsum("nj,njk->nk", w, vertices[tets[tet]])
