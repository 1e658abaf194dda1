"""The gpu schedule's kernels and launches (:mod:`gasp_warp_mpm.schedule`): the viscous step and the contact's balance
with every loop over points, nodes or list entries parallel, and every reduction a fixed-block two-level sum.

Primitives (each a ``build_*(Ft)`` closure, found by :func:`gasp_warp_mpm.warmup.all_kernels`):

- lists by compaction (:func:`build_lists`): ``list_flags`` (one thread a node: ``v*``, the node's and the cell's
  flags), one exclusive ``wp.utils.array_scan`` of both flags (a ``vec2i`` array, scanned per component),
  ``list_scatter`` (one thread a node: its slot is its scan value, so the lists are in node order, as the cpu
  schedule's one-thread loop writes them; the last node writes the counts);
- block sums (:func:`build_block_sums`): ``dot_blocks`` (one thread a block of :data:`BLOCK` list entries, summed in
  order), ``fold`` (one thread a block of :data:`BLOCK` partials) as often as needed, ``fold_final`` (one thread,
  at most :data:`BLOCK` partials, in order) into the CG's scalars;
- per-row sums (:func:`build_row_sums`): ``moment_blocks`` (one thread a block of points: the cpu schedule's
  ``contact_moments`` terms summed per body and support into that block's partials), ``friction_blocks`` (one thread
  a block of nodes: ``balance_node``'s terms of the nodes the grid update marked, per support), ``fold_rows`` (one
  thread per (row, column): the blocks' partials in block order; sums, or the box's min and max);
- the fix (:func:`build_fix`): ``fix_supports`` (one thread a support: ``balance.body_fix``), ``fix_nodes`` (one
  thread a node: the support's ``dv + alpha x (X - x_m)``), ``fix_clear`` (one thread a support);
- CG control (:func:`build_cg_control`): ``cg_begin`` and ``cg_beta`` (one thread: scalars), the latter also writing
  the loop's condition and stopping at :data:`gasp_warp_mpm.viscosity.MAX_ITERS` on the device.

Launch dimensions are fixed by the grid and the points (list lengths stay on the device), so one CUDA graph serves
every substep; on CPU the same launches run, and the CG's condition is read every :data:`CHECK_EVERY` iterations (the
iterations after convergence change nothing: ``step_alpha`` makes them no-ops).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the closures below
as type objects.
"""
import functools

import warp as wp

from ..balance import FR_COLUMNS, body_fix, f64, v64
from ..contact import build_collider_contact, build_contact_impulse
from ..forces import build_extras_struct
from ..precision import MODULE_OPTIONS, build_types
from ..viscosity import MAX_ITERS, MAX_ITERS_GRAPH, TOL, ImplicitViscosity, build_viscosity
from . import BLOCK, n_blocks

#: On CPU (or CUDA without conditional graph nodes, outside a capture) the CG's condition is read on the host every
#: this many iterations: one sync per 4 iterations instead of one per iteration.
CHECK_EVERY = 4
BLK = wp.constant(BLOCK)
#: Columns of the balance's friction sums that the nodes give (``balance.FR_COLUMNS``' first 17; the rest are the
#: per-support results ``fix_supports`` writes).
FR_SUM_COLUMNS = 17
#: ``gasp_core.toolkit.contact.JSUMS``: columns 13-18 are the pushed points' box (min, max per axis), the rest sums.
JSUMS_BOX = 13


@functools.cache
def build_lists(Ft):
    """``(list_flags, list_scatter)`` of scalar type ``Ft``: the viscous node and cell lists by compaction."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def list_flags(grid_mv: wp.array(dtype=vec4), u: wp.array(dtype=vec3), valid: wp.array(dtype=wp.int32),
                   flags: wp.array(dtype=wp.vec2i), ng: int):
        # one thread a node: v* where it has mass; its cell valid when all 8 corners have mass (never on the last plane)
        I = wp.tid()
        i = I / (ng * ng)
        j = (I / ng) % ng
        k = I % ng
        g = grid_mv[I]
        nf = int(0)
        if g[3] > Ft(0.0):
            u[I] = vec3(g[0], g[1], g[2]) / g[3]
            nf = 1
        ok = int(0)
        if i < ng - 1 and j < ng - 1 and k < ng - 1:
            ok = 1
            for a in range(2):
                for b in range(2):
                    for e in range(2):
                        if grid_mv[I + (a * ng + b) * ng + e][3] <= Ft(0.0):
                            ok = 0
        valid[I] = ok
        flags[I] = wp.vec2i(nf, ok)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def list_scatter(flags: wp.array(dtype=wp.vec2i), slots: wp.array(dtype=wp.vec2i), nodes: wp.array(dtype=wp.int32),
                     cells: wp.array(dtype=wp.int32), counts: wp.array(dtype=wp.int32)):
        # one thread a node: its exclusive-scan value is its slot, so the lists keep node order
        I = wp.tid()
        f = flags[I]
        s = slots[I]
        if f[0] != 0:
            nodes[s[0]] = I
        if f[1] != 0:
            cells[s[1]] = I
        if I == flags.shape[0] - 1:
            counts[0] = s[0] + f[0]
            counts[1] = s[1] + f[1]

    return list_flags, list_scatter


@functools.cache
def build_block_sums(Ft):
    """``(dot_blocks, fold, fold_final)`` of scalar type ``Ft``: a dot product over a node list, two-level."""
    vec3 = build_types(Ft)[0]

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def dot_blocks(a: wp.array(dtype=vec3), b: wp.array(dtype=vec3), nodes: wp.array(dtype=wp.int32),
                   counts: wp.array(dtype=wp.int32), part: wp.array(dtype=Ft)):
        # one thread a block of BLOCK list entries, in list (node) order
        blk = wp.tid()
        s = Ft(0.0)
        for t in range(blk * BLK, wp.min(blk * BLK + BLK, counts[0])):
            I = nodes[t]
            s = s + wp.dot(a[I], b[I])
        part[blk] = s

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def fold(part_in: wp.array(dtype=Ft), part_out: wp.array(dtype=Ft)):
        # one thread a block of BLOCK partials, in order
        blk = wp.tid()
        s = Ft(0.0)
        for t in range(blk * BLK, wp.min(blk * BLK + BLK, part_in.shape[0])):
            s = s + part_in[t]
        part_out[blk] = s

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def fold_final(part_in: wp.array(dtype=Ft), out: wp.array(dtype=Ft), slot: int):
        # one thread: at most BLOCK partials, in order (scalar bookkeeping)
        s = Ft(0.0)
        for t in range(part_in.shape[0]):
            s = s + part_in[t]
        out[slot] = s

    return dot_blocks, fold, fold_final


@functools.cache
def build_cg_control(Ft):
    """``(cg_begin, cg_beta)`` of scalar type ``Ft``: the CG's scalars with the loop's condition on the device."""

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def cg_begin(scal: wp.array(dtype=Ft), done: wp.array(dtype=wp.int32), cond: wp.array(dtype=wp.int32),
                 it: wp.array(dtype=wp.int32)):
        # viscosity.begin, and the condition: iterate while not done
        scal[1] = scal[0]
        done[0] = 0
        if scal[0] <= Ft(0.0):
            done[0] = 1
        cond[0] = 1 - done[0]
        it[0] = 0

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def cg_beta(scal: wp.array(dtype=Ft), done: wp.array(dtype=wp.int32), tol2: Ft, cond: wp.array(dtype=wp.int32),
                it: wp.array(dtype=wp.int32), max_iters: int):
        # viscosity.step_beta; an iteration counted while not done; done at max_iters (later iterations: no-ops)
        scal[5] = Ft(0.0)
        if done[0] == 0:
            if scal[0] > Ft(0.0):
                scal[5] = scal[4] / scal[0]
            scal[0] = scal[4]
            if scal[4] <= tol2 * scal[1]:
                done[0] = 1
            it[0] = it[0] + 1
            if it[0] >= max_iters:
                done[0] = 1
        cond[0] = 1 - done[0]

    return cg_begin, cg_beta


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
def acc_contact(part: wp.array3d(dtype=f64), blk: int, s: int, j: f64, r: v64, n: v64, vc: v64):
    # balance.add_contact into a block's partials
    jn = j * n
    mn = wp.cross(r, jn)
    part[blk, s, 0] = part[blk, s, 0] + j
    for q in range(3):
        part[blk, s, 1 + q] = part[blk, s, 1 + q] + j * r[q]
        part[blk, s, 4 + q] = part[blk, s, 4 + q] + jn[q]
        part[blk, s, 7 + q] = part[blk, s, 7 + q] + mn[q]
        part[blk, s, 10 + q] = part[blk, s, 10 + q] + j * vc[q]
        part[blk, s, 13 + 2 * q] = wp.min(part[blk, s, 13 + 2 * q], r[q])
        part[blk, s, 14 + 2 * q] = wp.max(part[blk, s, 14 + 2 * q], r[q])


@functools.cache
def build_row_sums(Ft):
    """``(moment_blocks, friction_blocks, fold_rows)`` of scalar type ``Ft``: the balance's per-body and per-support
    sums, two-level, no atomics."""
    vec3, vec4, mat33 = build_types(Ft)
    collider_contact = build_collider_contact(Ft)[0]
    contact_impulse = build_contact_impulse(Ft)
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
                pjs[blk, s, 13 + 2 * d] = f64(1.0e30)
                pjs[blk, s, 14 + 2 * d] = f64(-1.0e30)
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
                depth = planes[q][0] + kcs[2] - wp.dot(plane_n[q], xp)
                if depth > Ft(0.0):
                    jq = contact_impulse(ex, b, ex.plane_e[q], wp.dot(plane_n[q], vp), 0, plane_n[q], depth, kcs, dt)
                if jq > Ft(0.0):
                    nq = plane_n[q]
                    acc_contact(pjs, blk, b * n_sup + int(planes[q][2]), f64(jq), r,
                                v64(f64(nq[0]), f64(nq[1]), f64(nq[2])), v64(f64(0.0)))
            if colc != 0:
                base = ex.step[0] * ex.width
                for cc in range(ex.n_col):
                    jq, n, vc = collider_contact(ex, base, cc, xp, vp, kcs, dt, b, 0)
                    if jq > Ft(0.0):
                        acc_contact(pjs, blk, b * n_sup + 1 + cc, f64(jq), r, v64(f64(n[0]), f64(n[1]), f64(n[2])),
                                    v64(f64(vc[0]), f64(vc[1]), f64(vc[2])))

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
        # one thread per (row, column) of the partials: the blocks in block order; from column box_from on, the
        # columns alternate min and max (the pushed points' box)
        t = wp.tid()
        nc = part.shape[2]
        row = t / nc
        c = t % nc
        if c < box_from:
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
    """``(fix_supports, fix_nodes, fix_clear)`` of scalar type ``Ft``: ``balance.contact_fix`` split into a per-support
    solve, a per-node apply and a per-support clear."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def fix_supports(shift: wp.array2d(dtype=f64), jsums: wp.array2d(dtype=f64), fr_sums: wp.array2d(dtype=f64),
                     mass: wp.array(dtype=f64), reach: wp.array(dtype=f64), g_dt: vec3, n_sup: int):
        s = wp.tid()   # one thread a support row (per-body bookkeeping)
        b = s / n_sup
        body_fix(s, b, shift, jsums, fr_sums, mass[b], reach[b], v64(f64(g_dt[0]), f64(g_dt[1]), f64(g_dt[2])))

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def fix_nodes(grid_v: wp.array(dtype=vec3), grid_fbody: wp.array(dtype=wp.int32), fr_dv: wp.array(dtype=vec4),
                  fr_sums: wp.array2d(dtype=f64), lo: vec3, dx: Ft, n_grid: int):
        # one thread a node: a marked node (balance_node ran there) takes its support's change and is unmarked
        node = wp.tid()
        s = grid_fbody[node]
        if s >= 0 and fr_dv[node][3] > Ft(0.0):
            if fr_sums[s, 3] > f64(0.0):
                i = node / (n_grid * n_grid)
                j = (node / n_grid) % n_grid
                k = node % n_grid
                X = v64(f64(lo[0] + dx * Ft(i)), f64(lo[1] + dx * Ft(j)), f64(lo[2] + dx * Ft(k)))
                dv = v64(fr_sums[s, 17], fr_sums[s, 18], fr_sums[s, 19]) + wp.cross(
                    v64(fr_sums[s, 20], fr_sums[s, 21], fr_sums[s, 22]),
                    X - v64(fr_sums[s, 23], fr_sums[s, 24], fr_sums[s, 25]))
                grid_v[node] = grid_v[node] + vec3(Ft(dv[0]), Ft(dv[1]), Ft(dv[2]))
            grid_fbody[node] = -1
        fr_dv[node] = vec4(Ft(0.0))

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def fix_clear(jsums: wp.array2d(dtype=f64), fr_sums: wp.array2d(dtype=f64)):
        s = wp.tid()   # one thread a support row: its sums cleared, the box inverted
        for q in range(26):
            fr_sums[s, q] = f64(0.0)
        for q in range(13):
            jsums[s, q] = f64(0.0)
        for d in range(3):
            jsums[s, 13 + 2 * d] = f64(1.0e30)
            jsums[s, 14 + 2 * d] = f64(-1.0e30)

    return fix_supports, fix_nodes, fix_clear


def fold_chain(n: int) -> list:
    """Sizes of the partial arrays of a sum over ``n`` items: ``[n_blocks(n), n_blocks(that), ...]`` down to at most
    :data:`BLOCK` (the last is folded by one thread)."""
    sizes = [n_blocks(n)]
    while sizes[-1] > BLOCK:
        sizes.append(n_blocks(sizes[-1]))
    return sizes


class GpuViscosity(ImplicitViscosity):
    """:class:`gasp_warp_mpm.viscosity.ImplicitViscosity` on the gpu schedule: lists by compaction, block-reduced dot
    products, the CG's condition on the device. Every launch covers the grid (or the list's capacity); the lists'
    lengths stay on the device."""

    def __init__(self, eng, Ft):
        super().__init__(eng, Ft)
        d, n = eng.device, eng.n_grid ** 3
        self.flags = wp.zeros(n, dtype=wp.vec2i, device=d)
        self.slots = wp.zeros(n, dtype=wp.vec2i, device=d)
        self.parts = [wp.zeros(m, dtype=Ft, device=d) for m in fold_chain(n)]
        self.cond = wp.zeros(1, dtype=wp.int32, device=d)
        self.it = wp.zeros(1, dtype=wp.int32, device=d)
        self.g_lists = build_lists(Ft)
        self.g_sums = build_block_sums(Ft)
        self.g_cg = build_cg_control(Ft)

    def _dot(self, a, b, slot: int) -> None:
        dot_blocks, fold, fold_final = self.g_sums
        d, parts = self.e.device, self.parts
        wp.launch(dot_blocks, dim=parts[0].shape[0], device=d, inputs=[a, b, self.nodes, self.counts, parts[0]])
        for src, dst in zip(parts[:-1], parts[1:]):
            wp.launch(fold, dim=dst.shape[0], device=d, inputs=[src, dst])
        wp.launch(fold_final, dim=1, device=d, inputs=[parts[-1], self.scal, slot])

    def _iteration(self) -> None:
        e, k, d, ng, n = self.e, self.k, self.e.device, self.e.n_grid, self.e.n_grid ** 3
        dt, inv_dx, cnt = self.Ft(e.dt), self.Ft(e.inv_dx), self.counts
        wp.launch(k.cell_stress, dim=n, device=d, inputs=[self.p, self.wc, self.cells, cnt, self.S, ng, inv_dx])
        wp.launch(k.apply, dim=n, device=d, inputs=[e.grid_mv, self.S, self.valid, self.nodes, cnt, self.p, self.Ap,
                                                    ng, dt, inv_dx])
        self._dot(self.p, self.Ap, 2)
        wp.launch(k.step_alpha, dim=1, device=d, inputs=[self.scal, self.done])
        wp.launch(k.update, dim=n, device=d, inputs=[self.u, self.r, self.z, self.p, self.Ap, self.diag, self.nodes,
                                                     cnt, self.scal])
        self._dot(self.r, self.z, 4)
        wp.launch(self.g_cg[1], dim=1, device=d, inputs=[self.scal, self.done, self.Ft(TOL * TOL), self.cond,
                                                         self.it, MAX_ITERS])
        wp.launch(k.direction, dim=n, device=d, inputs=[self.z, self.p, self.nodes, cnt, self.scal])

    def _iterations(self, count: int) -> None:
        for _ in range(count):
            self._iteration()

    def solve(self, capturing: bool) -> None:
        """Launch one viscous step (between P2G and the grid update), the same launches on every device: on CUDA
        inside the frame's graph capture, the CG loop is a conditional node (``wp.capture_while``) where Warp
        supports one, else :data:`MAX_ITERS_GRAPH` iterations; elsewhere the condition is read every
        :data:`CHECK_EVERY` iterations."""
        e, k, d, ng, n = self.e, self.k, self.e.device, self.e.n_grid, self.e.n_grid ** 3
        dt, inv_dx, cnt = self.Ft(e.dt), self.Ft(e.inv_dx), self.counts
        list_flags, list_scatter = self.g_lists
        wp.launch(list_flags, dim=n, device=d, inputs=[e.grid_mv, self.u, self.valid, self.flags, ng])
        wp.utils.array_scan(self.flags, self.slots, inclusive=False)
        wp.launch(list_scatter, dim=n, device=d, inputs=[self.flags, self.slots, self.nodes, self.cells, cnt])
        wp.launch(k.cell_weights, dim=n, device=d, inputs=[e.grid_eta, self.valid, self.cells, cnt, self.wc, ng])
        wp.launch(k.cell_stress, dim=n, device=d, inputs=[self.u, self.wc, self.cells, cnt, self.S, ng, inv_dx])
        wp.launch(k.start, dim=n, device=d, inputs=[e.grid_mv, self.wc, self.valid, self.S, self.nodes, cnt,
                                                    self.diag, self.r, self.z, self.p, ng, dt, inv_dx])
        self._dot(self.r, self.z, 0)
        wp.launch(self.g_cg[0], dim=1, device=d, inputs=[self.scal, self.done, self.cond, self.it])
        if capturing and d.is_cuda:
            if wp.is_conditional_graph_supported():
                wp.capture_while(self.cond, self._iterations, count=1)
            else:
                self._iterations(MAX_ITERS_GRAPH)
        else:
            it = 0
            while it < MAX_ITERS and int(self.cond.numpy()[0]):
                self._iterations(CHECK_EVERY)
                it += CHECK_EVERY
        wp.launch(k.finish, dim=n, device=d, inputs=[e.grid_mv, e.grid_eta, self.u, self.nodes, cnt])
        self.solves += 1


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
                                    g_dt, engine.n_sup]),
           rec(fix_nodes, ng ** 3, [engine.grid_v, engine.grid_fbody, engine.fr_dv, engine.fr_sums, lo_v, dx, ng]),
           rec(fix_clear, rows, [engine.c_jsums, engine.fr_sums])]
    assert FR_COLUMNS == 26
    return pre, fix
