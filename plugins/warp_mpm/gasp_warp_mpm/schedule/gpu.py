"""The gpu schedule's kernels and launches (:mod:`gasp_warp_mpm.schedule`): the viscous step (the contact's balance:
:mod:`gasp_warp_mpm.schedule.gpu_balance`) with every loop over points, nodes or list entries parallel, and every reduction a fixed-block two-level sum.

Primitives (each a ``build_*(Ft)`` closure, found by :func:`gasp_warp_mpm.warmup.all_kernels`):

- lists by compaction (:func:`build_lists`): ``list_flags`` (one thread a node: ``v*``, the node's and the cell's
  flags), one exclusive ``wp.utils.array_scan`` of both flags (a ``vec2i`` array, scanned per component),
  ``list_scatter`` (one thread a node: its slot is its scan value, so the lists are in node order, as the cpu
  schedule's one-thread loop writes them; the last node writes the counts);
- block sums (:func:`build_block_sums`): ``dot_blocks`` (one thread a block of :data:`BLOCK` list entries, summed in
  order), ``fold`` (one thread a block of :data:`BLOCK` partials) as often as needed, ``fold_final`` (one thread,
  at most :data:`BLOCK` partials, in order) into the CG's scalars;
- the contact's balance: :mod:`gasp_warp_mpm.schedule.gpu_balance`;
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

from ..precision import MODULE_OPTIONS, build_types
from ..viscosity import MAX_ITERS, MAX_ITERS_GRAPH, TOL, ImplicitViscosity
from . import BLOCK, n_blocks

#: On CPU (or CUDA without conditional graph nodes, outside a capture) the CG's condition is read on the host every
#: this many iterations: one sync per 4 iterations instead of one per iteration.
CHECK_EVERY = 4
BLK = wp.constant(BLOCK)


@functools.cache
def build_lists(Ft):
    """``(list_flags, list_scatter)`` of scalar type ``Ft``: the viscous node and cell lists by compaction."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def list_flags(grid_mv: wp.array(dtype=vec4), u: wp.array(dtype=vec3), valid: wp.array(dtype=wp.int32),
                   flags: wp.array(dtype=wp.vec2i), ng: int, label: wp.array(dtype=wp.int32), same: int):
        # one thread a node: v* where it has mass; its cell valid when all 8 corners have mass and, with same, one
        # label (never on the last plane)
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
                        J = I + (a * ng + b) * ng + e
                        if grid_mv[J][3] <= Ft(0.0) or (same != 0 and label[J] != label[I]):
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
def build_mom_sums(Ft):
    """``(mom_blocks, fold, fold_final)`` of scalar type ``Ft``: the residual's sum and the mass over the entries of a
    node list with one label (``vec4``), two-level as :func:`build_block_sums` (viscosity.finish's ``du``; one pass a
    label, so the partials' memory does not grow with the bodies)."""
    vec3, vec4 = build_types(Ft)[:2]

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def mom_blocks(r: wp.array(dtype=vec3), grid_mv: wp.array(dtype=vec4), nodes: wp.array(dtype=wp.int32),
                   counts: wp.array(dtype=wp.int32), label: wp.array(dtype=wp.int32), b: int,
                   part: wp.array(dtype=vec4)):
        # one thread a block of BLOCK list entries, in order: those labelled b
        blk = wp.tid()
        s = vec4()
        for t in range(blk * BLK, wp.min(blk * BLK + BLK, counts[0])):
            I = nodes[t]
            if label[I] == b:
                ri = r[I]
                s = s + vec4(ri[0], ri[1], ri[2], grid_mv[I][3])
        part[blk] = s

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def fold(part_in: wp.array(dtype=vec4), part_out: wp.array(dtype=vec4)):
        blk = wp.tid()
        s = vec4()
        for t in range(blk * BLK, wp.min(blk * BLK + BLK, part_in.shape[0])):
            s = s + part_in[t]
        part_out[blk] = s

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def fold_final(part_in: wp.array(dtype=vec4), out: wp.array(dtype=vec4), slot: int):
        s = vec4()
        for t in range(part_in.shape[0]):
            s = s + part_in[t]
        out[slot] = s

    return mom_blocks, fold, fold_final


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
        self.parts4 = [wp.zeros(m, dtype=build_types(Ft)[1], device=d) for m in fold_chain(n)]
        self.g_moms = build_mom_sums(Ft)
        self.cond = wp.zeros(1, dtype=wp.int32, device=d)
        self.it = wp.zeros(1, dtype=wp.int32, device=d)
        self.g_lists = build_lists(Ft)
        self.g_sums = build_block_sums(Ft)
        self.cg_begin, self.cg_beta = build_cg_control(Ft)

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
        wp.launch(self.cg_beta, dim=1, device=d, inputs=[self.scal, self.done, self.Ft(TOL * TOL), self.cond, self.it,
                                                       MAX_ITERS])
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
        self.label_nodes()
        wp.launch(list_flags, dim=n, device=d, inputs=[e.grid_mv, self.u, self.valid, self.flags, ng, self.label,
                                                         int(self.same_label)])
        wp.utils.array_scan(self.flags, self.slots, inclusive=False)
        wp.launch(list_scatter, dim=n, device=d, inputs=[self.flags, self.slots, self.nodes, self.cells, cnt])
        wp.launch(k.cell_weights, dim=n, device=d, inputs=[e.grid_eta, self.valid, self.cells, cnt, self.wc, ng])
        wp.launch(k.cell_stress, dim=n, device=d, inputs=[self.u, self.wc, self.cells, cnt, self.S, ng, inv_dx])
        wp.launch(k.start, dim=n, device=d, inputs=[e.grid_mv, self.wc, self.valid, self.S, self.nodes, cnt,
                                                    self.diag, self.r, self.z, self.p, ng, dt, inv_dx])
        self._dot(self.r, self.z, 0)
        wp.launch(self.cg_begin, dim=1, device=d, inputs=[self.scal, self.done, self.cond, self.it])
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
        mom_blocks, fold, fold_final = self.g_moms
        parts = self.parts4
        for b in range(self.n_labels):   # one pass a label (the labels' count is fixed: one graph serves)
            wp.launch(mom_blocks, dim=parts[0].shape[0], device=d, inputs=[self.r, e.grid_mv, self.nodes, cnt,
                                                                           self.label, b, parts[0]])
            for src, dst in zip(parts[:-1], parts[1:]):
                wp.launch(fold, dim=dst.shape[0], device=d, inputs=[src, dst])
            wp.launch(fold_final, dim=1, device=d, inputs=[parts[-1], self.mom, b])
        wp.launch(k.finish, dim=n, device=d, inputs=[e.grid_mv, e.grid_eta, self.u, self.nodes, cnt, self.mom,
                                                    self.label, int(self.conserve)])
        self.solves += 1
