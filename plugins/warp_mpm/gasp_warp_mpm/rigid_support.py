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
from gasp_core.mpm.rigid_fit import FOOT_BAND, FOOT_SAMPLES
from gasp_core.mpm.rigid_support import HOLLOW_POWER_STEPS, HOLLOW_REACH, HOLLOW_WINDOW, ROUND_DEEP

vec3d = wp.types.vector(3, wp.float64)
vec4d = wp.types.vector(4, wp.float64)
mat33d = wp.types.matrix((3, 3), wp.float64)
FLAT_0 = wp.constant(wp.float64(FLAT_FROM))
FLAT_W = wp.constant(wp.float64(FLAT_TO - FLAT_FROM))
DEEP = wp.constant(wp.float64(ROUND_DEEP))
WINDOW = wp.constant(wp.float64(HOLLOW_WINDOW))
POWER = wp.constant(HOLLOW_POWER_STEPS)
REACH = wp.constant(wp.float64(HOLLOW_REACH))
BAND = wp.constant(wp.float64(FOOT_BAND))
SAMPLES = wp.constant(FOOT_SAMPLES)
STEP = wp.constant(wp.float64(2.0 / FOOT_SAMPLES))


@wp.struct
class Hollow:
    """Round 92 (``gasp_core.mpm.hollow.hollow_data``): the outer points of the bodies that are not round, in their
    rest frames, sorted by cell (``X``; cell ``g``'s ``cstart[g]`` to ``cstart[g + 1]``; a body's cells' origin
    ``corg``, size ``csize`` and ``cdims`` ``[nx, ny, nz, first cell]``), each body's point spacing (m), and a round
    body's radius, half-length (m) and rest axis (zeros: a sphere's); round 93: ``curved``, per table row 1.0 where
    the body reads curved there (``gasp_core.mpm.rigid_support.curved_rows``); round 94: ``side``, per body 1.0 for a
    cylinder whose side takes its foot as a point, 2.0 its foot alone (``gasp_core.mpm.hollow.hollow_data``)."""
    X: wp.array(dtype=vec3d)
    cstart: wp.array(dtype=wp.int32)
    corg: wp.array(dtype=vec3d)
    csize: wp.array(dtype=wp.float64)
    cdims: wp.array(dtype=wp.int32)
    spacing: wp.array(dtype=wp.float64)
    radius: wp.array(dtype=wp.float64)
    half: wp.array(dtype=wp.float64)
    axis: wp.array(dtype=vec3d)
    curved: wp.array(dtype=wp.float64)
    side: wp.array(dtype=wp.float64)


def support_arrays(data, device, nb: int, setup=None) -> tuple:
    """``gasp_core.mpm.rigid_pairs.support_data``'s tables as Warp arrays (vec3d, float64, mat33d, float64 per body),
    ``nd``, the round bodies (float64 per body, round 90), the normal's cone (its cosine, float; round 91) and round
    92's :class:`Hollow` (of ``setup``; empty without it); ``data`` None: no table for any of the ``nb`` bodies
    (every band 0: every contact a face's)."""
    from gasp_core.mpm.hollow import hollow_data
    from gasp_core.mpm.rigid_support import curved_rows
    if data is None:
        nb = max(int(nb), 1)
        data = (np.zeros((nb, 3)), np.ones(nb), np.zeros((nb, 3, 3)), np.zeros(nb), 0, np.zeros(nb), 2.0)
    dirs, h, curv, delta, nd, rnd, cos_cone = data
    nb = len(rnd)
    data = hollow_data(setup, rnd) if setup is not None else {
        "X": np.zeros((1, 3)), "cstart": np.zeros(nb + 1, np.int32), "corg": np.zeros((nb, 3)), "csize": np.ones(nb),
        "cdims": np.ravel([[1, 1, 1, b] for b in range(nb)]).astype(np.int32), "spacing": np.zeros(nb),
        "radius": np.zeros(nb), "half": np.zeros(nb), "axis": np.zeros((nb, 3)), "side": np.zeros(nb)}
    hol = Hollow()
    for name in ("X", "corg", "axis"):
        setattr(hol, name, wp.array(data[name], dtype=vec3d, device=device))
    for name in ("csize", "spacing", "radius", "half", "side"):
        setattr(hol, name, wp.array(data[name], dtype=wp.float64, device=device))
    for name in ("cstart", "cdims"):
        setattr(hol, name, wp.array(data[name], dtype=wp.int32, device=device))
    hol.curved = wp.array(curved_rows(h, curv), dtype=wp.float64, device=device)
    return (wp.array(dirs, dtype=vec3d, device=device), wp.array(h, dtype=wp.float64, device=device),
            wp.array(curv, dtype=mat33d, device=device), wp.array(delta, dtype=wp.float64, device=device), int(nd),
            wp.array(rnd, dtype=wp.float64, device=device), float(cos_cone), hol)


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
def flat_at(h: wp.array(dtype=wp.float64), curv: wp.array(dtype=mat33d), delta: wp.array(dtype=wp.float64), b: int,
            row: int, R: mat33d, t_world: vec3d):
    # gasp_core.mpm.rigid_support.body_flatness at body b's table row: its surface's curvature kappa = 1 / rho along
    # the slip t against the support h (rigid_support.flatness)
    f = wp.float64(1.0)
    if delta[b] > wp.float64(0.0):
        tl = wp.transpose(R) * t_world
        kh = wp.dot(tl, curv[row] * tl) * h[row]
        if kh * (FLAT_0 + FLAT_W) > wp.float64(1.0):
            f = wp.min(wp.max((wp.float64(1.0) / kh - FLAT_0) / FLAT_W, wp.float64(0.0)), wp.float64(1.0))
    return f


@wp.func
def roll_flat_at(h: wp.array(dtype=wp.float64), curv: wp.array(dtype=mat33d), delta: wp.array(dtype=wp.float64),
                 a: int, b: int, row_a: int, row_b: int, RA: mat33d, RB: mat33d, n: vec3d, ut: vec3d, lt: wp.float64,
                 dw: vec3d):
    # gasp_core.mpm.rigid_pairs._roll_flatness at the bodies' table rows towards each other: the pair's flatness
    # along the slip ut, or without slip along the bodies' relative rolling (dw x n); 1 with neither
    f = wp.float64(1.0)
    roll = wp.cross(dw - wp.dot(dw, n) * n, n)
    lr = wp.length(roll)
    if lt > wp.float64(0.0) or lr > wp.float64(0.0):
        t = roll / wp.max(lr, wp.float64(1.0e-300))
        if lt > wp.float64(0.0):
            t = ut / lt
        f = wp.min(flat_at(h, curv, delta, a, row_a, RA, t), flat_at(h, curv, delta, b, row_b, RB, t))
    return f


@wp.func
def roll_flat(dirs: wp.array(dtype=vec3d), h: wp.array(dtype=wp.float64), curv: wp.array(dtype=mat33d),
              delta: wp.array(dtype=wp.float64), nd: int, a: int, b: int, RA: mat33d, RB: mat33d, n: vec3d,
              ut: vec3d, lt: wp.float64, dw: vec3d):
    # roll_flat_at with the rows looked up (body a towards n, b towards -n)
    return roll_flat_at(h, curv, delta, a, b, body_row(dirs, nd, a, RA, n), body_row(dirs, nd, b, RB, -n), RA, RB,
                        n, ut, lt, dw)


@wp.func
def roll_point_at(h: wp.array(dtype=wp.float64), rnd: wp.array(dtype=wp.float64), a: int, b: int, row_a: int,
                  row_b: int, cA: vec3d, cB: vec3d, n: vec3d, x_c: vec3d):
    # gasp_core.mpm.rigid_support.contact_plane: the contact point moved along n onto where the surfaces meet;
    # round 90: onto a round body's own surface (rnd 1, its exact table), midway where both or neither are round
    wa = wp.float64(0.5) + wp.float64(0.5) * (wp.min(rnd[a], wp.float64(1.0)) - wp.min(rnd[b], wp.float64(1.0)))
    plane = wa * (wp.dot(cA, n) + h[row_a]) + (wp.float64(1.0) - wa) * (wp.dot(cB, n) - h[row_b])
    return x_c + (plane - wp.dot(x_c, n)) * n


@wp.func
def roll_point(dirs: wp.array(dtype=vec3d), h: wp.array(dtype=wp.float64), rnd: wp.array(dtype=wp.float64), nd: int,
               a: int, b: int, RA: mat33d, RB: mat33d, cA: vec3d, cB: vec3d, n: vec3d, x_c: vec3d):
    # roll_point_at with the rows looked up
    return roll_point_at(h, rnd, a, b, body_row(dirs, nd, a, RA, n), body_row(dirs, nd, b, RB, -n), cA, cB, n, x_c)


@wp.func
def axis_gap(Y: vec3d, e: vec3d, h: wp.float64):
    # the distance of Y (from a round body's centre) to its axis's segment +-h e (a sphere: e 0, |Y|)
    return wp.length(Y - wp.clamp(wp.dot(Y, e), -h, h) * e)


@wp.func
def cell_span(lo: wp.float64, hi: wp.float64, c: wp.float64, n: int):
    # the cells (first, last) of a body's n along one axis that [lo, hi] (m, from the cells' origin) meets
    return wp.max(int(wp.floor(lo / c)), 0), wp.min(int(wp.floor(hi / c)), n - 1)


@wp.func
def hollow_sums(hol: Hollow, f: int, q: vec3d, e: vec3d, h: wp.float64, reach: wp.float64, d_min: wp.float64,
                win: wp.float64):
    # one pass over body f's outer points in the cells within reach of round body's segment q +- h e (f's frame):
    # with win 0 the least distance (d_min's), else the plane fit's weighted sums (W, sum w Y, sum w Y Y^T) and
    # round 94's along the axis (sum w t^k, k 1-4, and sum w t^k Y, k 1-2, t = Y . e / h; h 0: t 0)
    ext = vec3d(wp.abs(e[0]), wp.abs(e[1]), wp.abs(e[2])) * h + vec3d(reach, reach, reach)
    o = q - hol.corg[f]
    c = hol.csize[f]
    nx = hol.cdims[4 * f]
    ny = hol.cdims[4 * f + 1]
    nz = hol.cdims[4 * f + 2]
    first = hol.cdims[4 * f + 3]
    i0, i1 = cell_span(o[0] - ext[0], o[0] + ext[0], c, nx)
    j0, j1 = cell_span(o[1] - ext[1], o[1] + ext[1], c, ny)
    k0, k1 = cell_span(o[2] - ext[2], o[2] + ext[2], c, nz)
    dm = d_min
    W = wp.float64(0.0)
    y = vec3d(wp.float64(0.0))
    S = mat33d(wp.float64(0.0))
    T = vec4d(wp.float64(0.0))
    Y1 = vec3d(wp.float64(0.0))
    Y2 = vec3d(wp.float64(0.0))
    for i in range(i0, i1 + 1):
        for j in range(j0, j1 + 1):
            for k in range(k0, k1 + 1):
                g = first + (i * ny + j) * nz + k
                for p in range(hol.cstart[g], hol.cstart[g + 1]):
                    Y = hol.X[p] - q
                    d = axis_gap(Y, e, h)
                    if d <= reach:
                        if win == wp.float64(0.0):
                            dm = wp.min(dm, d)
                        else:
                            t = wp.float64(1.0) - (d - d_min) / win
                            if t > wp.float64(0.0):
                                W = W + t * t
                                y = y + (t * t) * Y
                                S = S + (t * t) * wp.outer(Y, Y)
                                if h > wp.float64(0.0):
                                    u = wp.dot(Y, e) / h
                                    T = T + (t * t) * vec4d(u, u * u, u * u * u, u * u * u * u)
                                    Y1 = Y1 + (t * t * u) * Y
                                    Y2 = Y2 + (t * t * u * u) * Y
    return dm, W, y, S, T, Y1, Y2


@wp.func
def side_foot(W: wp.float64, Y0: vec3d, T: vec4d, Y1: vec3d, Y2: vec3d, m: vec3d, me: wp.float64, h: wp.float64,
              band: wp.float64):
    # round 94 (gasp_core.mpm.rigid_fit.side_foot): the parabola of the patch's heights z = Y . m in u = t / h fitted
    # from the sums (normal equations), the side's gap along the segment read at SAMPLES points, the foot (m along
    # the axis) the mean of t weighted by max(band - (gap - least gap), 0); 0 where the fit is singular
    A = mat33d(wp.float64(1.0), T[0] / W, T[1] / W, T[0] / W, T[1] / W, T[2] / W, T[1] / W, T[2] / W, T[3] / W)
    foot = wp.float64(0.0)
    if wp.determinant(A) > wp.float64(1.0e-9):
        c = wp.inverse(A) * (vec3d(wp.dot(m, Y0), wp.dot(m, Y1), wp.dot(m, Y2)) / W)
        least = wp.float64(1.0e30)
        for k in range(SAMPLES):
            u = wp.float64(-1.0) + (wp.float64(k) + wp.float64(0.5)) * STEP
            least = wp.min(least, u * h * me - (c[1] * u + c[2] * u * u))
        P = wp.float64(0.0)
        Pu = wp.float64(0.0)
        for j in range(SAMPLES):
            u = wp.float64(-1.0) + (wp.float64(j) + wp.float64(0.5)) * STEP
            p = wp.max(band - (u * h * me - (c[1] * u + c[2] * u * u) - least), wp.float64(0.0))
            P = P + p
            Pu = Pu + p * u
        foot = h * Pu / P
    return foot


@wp.func
def hollow_normal(hol: Hollow, f: int, r: int, Rf: mat33d, Rr: mat33d, cf: vec3d, cr: vec3d, fn: vec3d):
    # round 92 (gasp_core.mpm.rigid_support.hollow_normal): the normal out of body f towards round body r's centre cr
    # (a cylinder's axis), the least spread of f's outer points within d_min + WINDOW s of it, of those within its
    # radius + REACH s, weighted (1 - (d - d_min) / (WINDOW s))^2 (power steps of tr(C) I - C from the nodes' fn,
    # turned towards cr); fn where there are none. Only the cells within the reach are read (hollow_sums). Round 94
    # (gasp_core.mpm.rigid_fit.hollow_contact): with it, a cylinder's foot (m along its axis from cr) and hol.side
    # where its side touches (else 0 and 0.0), its normal then across its axis.
    q = wp.transpose(Rf) * (cr - cf)
    e = wp.transpose(Rf) * (Rr * hol.axis[r])
    h = hol.half[r]
    reach = hol.radius[r] + REACH * hol.spacing[f]
    d_min, W0, y0, S0, T0, Y10, Y20 = hollow_sums(hol, f, q, e, h, reach, wp.float64(1.0e30), wp.float64(0.0))
    out = fn
    foot = wp.float64(0.0)
    side = wp.float64(0.0)
    if d_min < wp.float64(1.0e29):
        dm, W, Ys, S, T, Y1, Y2 = hollow_sums(hol, f, q, e, h, reach, d_min, WINDOW * hol.spacing[f])
        y = Ys / W
        C = S / W - wp.outer(y, y)
        M = (C[0, 0] + C[1, 1] + C[2, 2]) * wp.identity(n=3, dtype=wp.float64) - C
        m = wp.transpose(Rf) * fn
        for _k in range(POWER):
            m = wp.normalize(M * m)
        if wp.dot(m, y) > wp.float64(0.0):
            m = -m
        if hol.side[r] > wp.float64(0.0) and wp.abs(wp.dot(y, e)) < h:   # round 94: a cylinder's side
            m = wp.normalize(m - wp.dot(m, e) * e)
            foot = side_foot(W, Ys, T, Y1, Y2, m, wp.dot(m, e), h, BAND * hol.spacing[f])
            side = hol.side[r]
        out = Rf * m
    return out, foot, side


@wp.func
def round_normal(dirs: wp.array(dtype=vec3d), h: wp.array(dtype=wp.float64), rnd: wp.array(dtype=wp.float64), nd: int,
                 cos_cone: wp.float64, a: int, b: int, RA: mat33d, RB: mat33d, cA: vec3d, cB: vec3d, n: vec3d,
                 hol: Hollow):
    # round 91 (gasp_core.mpm.rigid_support.pair_normal): two spheres (rnd 1) take their line of centres; a pair of
    # one round body takes as its normal (from A into B) the other body's table direction within the cone of the
    # nodes' n that leaves the two supports farthest apart (the separating axis, rigid_support.round_normal); n
    # otherwise, with the switch off (cos_cone > 1), or where no direction lies in the cone; round 92: too deep in the
    # hull for a contact (a hollow), a round body takes hollow_normal; round 93: so does one whose row reads the other
    # body curved there (hol.curved, rigid_support.curved_rows), started from the row; round 94: with it, a
    # cylinder's foot on the fit and its side flag (hollow_normal; 0 and 0 otherwise)
    out = n
    foot = wp.float64(0.0)
    side = wp.float64(0.0)
    if cos_cone <= wp.float64(1.0) and rnd[a] == wp.float64(1.0) and rnd[b] == wp.float64(1.0):
        out = wp.normalize(cB - cA)
    elif nd > 0 and (rnd[a] > wp.float64(0.0)) != (rnd[b] > wp.float64(0.0)):
        f = a
        r = b
        Rf = RA
        Rr = RB
        sg = wp.float64(1.0)
        if rnd[a] > wp.float64(0.0):
            f = b
            r = a
            Rf = RB
            Rr = RA
            sg = wp.float64(-1.0)
        fn = sg * n   # out of f towards the round body
        dc = sg * (cB - cA)
        top = wp.float64(-1.0e30)
        hr = wp.float64(0.0)
        best = int(0)
        for i in range(nd):
            e = Rf * dirs[f * nd + i]
            if wp.dot(e, fn) >= cos_cone:
                h_r = h[body_row(dirs, nd, r, Rr, -e)]
                gap = wp.dot(e, dc) - h[f * nd + i] - h_r
                if gap > top:
                    top = gap
                    hr = h_r
                    out = sg * e
                    best = f * nd + i
        cf = cA
        cr = cB
        if sg < wp.float64(0.0):
            cf = cB
            cr = cA
        if top < -DEEP * hr:   # deeper in the other body's hull than a contact can be: a concave part, the nodes' n
            out = n
            if cos_cone <= wp.float64(1.0) and top > wp.float64(-1.0e29):
                fit, foot, side = hollow_normal(hol, f, r, Rf, Rr, cf, cr, fn)
                out = sg * fit
        elif top > wp.float64(-1.0e29) and hol.curved[best] > wp.float64(0.0):   # round 93: a curved face, the fit
            fit, foot, side = hollow_normal(hol, f, r, Rf, Rr, cf, cr, sg * out)
            out = sg * fit
    return out, foot, side


@wp.func
def pair_gap(dirs: wp.array(dtype=vec3d), h: wp.array(dtype=wp.float64), rnd: wp.array(dtype=wp.float64), nd: int,
             cos_cone: wp.float64, a: int, b: int, RA: mat33d, RB: mat33d, cA: vec3d, cB: vec3d, n: vec3d,
             hol: Hollow):
    # round 91 (gasp_core.mpm.rigid_support.pair_gap): two spheres, or a sphere and a body that is not round, the gap
    # between the two supports along n (m, < 0 overlapping); else -1e30 (none known: the law as before, every approach
    # of touching nodes removed); round 93: none known where the body that is not round reads curved at its row
    g = wp.float64(-1.0e30)
    ka = rnd[a]
    kb = rnd[b]
    one = (ka == wp.float64(1.0) and kb == wp.float64(0.0)) or (ka == wp.float64(0.0) and kb == wp.float64(1.0))
    if cos_cone <= wp.float64(1.0) and nd > 0 and ((ka == wp.float64(1.0) and kb == wp.float64(1.0)) or one):
        row_a = body_row(dirs, nd, a, RA, n)
        row_b = body_row(dirs, nd, b, RB, -n)
        curved = (ka == wp.float64(0.0) and hol.curved[row_a] > wp.float64(0.0)) or (
            kb == wp.float64(0.0) and hol.curved[row_b] > wp.float64(0.0))
        if not curved:
            g = wp.dot(n, cB - cA) - h[row_a] - h[row_b]
    return g


@wp.func
def allowed_approach(gap: wp.float64, un: wp.float64, dt: wp.float64):
    # round 91's speculative contact (gasp_core.mpm.rigid_friction.allowed_approach): the approach speed the pair may
    # keep this substep so that it closes the gap its centres had at the step's start, max(gap / dt + un, 0); 0 where
    # no gap is known
    s = wp.float64(0.0)
    if gap > wp.float64(-1.0e29):
        s = wp.max(gap / dt + un, wp.float64(0.0))
    return s


@wp.func
def tip(f: wp.float64, inv_inertia: mat33d, arm: vec3d, n: vec3d):
    # (1 - f) of the tipping part (across n) of the moment arm through a body's inverse inertia (round 65's rolling)
    return (wp.float64(1.0) - f) * (inv_inertia * (arm - wp.dot(arm, n) * n))


@wp.func
def body_inv(inertia0: mat33d, R: mat33d, M: wp.float64, half: wp.float64):
    # the inverse of a body's inertia at its pose with APIC's M dx^2 / 2 (half = dx^2 / 2)
    return wp.inverse(R * inertia0 * wp.transpose(R) + half * M * wp.identity(3, wp.float64))


@wp.func
def slip_at(x_c: vec3d, VA: vec3d, wA: vec3d, cA: vec3d, VB: vec3d, wB: vec3d, cB: vec3d, n: vec3d):
    # the arms from the centres to x_c and the tangential velocity of A's point x_c relative to B's
    rA = x_c - cA
    rB = x_c - cB
    u = VA + wp.cross(wA, rA) - VB - wp.cross(wB, rB)
    return rA, rB, u - wp.dot(u, n) * n
