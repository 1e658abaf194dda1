"""The contact's balance on the gpu schedule (:mod:`gasp_warp_mpm.schedule`): the cpu schedule's sums with no f64
atomics on a body's row and no loop over nodes on one thread.

- per-row sums (:func:`build_row_sums`): ``moment_blocks`` (one thread a block of points: the cpu schedule's
  ``contact_moments`` terms summed per body and support into that block's partials), ``friction_blocks`` (one thread
  a block of nodes: ``balance_node``'s terms of the nodes the grid update marked, per support), ``fold_rows`` (one
  thread per (row, column): the blocks' partials in block order; sums, or the box's min and max);
- the fix (:func:`build_fix`): ``fix_supports`` (one thread a support: ``balance.body_fix``), ``fix_nodes`` (one
  thread a node: the support's ``dv + alpha x (X - x_m)``), ``fix_clear`` (one thread a support).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the closures below
as type objects.
"""
import functools

import warp as wp

from ..balance import FR_COLUMNS, body_fix, f64, v64
from ..contact import build_collider_contact, build_contact_impulse, build_plane_point
from ..forces import build_extras_struct
from ..grid import build_node_fix
from ..precision import MODULE_OPTIONS, build_types
from . import BLOCK, n_blocks

BLK = wp.constant(BLOCK)
#: Columns of the balance's friction sums that the nodes give (``balance.FR_COLUMNS``' first 17; the rest are the
#: per-support results ``fix_supports`` writes).
FR_SUM_COLUMNS = 17
#: ``gasp_core.mpm.contact.JSUMS``: columns 14-19 are the pushed points' box (min, max per axis), the rest sums.
JSUMS_BOX = 14


@wp.func
def acc_second(part: wp.array3d(dtype=f64), blk: int, b: int, col: int, m: f64, r: v64):
    # balance.add_second_moments into a block's partials
    part[blk, b, col] = part[blk, b, col] + m * r[0] * r[0]
    part[blk, b, col + 1] = part[blk, b, col + 1] + m * r[0] * r[1]
    part[blk, b, col + 2] = part[blk, b, col + 2] + m * r[0] * r[2]
    part[blk, b, col + 3] = part[blk, b, col + 3] + m * r[1] * r[1]
    part[blk, b, col + 4] = part[blk, b, col + 4] + m * r[1] * r[2]
    part[blk, b, col + 5] = part[blk, b, col + 5] + m * r[2] * r[2]


@wp.func
def acc_contact(part: wp.array3d(dtype=f64), blk: int, s: int, j: f64, r: v64, n: v64, vc: v64, m: f64):
    # balance.add_contact into a block's partials
    jn = j * n
    mn = wp.cross(r, jn)
    part[blk, s, 0] = part[blk, s, 0] + j
    part[blk, s, 13] = part[blk, s, 13] + m
    for q in range(3):
        part[blk, s, 1 + q] = part[blk, s, 1 + q] + j * r[q]
        part[blk, s, 4 + q] = part[blk, s, 4 + q] + jn[q]
        part[blk, s, 7 + q] = part[blk, s, 7 + q] + mn[q]
        part[blk, s, 10 + q] = part[blk, s, 10 + q] + j * vc[q]
        part[blk, s, 14 + 2 * q] = wp.min(part[blk, s, 14 + 2 * q], r[q])
        part[blk, s, 15 + 2 * q] = wp.max(part[blk, s, 15 + 2 * q], r[q])
    acc_second(part, blk, s, 20, j, r)   # round 86: sum j x x^T, then sum j^2 (gasp_core.mpm.take_back)
    part[blk, s, 26] = part[blk, s, 26] + j * j


@functools.cache
def build_row_sums(Ft):
    """``(moment_blocks, friction_blocks, fold_rows)`` of scalar type ``Ft``: the balance's per-body and per-support
    sums, two-level, no atomics. It is long because the three kernels are closures of the scalar type, built
    together."""
    vec3, vec4, mat33 = build_types(Ft)
    collider_contact = build_collider_contact(Ft)[0]
    contact_impulse, plane_point = build_contact_impulse(Ft), build_plane_point(Ft)
    Extras = build_extras_struct(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def moment_blocks(x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), C: wp.array(dtype=mat33),
                      p_mass: wp.array(dtype=Ft), body: wp.array(dtype=wp.int32), p_contact: wp.array(dtype=vec3),
                      planes: wp.array(dtype=vec3), plane_n: wp.array(dtype=vec3), dt: Ft, dx: Ft, n_pts: int,
                      psums: wp.array3d(dtype=f64), pjs: wp.array3d(dtype=f64), ex: Extras, colc: int, n_sup: int):
        # one thread a block of BLOCK points, in point order: balance.contact_moments' terms into the block's partials
        blk = wp.tid()
        for b in range(psums.shape[1]):
            for q in range(psums.shape[2]):
                psums[blk, b, q] = f64(0.0)
        for s in range(pjs.shape[1]):
            for q in range(pjs.shape[2]):
                pjs[blk, s, q] = f64(0.0)
            for d in range(3):
                pjs[blk, s, 14 + 2 * d] = f64(1.0e30)
                pjs[blk, s, 15 + 2 * d] = f64(-1.0e30)
        for p in range(blk * BLK, wp.min(blk * BLK + BLK, n_pts)):
            b = body[p]
            xp = x[p]
            vp = v[p]
            m = f64(p_mass[p])
            r = v64(f64(xp[0]), f64(xp[1]), f64(xp[2]))
            mv = m * v64(f64(vp[0]), f64(vp[1]), f64(vp[2]))
            Cp = C[p]
            spin = (f64(0.25) * f64(dx) * f64(dx)) * v64(f64(Cp[2, 1] - Cp[1, 2]), f64(Cp[0, 2] - Cp[2, 0]),
                                                         f64(Cp[1, 0] - Cp[0, 1]))
            lr = wp.cross(r, mv) + m * spin
            psums[blk, b, 0] = psums[blk, b, 0] + m
            for q in range(3):
                psums[blk, b, 1 + q] = psums[blk, b, 1 + q] + m * r[q]
                psums[blk, b, 10 + q] = psums[blk, b, 10 + q] + mv[q]
                psums[blk, b, 13 + q] = psums[blk, b, 13 + q] + lr[q]
            acc_second(psums, blk, b, 4, m, r)
            kcs = p_contact[p]
            for q in range(planes.shape[0]):
                jq = Ft(0.0)
                xq, vq, kq, own = plane_point(ex, b, xp, vp, plane_n[q], kcs, p_mass[p])   # round 88: a sphere
                depth = planes[q][0] + kq[2] - wp.dot(plane_n[q], xq)
                if depth > Ft(0.0):
                    jq = contact_impulse(ex, b, ex.plane_e[q], wp.dot(plane_n[q], vq), 0, plane_n[q], depth, kq, dt,
                                         xq, own)
                if jq > Ft(0.0):
                    nq = plane_n[q]
                    acc_contact(pjs, blk, b * n_sup + int(planes[q][2]), f64(jq), v64(f64(xq[0]), f64(xq[1]),
                                f64(xq[2])), v64(f64(nq[0]), f64(nq[1]), f64(nq[2])), v64(f64(0.0)), m)
            if colc != 0:
                base = ex.step[0] * ex.width
                for cc in range(ex.n_col):
                    jq, n, vc, xq = collider_contact(ex, base, cc, xp, vp, kcs, dt, b, 0, p_mass[p])
                    if jq > Ft(0.0):
                        acc_contact(pjs, blk, b * n_sup + 1 + cc, f64(jq), v64(f64(xq[0]), f64(xq[1]), f64(xq[2])),
                                    v64(f64(n[0]), f64(n[1]), f64(n[2])), v64(f64(vc[0]), f64(vc[1]), f64(vc[2])), m)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def friction_blocks(grid_fbody: wp.array(dtype=wp.int32), fr_dv: wp.array(dtype=vec4), fr_fb: wp.array(dtype=Ft),
                        lo: vec3, dx: Ft, n_grid: int, part: wp.array3d(dtype=f64)):
        # one thread a block of BLOCK nodes, in node order: balance_node's terms of the nodes the grid update marked
        # (support row grid_fbody >= 0, and a friction record with mass) into the block's partials
        blk = wp.tid()
        for s in range(part.shape[1]):
            for q in range(part.shape[2]):
                part[blk, s, q] = f64(0.0)
        for node in range(blk * BLK, wp.min(blk * BLK + BLK, grid_fbody.shape[0])):
            s = grid_fbody[node]
            d = fr_dv[node]
            if s >= 0 and d[3] > Ft(0.0):
                i = node / (n_grid * n_grid)
                j = (node / n_grid) % n_grid
                k = node % n_grid
                X = lo + dx * vec3(Ft(i), Ft(j), Ft(k))
                r = v64(f64(X[0]), f64(X[1]), f64(X[2]))
                mm = f64(d[3])
                f = mm * v64(f64(d[0]), f64(d[1]), f64(d[2]))
                tq = wp.cross(r, f)
                for q in range(3):
                    part[blk, s, q] = part[blk, s, q] + f[q]
                    part[blk, s, 4 + q] = part[blk, s, 4 + q] + mm * r[q]
                    part[blk, s, 13 + q] = part[blk, s, 13 + q] + tq[q]
                part[blk, s, 3] = part[blk, s, 3] + mm
                acc_second(part, blk, s, 7, mm, r)
                part[blk, s, 16] = part[blk, s, 16] + f64(fr_fb[node])

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def fold_rows(part: wp.array3d(dtype=f64), out: wp.array2d(dtype=f64), box_from: int):
        # one thread per (row, column) of the partials: the blocks in block order; the six columns from box_from on
        # alternate min and max (the pushed points' box)
        t = wp.tid()
        nc = part.shape[2]
        row = t / nc
        c = t % nc
        if c < box_from or c >= box_from + 6:   # sums; the box's six columns alternate min and max
            s = f64(0.0)
            for blk in range(part.shape[0]):
                s = s + part[blk, row, c]
            out[row, c] = s
        elif (c - box_from) % 2 == 0:
            s = f64(1.0e30)
            for blk in range(part.shape[0]):
                s = wp.min(s, part[blk, row, c])
            out[row, c] = s
        else:
            s = f64(-1.0e30)
            for blk in range(part.shape[0]):
                s = wp.max(s, part[blk, row, c])
            out[row, c] = s

    return moment_blocks, friction_blocks, fold_rows


@functools.cache
def build_fix(Ft):
    """``(fix_supports, fix_nodes, fix_clear)`` of scalar type ``Ft``: the cpu schedule's one-thread
    ``schedule.ordered.contact_fix`` split into a per-support solve, a per-node apply (with its change given to field
    B alone where the grid update kept ``f`` in ``grid_mf``, ``B_BALANCE``) and a per-support clear."""
    vec3, vec4, mat33 = build_types(Ft)
    node_fix = build_node_fix(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def fix_supports(shift: wp.array2d(dtype=f64), jsums: wp.array2d(dtype=f64), fr_sums: wp.array2d(dtype=f64),
                     mass: wp.array(dtype=f64), reach: wp.array(dtype=f64), g_dt: vec3, n_sup: int,
                     rigid: wp.array(dtype=wp.int32)):
        s = wp.tid()   # one thread a support row (per-body bookkeeping)
        b = s / n_sup
        body_fix(s, b, shift, jsums, fr_sums, mass[b], reach[b], v64(f64(g_dt[0]), f64(g_dt[1]), f64(g_dt[2])),
                 rigid[b])

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def fix_nodes(grid_v: wp.array(dtype=vec3), grid_fbody: wp.array(dtype=wp.int32), fr_dv: wp.array(dtype=vec4),
                  fr_sums: wp.array2d(dtype=f64), lo: vec3, dx: Ft, n_grid: int, grid_mf: wp.array(dtype=Ft),
                  grid_dv: wp.array(dtype=vec3)):
        # one thread a node: a marked node (balance_node ran there) takes its support's change and is unmarked
        node = wp.tid()
        s = grid_fbody[node]
        if s >= 0 and fr_dv[node][3] > Ft(0.0):
            if fr_sums[s, 3] > f64(0.0):
                node_fix(grid_v, grid_dv, grid_mf, fr_sums, s, node, lo, dx, n_grid)
            grid_fbody[node] = -1
        if grid_mf.shape[0] > 1 and s >= 0:
            grid_mf[node] = Ft(0.0)
        fr_dv[node] = vec4(Ft(0.0))

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def fix_clear(jsums: wp.array2d(dtype=f64), fr_sums: wp.array2d(dtype=f64)):
        s = wp.tid()   # one thread a support row: its sums cleared, the box inverted
        for q in range(26):
            fr_sums[s, q] = f64(0.0)
        for q in range(14):
            jsums[s, q] = f64(0.0)
        for q in range(20, 27):
            jsums[s, q] = f64(0.0)
        for d in range(3):
            jsums[s, 14 + 2 * d] = f64(1.0e30)
            jsums[s, 15 + 2 * d] = f64(-1.0e30)

    return fix_supports, fix_nodes, fix_clear


def gpu_balance_launches(engine, k, lo_v, dx, dt_f, ex) -> tuple[list, list]:
    """Pre-recorded launches of the balance on the gpu schedule: before P2G the per-body and per-support moments
    (``moment_blocks``, two ``fold_rows``, ``contact_shift``), after the grid update the friction sums
    (``friction_blocks``, ``fold_rows``) and the fix (``fix_supports``, ``fix_nodes``, ``fix_clear``); ``([], [])``
    without a balance. Allocates the block partials on ``engine``."""
    if engine.c_shift.shape[0] == 0:
        return [], []
    Ft = wp.float32 if engine.precision == "f32" else wp.float64
    d, ng = engine.device, engine.n_grid
    moment_blocks, friction_blocks, fold_rows = build_row_sums(Ft)
    fix_supports, fix_nodes, fix_clear = build_fix(Ft)
    contact_shift = k.contact_shift
    nb, rows = engine.c_sums.shape[0], engine.fr_sums.shape[0]
    nbp, nbn = n_blocks(engine.n_material), n_blocks(ng ** 3)
    engine.g_psums = wp.zeros((nbp, nb, engine.c_sums.shape[1]), dtype=f64, device=d)
    engine.g_pjs = wp.zeros((nbp, rows, engine.c_jsums.shape[1]), dtype=f64, device=d)
    engine.g_pfr = wp.zeros((nbn, rows, FR_SUM_COLUMNS), dtype=f64, device=d)
    g_dt = k.vec3(*[float(c) * engine.dt for c in engine.setup.gravity])

    def rec(kernel, dim, inputs):
        return wp.launch(kernel, dim=dim, device=d, record_cmd=True, inputs=inputs)

    pre = [rec(moment_blocks, nbp, [engine.x, engine.v, engine.C, engine.p_mass, engine.body, engine.p_contact,
                                    engine.planes, engine.plane_n, dt_f, dx, engine.n_material, engine.g_psums,
                                    engine.g_pjs, ex, engine.colc, engine.n_sup]),
           rec(fold_rows, nb * engine.c_sums.shape[1], [engine.g_psums, engine.c_sums, engine.c_sums.shape[1]]),
           rec(fold_rows, rows * engine.c_jsums.shape[1], [engine.g_pjs, engine.c_jsums, JSUMS_BOX]),
           rec(contact_shift, nb, [engine.c_sums, engine.c_shift])]
    fix = [rec(friction_blocks, nbn, [engine.grid_fbody, engine.fr_dv, engine.fr_fb, lo_v, dx, ng, engine.g_pfr]),
           rec(fold_rows, rows * FR_SUM_COLUMNS, [engine.g_pfr, engine.fr_sums, FR_SUM_COLUMNS]),
           rec(fix_supports, rows, [engine.c_shift, engine.c_jsums, engine.fr_sums, engine.c_mass, engine.c_reach,
                                    g_dt, engine.n_sup, engine.c_rigid]),
           rec(fix_nodes, ng ** 3, [engine.grid_v, engine.grid_fbody, engine.fr_dv, engine.fr_sums, lo_v, dx, ng,
                                     engine.grid_mf, engine.grid_dv]),
           rec(fix_clear, rows, [engine.c_jsums, engine.fr_sums])]
    assert FR_COLUMNS == 26
    return pre, fix
