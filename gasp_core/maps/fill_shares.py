"""The mass at a solid's faces (issue 66): each fill cell the surface crosses holds its share of ``h^3``, measured
at ``SUB^3`` sub-cells against the planes of the surface splats, with its fill point at the centre of its inside part
(:func:`cell_fractions`, :func:`surface_distance`, :func:`surface_planes`; docs/fill.md, "The mass at the faces").

The default fill (issue 66 item 3; it was opt-in, ``GASP_FILL=shares``, while it cost about 11 s on the README donut
against 1.5 s). Measured by ``benchmarks/fill_cost.py`` (the donut's object as ``gasp simulate`` fills it, both ways
in one run, load 2.6-3.0 on 2 cores): 1.41 s CPU against 0.59 s by whole cells, its mass 0.609 to 0.549 kg; the
family of ``tests/test_fill_mass.py`` within 1.0 % of its volume at n_grid 32, 48 and 64 (whole cells: -42 to +46 %).
Where the splats' planes do not hold the splats (:func:`outside_share`, :data:`HELD_OUT`) the object keeps every
cell whose centre ``phi`` puts inside as a whole ``h^3`` (:mod:`gasp_core.maps.fill`).
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from gasp_core.maps.occupancy import HALF_SHELL, SPLAT_SIGMA, sample_phi

#: A splat is a plane of the surface (:func:`surface_planes`) when ``phi`` falls by at least ``PLANE_STEP`` voxels
#: from one voxel behind it to one voxel in front of it along its normal, and is under ``PLANE_OUT`` voxels two voxels
#: in front (it faces the outside; a capture's Gaussians deep inside the solid do not).
PLANE_STEP, PLANE_OUT = 0.5, 0.5
#: ... and its normal is within ``acos(PLANE_COS)`` of ``phi``'s steepest descent (a trained capture's Gaussians that
#: are not flat, or lie across the surface, have normals that are not the surface's).
PLANE_COS = 0.8


def surface_planes(splats: np.ndarray, phi: np.ndarray, lo: np.ndarray, voxel: float) -> tuple[np.ndarray, np.ndarray]:
    """The splats that lie on the solid's surface as planes with their outward normals: the sub-voxel surface
    (issue 66) where ``phi``, a distance in voxels, places it only to about a voxel.

    A flat splat ``v1, v2, v3`` (GaMeS) lies in the plane through ``v1`` normal to ``(v2 - v1) x (v3 - v1)``; the normal
    is turned to where ``phi`` (:func:`solid_field`) falls, and the splat is kept when it falls by
    :data:`PLANE_STEP` voxels across it and the outside is within two voxels in front of it (:data:`PLANE_OUT`).

    Returns
    -------
    means : ndarray, shape (k, 3)
        Points on the planes (the splats' means), metres.
    normals : ndarray, shape (k, 3)
        Outward unit normals.
    """
    splats = np.asarray(splats, np.float64)
    m = splats[:, 0]
    nrm = np.cross(splats[:, 1] - m, splats[:, 2] - m)
    size = np.linalg.norm(nrm, axis=1)
    ok = size > 0
    m, nrm = m[ok], nrm[ok] / size[ok, None]
    front = sample_phi(phi, lo, voxel, m + voxel * nrm)
    back = sample_phi(phi, lo, voxel, m - voxel * nrm)
    flip = front > back
    nrm[flip] *= -1.0
    step = np.abs(back - front)
    out = sample_phi(phi, lo, voxel, m + 2.0 * voxel * nrm)
    grad = np.stack([sample_phi(phi, lo, voxel, m + voxel * e) - sample_phi(phi, lo, voxel, m - voxel * e)
                     for e in np.eye(3)], axis=1)
    cos = -np.einsum("ij,ij->i", grad, nrm) / np.maximum(np.linalg.norm(grad, axis=1), 1e-12)
    keep = (step >= PLANE_STEP) & (out < PLANE_OUT) & (cos >= PLANE_COS)
    return m[keep], nrm[keep]


#: Sub-cells per axis that a cell the surface crosses is sampled at (:func:`cell_fractions`).
SUB = 3
#: Surface planes a point is measured against (its nearest, and the neighbours that make an edge with it), and the
#: cosine under which a neighbour's plane turns from the nearest's (an edge: :func:`surface_distance`).
NEIGHBOURS, EDGE_COS = 16, 0.5
#: How far (footprint radii, the 90th percentile's) a point's foot on a plane may lie from its splat for the plane
#: to join the nearest's at a concave edge (:func:`surface_distance`).
COVER = 1.5
#: Planes nearest a cell's centre that its sub-cells look among.
CANDIDATES = 24
#: Cells by the surface (:func:`cell_fractions`): within one cell of those whose centre has ``phi`` above
#: ``-NEAR_PHI`` voxels (``phi`` stops at ``-HALF_SHELL``, 1.5, outside).
NEAR_PHI = 1.25
_CUBE = np.ones((3, 3, 3), bool)
#: A cell whose share inside is under this is left out (its volume, under 1 % of a cell, is lost).
MIN_SHARE = 0.01
#: True: a cell whose centre is past ``phi``'s floor (its distance ``inf``) is measured by its sub-cells too (round 34;
#: False: left out whole, as before, up to ``1/2 - HALF_SHELL voxel / h`` of it inside).
SAMPLE_PAST_FLOOR = True


def surface_distance(phi: np.ndarray, vlo: np.ndarray, voxel: float, splats: np.ndarray, h: float,
                     floor: float | None = None) -> Callable[..., tuple[np.ndarray, np.ndarray]]:
    """The signed distance to the solid's surface (metres, positive outside) that :func:`cell_fractions` measures
    cells with (issue 66).

    The surface is the planes of the splats that lie on it (:func:`surface_planes`).
    A point is measured against its nearest plane, bent by the surface's curvature across it (from the neighbours'
    normals: on a curved face the tangent planes lie outside the solid, which they would grow by ``l^2 / 2R``), and
    against the neighbours whose plane turns from the nearest's by more than ``acos(EDGE_COS)``: at a convex edge
    (each behind the other) the solid is the intersection of the half-spaces, at a concave edge their union (a
    sampled edge's nearest plane alone bulges out by the sampling gap, as far as the planes reach). Where no plane is
    within ``2 voxel + h + 2 SPLAT_SIGMA`` splat sizes (the 90th percentile), ``phi`` decides; and no point is
    inside where ``phi`` is more than a voxel outside (past the footprints' shell), nor under a ``floor``
    (:func:`_plane_distance` does the planes' part).

    Returns
    -------
    callable
        ``distance(q, cand=None)``: for points ``q`` (shape (k, 3), or (k, s, 3): ``k`` groups of ``s`` points close
        together, a cell's sub-cells), the signed distance and the width factor ``|n|_1`` of the plane it came from
        (1 for ``phi``'s or the floor's), both of shape ``q.shape[:-1]``. ``cand`` (shape (k, c), c >=
        :data:`NEIGHBOURS`) are indices of the planes each group looks among (``len(planes)``: none), one search
        for the group (``distance.candidates(centres)`` gives them); without it each point searches on its own.
    """
    means, normals = surface_planes(splats, phi, vlo, voxel)
    size = np.linalg.norm(splats[:, 1:] - splats[:, :1], axis=2).max(axis=1)
    footprint = SPLAT_SIGMA * float(np.quantile(size, 0.9)) if len(size) else 0.0
    reach = 2.0 * voxel + h + 2.0 * footprint
    cover = COVER * footprint
    tree = cKDTree(means) if len(means) else None
    pm = np.concatenate([means, np.zeros((1, 3))])       # a last row for "no plane": masked wherever it is read
    pn = np.concatenate([normals, np.zeros((1, 3))])
    uid = np.append(np.unique(means, axis=0, return_inverse=True)[1].ravel(), -1)    # planes through one point

    def candidates(q: np.ndarray, k: int, bound: float) -> np.ndarray:
        """Indices (shape (len(q), k)) of the ``k`` planes nearest each point within ``bound``; ``len(means)``: none."""
        return tree.query(q, k=k, distance_upper_bound=bound)[1].reshape(len(q), k)

    def distance(q: np.ndarray, cand: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        q = np.asarray(q, np.float64)
        shape = q.shape[:-1]
        qg = q.reshape(-1, 1, 3) if q.ndim == 2 or cand is None else q
        sd = _phi_distance(phi, vlo, voxel, qg.reshape(-1, 3)).reshape(qg.shape[:2])
        width = np.ones(sd.shape)
        if tree is not None:
            if cand is None:
                cand = candidates(qg[:, 0], NEIGHBOURS, reach)
            step = max(1, CHUNK // (cand.shape[1] * qg.shape[1]))
            for s in range(0, len(qg), step):
                g = slice(s, s + step)
                best, wid, ok = _plane_distance(qg[g], cand[g], pm, pn, uid, reach, cover)
                sd[g] = np.where(ok, np.maximum(best, sd[g] - voxel), sd[g])  # never inside past the footprints' shell
                width[g] = np.where(ok, wid, 1.0)
        if floor is not None:
            under = floor - qg[..., 2]
            width = np.where(under > sd, 1.0, width)
            sd = np.maximum(sd, under)
        return sd.reshape(shape), width.reshape(shape)

    distance.candidates = (lambda q: candidates(q, CANDIDATES, reach + h)) if tree is not None else None
    return distance


def _phi_distance(phi: np.ndarray, vlo: np.ndarray, voxel: float, q: np.ndarray) -> np.ndarray:
    """``-phi * voxel`` (metres, positive outside) at the points ``q`` (shape (k, 3)); ``inf`` where ``phi`` is at its
    floor ``-HALF_SHELL`` (three voxels or more from the inside) or off its grid: no plane makes those inside, nor
    gives them a share (a fill spacing many voxels wide gave the sub-cells there up to half of theirs: a sparse donut
    at n_grid 8 was filled to 5 times its volume, 12 cm past its faces)."""
    c = (q - vlo) / voxel - 0.5
    off = ((c < 0) | (c > np.array(phi.shape) - 1)).any(axis=1)
    raw = sample_phi(phi, vlo, voxel, q)
    return np.where(off | (raw <= -HALF_SHELL), np.inf, -raw * voxel)


#: Elements of the largest arrays one step of :func:`surface_distance` makes (bounded memory: 8 bytes each, about
#: twenty of them live).
CHUNK = 2_000_000


def _plane_distance(q: np.ndarray, cand: np.ndarray, pm: np.ndarray, pn: np.ndarray, uid: np.ndarray, reach: float,
                    cover: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The planes' part of :func:`surface_distance` for groups of points ``q`` (shape (k, s, 3), metres) each looking
    among its candidate planes ``cand`` (shape (k, c); ``len(uid) - 1``: no plane) of points ``pm`` and normals
    ``pn`` (``uid``: one id for the planes through one point).

    Each point's :data:`NEIGHBOURS` nearest candidates within ``reach`` are its neighbours. Of the pairs of planes
    (:func:`_pairs`) a point needs its nearest plane's row with the group's candidates, masked by its own
    neighbours (the same as measuring each point's neighbours among themselves); a row is measured once for the
    points of a group that share their nearest plane (a cell's 27 sub-cells have a few), instead of ``NEIGHBOURS^2``
    pairs per point; the same for the pieces of the planes a point meets at a concave edge.
    Offsets are taken from the group's mean point (its cell's centre), in products of shape (k, s, c).

    Returns
    -------
    best, width : ndarray, shape (k, s)
        Signed distance (metres, positive outside) and ``|n|_1`` of the nearest plane.
    ok : ndarray, shape (k, s), bool
        A plane lies within ``reach`` (elsewhere the two above are meaningless).
    """
    ref = q.mean(axis=1, keepdims=True)
    ql, m, n = q - ref, pm[cand] - ref, pn[cand]                  # (k, s, 3), (k, c, 3), (k, c, 3)
    qm = np.matmul(ql, np.swapaxes(m, 1, 2))                      # (k, s, c)
    mm = np.einsum("kcj,kcj->kc", m, m)
    d2 = np.maximum(np.einsum("ksj,ksj->ks", ql, ql)[:, :, None] + mm[:, None, :] - 2.0 * qm, 0.0)
    d2 = np.where((cand < len(uid) - 1)[:, None, :], d2, np.inf)
    order = np.argsort(d2, axis=2)[:, :, :NEIGHBOURS]
    near = np.zeros(d2.shape, bool)
    np.put_along_axis(near, order, True, axis=2)
    near &= d2 <= reach ** 2
    a0 = order[:, :, 0]                                          # each point's nearest plane (candidate index)
    g = np.arange(len(q))[:, None]
    ok = near[g, np.arange(q.shape[1])[None, :], a0]
    plane = np.matmul(ql, np.swapaxes(n, 1, 2)) - np.einsum("kcj,kcj->kc", n, m)[:, None, :]
    rows = np.full(cand.shape, -1)                                # the candidates that are some point's nearest,
    rows[g, a0] = 1                                               # one row of the pairs each
    rk, ra = np.nonzero(rows > 0)
    rows[rk, ra] = np.arange(len(rk))
    e0, c0, dm2, kap = (t[rows[g, a0], 0] for t in _pairs(m[rk], n[rk], uid[cand[rk]], ra[:, None]))
    e0, c0 = e0 & near, c0 & near
    smooth = near & ~e0 & (dm2 > 0)
    kappa = np.where(smooth, kap, 0.0).sum(axis=2) / np.maximum(smooth.sum(axis=2), 1)
    p0 = np.take_along_axis(plane, a0[..., None], axis=2)[..., 0]
    lat = np.sqrt(np.maximum(np.where(ok, np.take_along_axis(d2, a0[..., None], axis=2)[..., 0], 0.0) - p0 ** 2, 0.0))
    best = p0 + np.clip(0.5 * kappa * lat ** 2, -0.5 * lat, 0.5 * lat)
    # each plane with those it makes a convex edge with is a convex piece (the intersection of the half-spaces); the
    # nearest's piece joins those it meets at a concave edge (the union) where the point's foot on that plane lies on
    # its splat's part of the surface (a face's plane goes on past the face: a dog-bone's gauge face under its grip's
    # shoulder)
    best = np.maximum(best, np.where(c0, plane, -np.inf).max(axis=2))
    concave = e0 & ~c0 & (np.where(near, d2, 0.0) - plane ** 2 <= cover ** 2)
    kk, ss, bb = np.nonzero(concave)                              # each point's planes at a concave edge, and
    c = cand.shape[1]                                             # their rows of the pairs, once for a group
    rk, inv = np.unique(kk * c + bb, return_inverse=True)
    joins = _pairs(m[rk // c], n[rk // c], uid[cand[rk // c]], (rk % c)[:, None])[1][inv.ravel(), 0] & near[kk, ss]
    piece = np.maximum(plane[kk, ss, bb], np.where(joins, plane[kk, ss], -np.inf).max(axis=1, initial=-np.inf))
    np.minimum.at(best, (kk, ss), piece)
    return best, np.abs(n[g, a0]).sum(axis=2), ok


def _pairs(m: np.ndarray, n: np.ndarray, uid: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, ...]:
    """Between the planes ``a`` (shape (k, s), candidate indices) and each of a group's candidate planes (points
    ``m``, normals ``n``, shape (k, c, 3); ``uid`` (k, c) the same where the points are): whether they meet at an edge
    (their normals turn by more than ``acos(EDGE_COS)``), whether it is convex (each behind the other), the squared
    distance of their points (0 where they are one point) and the curvature ``(n_c - n_a).(m_c - m_a) / |m_c -
    m_a|^2`` (0 there). Four arrays of shape (k, s, c): ``a`` each point's nearest plane (its row of the pairs), or
    every candidate (``s = c``: the whole table)."""
    g = np.arange(len(m))[:, None]
    na, ma = n[g, a], m[g, a]                                      # (k, s, 3)
    mt, nt = np.swapaxes(m, 1, 2), np.swapaxes(n, 1, 2)
    ahead = np.matmul(na, mt) - np.einsum("ksj,ksj->ks", na, ma)[:, :, None]      # n_a . (m_c - m_a)
    behind = np.matmul(ma, nt) - np.einsum("kcj,kcj->kc", n, m)[:, None, :]       # n_c . (m_a - m_c)
    mutual = ahead + behind                                       # -(n_c - n_a) . (m_c - m_a)
    one = uid[g, a][:, :, None] == uid[:, None, :]
    mm = np.einsum("kcj,kcj->kc", m, m)
    d2 = np.where(one, 0.0, np.maximum(np.take_along_axis(mm, a, axis=1)[:, :, None] + mm[:, None, :]
                                       - 2.0 * np.matmul(ma, mt), 1e-300))
    edge = np.matmul(na, nt) < EDGE_COS
    convex = edge & ~one & (mutual < 0)
    return edge, convex, d2, np.where(one, 0.0, -mutual / np.where(one, 1.0, d2))


def cell_fractions(seed: np.ndarray, deep: np.ndarray, phi: np.ndarray, vlo: np.ndarray, voxel: float,
                   splats: np.ndarray, lo: np.ndarray, h: float,
                   floor: float | None = None) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None]:
    """The fill points of spacing ``h``: the cells that hold part of the solid, the volume each point stands for and
    where (issue 66: a body's mass, and its fill inside its faces).

    ``deep`` cells (``phi`` at their centre at least :func:`band` voxels) are whole. The cells within one cell of the
    ``seed`` (``phi`` above ``-NEAR_PHI`` at their centre) are measured against :func:`surface_distance`: a cell the
    surface crosses is sampled at :data:`SUB` ^3 sub-cells, each inside by the share of it under that distance (a
    slab across the sub-cell), and its point goes to the centre of its inside part. Cells under :data:`MIN_SHARE` of
    a cell are left out. Under a ``floor`` (metres, world z) nothing is inside.

    The planes must describe the surface the splats show: where more than :data:`HELD_OUT` of the splats' means
    lie more than a voxel outside it (:func:`outside_share`), they do not, and the caller keeps whole cells by
    ``phi`` (three Nones are returned).

    Returns
    -------
    cells : ndarray, shape (k, 3), int64
        Fill-grid indices, in the grid's ravel order (the three are None where the planes do not hold the splats).
    share : ndarray, shape (k,)
        Share of each cell inside the solid, in ``[MIN_SHARE, 1]``.
    centre : ndarray, shape (k, 3)
        Centre of each cell's inside part, metres.
    """
    shape = seed.shape
    deep = deep.copy()
    if floor is not None:
        bottom = lo[2] + np.arange(shape[2]) * h
        deep &= (bottom >= floor)[None, None, :]
    band_cells = ndimage.binary_dilation(seed, _CUBE) & ~deep
    # round 77: the deep cells beside that band are measured too (``phi`` is deep past a concave edge: the cup's
    # cavity corner held whole cells 0.46 spacings past its inner wall at n_grid 64)
    band_cells |= deep & ndimage.binary_dilation(band_cells, _CUBE)
    deep &= ~band_cells
    near = np.argwhere(band_cells)
    distance = surface_distance(phi, vlo, voxel, splats, h, floor)
    if outside_share(distance, splats, voxel, floor) > HELD_OUT:
        return None, None, None
    centres = cell_centres(near, lo, h)
    sd, _ = distance(centres)
    share = np.where(sd <= 0, 1.0, 0.0)
    # a centre past phi's floor (inf) may still have sub-cells within reach of the surface: up to 1/2 - HALF_SHELL
    # voxels / h of the cell is inside (a dog-bone's gauge at n_grid 24 lost 3.2 % of its section so, round 34)
    cut = (np.abs(sd) < h) | (np.isposinf(sd) & SAMPLE_PAST_FLOOR)
    centre = centres.copy()
    if cut.any():
        u = (np.arange(SUB) + 0.5) / SUB - 0.5
        offs = np.stack(np.meshgrid(u, u, u, indexing="ij"), -1).reshape(-1, 3) * h
        idx = np.flatnonzero(cut)
        step = CHUNK // (len(offs) * CANDIDATES)          # the cells one step of the distance takes
        for s in range(0, len(idx), step):
            ii = idx[s:s + step]
            q = centres[ii, None, :] + offs[None]                 # (cells, SUB^3, 3)
            cand = None if distance.candidates is None else distance.candidates(centres[ii])
            d, w = distance(q, cand)
            t = w * h / SUB                                     # each sub-cell's extent along its plane's normal
            f = np.clip(0.5 - d / t, 0.0, 1.0)
            tot = f.sum(axis=1)
            share[ii] = tot / f.shape[1]
            q = q - inside_shift(d, t, f)[..., None] * surface_normal(d, h / SUB)
            cen = np.einsum("ik,ikj->ij", f, q) / np.maximum(tot, 1e-300)[:, None]
            centre[ii] = np.where(tot[:, None] > 0, cen, centres[ii])
    keep = share >= MIN_SHARE
    dcells = np.argwhere(deep)
    cells = np.concatenate([dcells, near[keep]])
    share = np.concatenate([np.ones(len(dcells)), share[keep]])
    centre = np.concatenate([cell_centres(dcells, lo, h), centre[keep]])
    order = np.argsort(np.ravel_multi_index(cells.T, shape), kind="stable")
    return cells[order], share[order], centre[order]


def surface_normal(d: np.ndarray, step: float) -> np.ndarray:
    """Round 77: the outward normal of the surface at each sub-cell (shape (k, SUB^3, 3), unit; 0 where it cannot be
    told), the gradient of the signed distance ``d`` (shape (k, SUB^3), metres, positive outside, the sub-cells in
    :func:`cell_fractions`' order, ``step`` metres apart) by differences across the cell's sub-cells (central
    inside, one-sided at its faces; ``inf`` past ``phi``'s floor gives no normal)."""
    dd = d.reshape(len(d), SUB, SUB, SUB)
    with np.errstate(invalid="ignore"):
        g = np.stack(np.gradient(dd, step, axis=(1, 2, 3)), -1).reshape(len(d), -1, 3)
    g = np.where(np.isfinite(g).all(axis=-1, keepdims=True), g, 0.0)
    norm = np.linalg.norm(g, axis=-1, keepdims=True)
    return np.where(norm > 0, g / np.maximum(norm, 1e-300), 0.0)


def inside_shift(d: np.ndarray, t: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Round 77: how far (metres, shape of ``d``) the centre of a sub-cell's inside part lies behind the sub-cell's
    centre along the surface's normal, for :func:`cell_fractions`' slab rule (inside share ``f = 1/2 - d / t``, ``t``
    its extent along the normal): the inside part of a partly cut sub-cell spans ``-t/2`` to ``-d``, so its centre is
    ``(t/2 + d) / 2`` behind; 0 for a whole or an empty one. Before round 77 the sub-cell's centre itself was taken,
    up to ``t / 2`` outside the surface: a ball's fill points reached 0.28 spacings out, the cup's inner corner 0.54."""
    part = (f > 0.0) & (f < 1.0)
    return np.where(part, 0.5 * (0.5 * t + np.where(part, d, 0.0)), 0.0)


#: Largest share of the splats' means more than a voxel outside the planes' surface for the planes to decide the
#: cells at the faces (:func:`cell_fractions`). Measured: GaMeS splats of meshes 0 (spot), trained captures 0 (the
#: donut) and 0.003 (the guitar, its means on the planes' surface to a fifth of a voxel while ``phi`` puts them a
#: voxel inside); the kitchen spinach region 0.46 (19 of its 245 splats are planes: they cut through the rest).
HELD_OUT = 0.05
#: Splats' means :func:`outside_share` measures at most (every ``n // MEANS``-th).
MEANS = 4096


def outside_share(distance: Callable, splats: np.ndarray, voxel: float, floor: float | None = None) -> float:
    """Share of the splats' means (``splats`` shape (m, 3, 3), metres; at most :data:`MEANS` of them, evenly taken;
    those under a ``floor`` left out) that ``distance`` (:func:`surface_distance`) puts more than ``voxel`` outside
    the solid. 0 without splats."""
    means = np.asarray(splats, np.float64)[:, 0]
    if floor is not None:
        means = means[means[:, 2] >= floor]
    means = means[::max(1, len(means) // MEANS)]
    return float(np.mean(distance(means)[0] > voxel)) if len(means) else 0.0


def cell_centres(cells: np.ndarray, lo: np.ndarray, h: float) -> np.ndarray:
    """Centres (metres) of the fill-grid cells ``cells`` (k, 3) of corner ``lo`` and spacing ``h``."""
    return lo + (cells + 0.5) * h
