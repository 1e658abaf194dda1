"""The rigid bodies' support tables on the device (round 65, issue 67 items 2 and 4; the NumPy reference and the
design are :mod:`gasp_core.mpm.rigid_support`, taichi_mpm's ``rigid_support.py`` the same): ``support_arrays`` builds
them once (NumPy), ``body_flat`` reads one body's flatness towards a world direction along the slip in a kernel,
``body_row`` the row of its nearest table direction (its support ``h``).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the functions below
as type objects.
"""
import numpy as np
import warp as wp

from gasp_core.mpm.rigid_friction import FLAT_FROM, FLAT_TO

vec3d = wp.types.vector(3, wp.float64)
mat33d = wp.types.matrix((3, 3), wp.float64)
FLAT_0 = wp.constant(wp.float64(FLAT_FROM))
FLAT_W = wp.constant(wp.float64(FLAT_TO - FLAT_FROM))


def support_arrays(setup, X0: np.ndarray, rigid: np.ndarray, device) -> tuple:
    """``(dirs, h, curv, delta, nd)``: every rigid body's ``gasp_core.mpm.rigid_support.support_table`` of its points
    with mass (``X0`` (n, 3) m, setup order; spacing ``p_vol ** (1/3)``), body ``b``'s rows ``b * nd`` to
    ``(b + 1) * nd``, as Warp arrays (vec3d, float64, mat33d, float64 per body; ``delta`` 0: no table, a face)."""
    from gasp_core.mpm.rigid_support import support_table, table_directions
    n = len(X0)
    body = np.broadcast_to(np.asarray(setup.body_id), (n,))
    vol = np.broadcast_to(np.asarray(setup.p_vol, np.float64), (n,))
    mass = np.broadcast_to(np.asarray(setup.p_mass, np.float64), (n,))
    nb, nd = len(rigid), len(table_directions(np.zeros((1, 3))))
    dirs, h, curv, delta = np.zeros((nb * nd, 3)), np.ones(nb * nd), np.zeros((nb * nd, 3, 3)), np.zeros(nb)
    for b in np.flatnonzero(rigid):
        sel = (body == b) & (mass > 0.0)
        if not sel.any():
            continue
        D, H, C, delta[b] = support_table(X0[sel], float(np.mean(vol[sel])) ** (1.0 / 3.0))
        rows = slice(b * nd, (b + 1) * nd)
        dirs[rows], h[rows] = D, H
        curv[rows] = C[:, [0, 1, 2, 1, 3, 4, 2, 4, 5]].reshape(-1, 3, 3)
    return (wp.array(dirs, dtype=vec3d, device=device), wp.array(h, dtype=wp.float64, device=device),
            wp.array(curv, dtype=mat33d, device=device), wp.array(delta, dtype=wp.float64, device=device), nd)


@wp.func
def body_row(dirs: wp.array(dtype=vec3d), nd: int, b: int, R: mat33d, d_world: vec3d):
    # the row of body b's table direction nearest to d (gasp_core.mpm.rigid_support._row)
    dl = wp.transpose(R) * d_world
    best = int(0)
    top = wp.float64(-2.0)
    for i in range(nd):
        c = wp.dot(dirs[b * nd + i], dl)
        if c > top:
            top = c
            best = b * nd + i
    return best


@wp.func
def body_flat(dirs: wp.array(dtype=vec3d), h: wp.array(dtype=wp.float64), curv: wp.array(dtype=mat33d),
              delta: wp.array(dtype=wp.float64), nd: int, b: int, R: mat33d, d_world: vec3d, t_world: vec3d):
    # gasp_core.mpm.rigid_support.body_flatness: the nearest table direction to d (in the body's frame), its
    # surface's curvature kappa = 1 / rho along the slip t against the support h (rigid_support.flatness)
    f = wp.float64(1.0)
    if delta[b] > wp.float64(0.0):
        best = body_row(dirs, nd, b, R, d_world)
        tl = wp.transpose(R) * t_world
        kh = wp.dot(tl, curv[best] * tl) * h[best]
        if kh * (FLAT_0 + FLAT_W) > wp.float64(1.0):
            f = wp.min(wp.max((wp.float64(1.0) / kh - FLAT_0) / FLAT_W, wp.float64(0.0)), wp.float64(1.0))
    return f
