"""The cpu schedule's ordered loops (issue 65, :mod:`gasp_warp_mpm.schedule`): every kernel of warp_mpm that walks
the grid's nodes or a list of them on one thread (``dim=1``) lives here, and only the cpu schedule launches it. Each
fixes the order of a float sum (or of a list the sums read), so the cpu schedule's frames are the same bits on every
run; on a GPU each would be one GPU thread, so the gpu schedule runs the parallel variant named beside it
(:mod:`gasp_warp_mpm.schedule.gpu`, :mod:`gasp_warp_mpm.schedule.gpu_balance`).

- :func:`build_ordered_viscosity`: ``lists`` (the viscous node and cell lists, one thread over the ``n_grid^3``
  nodes in node order; gpu: ``list_flags``, ``wp.utils.array_scan``, ``list_scatter``) and ``dot`` (a dot product
  over the node list, summed in list order on one thread; gpu: ``dot_blocks``, ``fold``, ``fold_final``), launched
  by :class:`CpuViscosity` (gpu: :class:`~gasp_warp_mpm.schedule.gpu.GpuViscosity`);
- :func:`build_contact_fix`: ``contact_fix`` (one thread: each support's fix, then each listed contact node, then the
  sums cleared; gpu: ``fix_supports``, ``fix_nodes``, ``fix_clear``), launched by :func:`balance_launches` (gpu:
  :func:`~gasp_warp_mpm.schedule.gpu_balance.gpu_balance_launches`).

Moved here from ``viscosity.py`` and ``balance.py`` unchanged, so the cpu schedule's bits are those before
(``benchmarks/studies/warp_ordered_bits.py``). The modules both schedules import hold no ``dim=1`` launch but of
the scalar kernels ``plugins/warp_mpm/tests/test_warp_layout.py`` lists, and no kernel loop over a node or point count.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the closures below
as type objects.
"""
import functools
import types

import warp as wp

from ..balance import body_fix, f64, v64
from ..grid import build_node_fix
from ..precision import MODULE_OPTIONS, build_types
from ..viscosity import MAX_ITERS, MAX_ITERS_GRAPH, TOL, ImplicitViscosity, build_viscosity


@functools.cache
def build_ordered_viscosity(Ft):
    """``lists`` and ``dot`` of scalar type ``Ft`` (a namespace): the viscous step's one-thread kernels."""
    vec3, vec4, mat33 = build_types(Ft)
    corner = build_viscosity(Ft).corner   # a cell's corner node (the wp.func the shared kernels use)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def lists(grid_mv: wp.array(dtype=vec4), u: wp.array(dtype=vec3), valid: wp.array(dtype=wp.int32),
              nodes: wp.array(dtype=wp.int32), cells: wp.array(dtype=wp.int32), counts: wp.array(dtype=wp.int32),
              ng: int, label: wp.array(dtype=wp.int32), same: int, box: wp.array(dtype=wp.int32)):
        # one thread: v*, valid cells (lower corner index, all 8 corners with mass and, with same, one label; never
        # on the last plane), and the lists in node order; round 65: over the hull of box's two halves (the step's
        # box, viscosity.ImplicitViscosity.box), which holds every node with mass and every valid 1 of the last step
        nn = int(0)
        nc = int(0)
        for i in range(wp.min(box[0], box[6]), wp.max(box[3], box[9]) + 1):
            for j in range(wp.min(box[1], box[7]), wp.max(box[4], box[10]) + 1):
                for k in range(wp.min(box[2], box[8]), wp.max(box[5], box[11]) + 1):
                    I = (i * ng + j) * ng + k
                    g = grid_mv[I]
                    if g[3] > Ft(0.0):
                        u[I] = vec3(g[0], g[1], g[2]) / g[3]
                        nodes[nn] = I
                        nn = nn + 1
                    ok = int(0)
                    if i < ng - 1 and j < ng - 1 and k < ng - 1:
                        ok = 1
                        for a in range(2):
                            for b in range(2):
                                for e in range(2):
                                    J = corner(I, a, b, e, ng)
                                    if grid_mv[J][3] <= Ft(0.0) or (same != 0 and label[J] != label[I]):
                                        ok = 0
                    valid[I] = ok
                    if ok != 0:
                        cells[nc] = I
                        nc = nc + 1
        counts[0] = nn
        counts[1] = nc

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def dot(a: wp.array(dtype=vec3), b: wp.array(dtype=vec3), nodes: wp.array(dtype=wp.int32),
            counts: wp.array(dtype=wp.int32), out: wp.array(dtype=Ft), slot: int):
        # one thread, in node order (the same sum on every run)
        s = Ft(0.0)
        for t in range(counts[0]):
            I = nodes[t]
            s = s + wp.dot(a[I], b[I])
        out[slot] = s

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def mom_sum(r: wp.array(dtype=vec3), grid_mv: wp.array(dtype=vec4), nodes: wp.array(dtype=wp.int32),
                counts: wp.array(dtype=wp.int32), label: wp.array(dtype=wp.int32), out: wp.array(dtype=vec4)):
        # one thread, in node order: the residual's sum and the mass per label (viscosity.finish's du)
        for b in range(out.shape[0]):
            out[b] = vec4()
        for t in range(counts[0]):
            I = nodes[t]
            ri = r[I]
            b = label[I]
            out[b] = out[b] + vec4(ri[0], ri[1], ri[2], grid_mv[I][3])

    return types.SimpleNamespace(lists=lists, dot=dot, mom_sum=mom_sum)


class CpuViscosity(ImplicitViscosity):
    """:class:`gasp_warp_mpm.viscosity.ImplicitViscosity` on the cpu schedule: the lists built and each dot product
    summed on one thread in node order (:func:`build_ordered_viscosity`), the list lengths and the convergence flag
    read back on the host."""

    def __init__(self, eng, Ft):
        super().__init__(eng, Ft)
        self.o = build_ordered_viscosity(Ft)

    def solve(self, capturing: bool) -> None:
        """Launch one viscous step (between P2G and the grid update). On CPU the list lengths and the convergence
        flag are read back (the launches are synchronous there); inside a CUDA graph capture every launch covers
        the whole grid and :data:`MAX_ITERS_GRAPH` iterations run."""
        e, k, o, d, ng = self.e, self.k, self.o, self.e.device, self.e.n_grid
        dt, inv_dx = self.Ft(e.dt), self.Ft(e.inv_dx)
        self.label_nodes()
        wp.launch(o.lists, dim=1, device=d, inputs=[e.grid_mv, self.u, self.valid, self.nodes, self.cells,
                                                    self.counts, ng, self.label, int(self.same_label), self.box])
        if capturing:
            n_nodes = n_cells = ng ** 3
        else:
            n_nodes, n_cells = (int(c) for c in self.counts.numpy())
        cnt = self.counts
        wp.launch(k.cell_weights, dim=n_cells, device=d, inputs=[e.grid_eta, self.valid, self.cells, cnt, self.wc, ng])
        wp.launch(k.cell_stress, dim=n_cells, device=d, inputs=[self.u, self.wc, self.cells, cnt, self.S, ng, inv_dx])
        wp.launch(k.start, dim=n_nodes, device=d, inputs=[e.grid_mv, self.wc, self.valid, self.S, self.nodes, cnt,
                                                          self.diag, self.r, self.z, self.p, ng, dt, inv_dx])
        wp.launch(o.dot, dim=1, device=d, inputs=[self.r, self.z, self.nodes, cnt, self.scal, 0])
        wp.launch(k.begin, dim=1, device=d, inputs=[self.scal, self.done])
        it = 0
        while it < (MAX_ITERS_GRAPH if capturing else MAX_ITERS):
            if not capturing and int(self.done.numpy()[0]):
                break
            wp.launch(k.cell_stress, dim=n_cells, device=d, inputs=[self.p, self.wc, self.cells, cnt, self.S, ng,
                                                                    inv_dx])
            wp.launch(k.apply, dim=n_nodes, device=d, inputs=[e.grid_mv, self.S, self.valid, self.nodes, cnt, self.p,
                                                              self.Ap, ng, dt, inv_dx])
            wp.launch(o.dot, dim=1, device=d, inputs=[self.p, self.Ap, self.nodes, cnt, self.scal, 2])
            wp.launch(k.step_alpha, dim=1, device=d, inputs=[self.scal, self.done])
            wp.launch(k.update, dim=n_nodes, device=d, inputs=[self.u, self.r, self.z, self.p, self.Ap, self.diag,
                                                               self.nodes, cnt, self.scal])
            wp.launch(o.dot, dim=1, device=d, inputs=[self.r, self.z, self.nodes, cnt, self.scal, 4])
            wp.launch(k.step_beta, dim=1, device=d, inputs=[self.scal, self.done, self.Ft(TOL * TOL)])
            wp.launch(k.direction, dim=n_nodes, device=d, inputs=[self.z, self.p, self.nodes, cnt, self.scal])
            it += 1
        wp.launch(o.mom_sum, dim=1, device=d, inputs=[self.r, e.grid_mv, self.nodes, cnt, self.label, self.mom])
        wp.launch(k.finish, dim=n_nodes, device=d, inputs=[e.grid_mv, e.grid_eta, self.u, self.nodes, cnt, self.mom,
                                                           self.label, int(self.conserve)])
        self.iters += it
        self.solves += 1


@functools.cache
def build_contact_fix(Ft):
    """``contact_fix``, the balance's one-thread kernel of scalar type ``Ft`` after the grid update
    (:mod:`gasp_warp_mpm.balance`'s docstring); at a listed node where the grid update kept the flowing-mass fraction
    ``f`` in ``grid_mf`` (``gasp_core.mpm.fields.B_BALANCE``: the fields keep their offsets there) the change is
    given to field B alone (``grid.build_node_fix``), and ``grid_mf`` is cleared."""
    vec3, vec4, mat33 = build_types(Ft)
    node_fix = build_node_fix(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def contact_fix(grid_v: wp.array(dtype=vec3), grid_fbody: wp.array(dtype=wp.int32),
                    shift: wp.array2d(dtype=f64), jsums: wp.array2d(dtype=f64), fr_sums: wp.array2d(dtype=f64),
                    fr_nodes: wp.array(dtype=wp.int32), mass: wp.array(dtype=f64), reach: wp.array(dtype=f64),
                    g_dt: vec3, lo: vec3, dx: Ft, n_grid: int, n_sup: int, grid_mf: wp.array(dtype=Ft),
                    grid_dv: wp.array(dtype=vec3), rigid: wp.array(dtype=wp.int32)):
        for s in range(fr_sums.shape[0]):
            b = s / n_sup
            body_fix(s, b, shift, jsums, fr_sums, mass[b], reach[b], v64(f64(g_dt[0]), f64(g_dt[1]), f64(g_dt[2])),
                     rigid[b])
        n = wp.min(fr_nodes[0], fr_nodes.shape[0] - 1)
        for q in range(n):
            node = fr_nodes[q + 1]
            s = grid_fbody[node]
            if fr_sums[s, 3] > f64(0.0):
                node_fix(grid_v, grid_dv, grid_mf, fr_sums, s, node, lo, dx, n_grid)
            grid_fbody[node] = -1
            if grid_mf.shape[0] > 1:
                grid_mf[node] = Ft(0.0)
        for s in range(fr_sums.shape[0]):
            for q in range(26):
                fr_sums[s, q] = f64(0.0)
            for q in range(14):
                jsums[s, q] = f64(0.0)
            for q in range(20, 27):
                jsums[s, q] = f64(0.0)
            for d in range(3):   # the box of the pushed points, inverted
                jsums[s, 14 + 2 * d] = f64(1.0e30)
                jsums[s, 15 + 2 * d] = f64(-1.0e30)
        fr_nodes[0] = 0

    return contact_fix


def balance_launches(engine, k, lo_v, dx, dt_f, ex) -> tuple[list, list]:
    """Pre-recorded launches of the balance on the cpu schedule: ``[contact_moments, contact_shift]`` (before P2G)
    and ``[contact_fix]`` (after the grid update); ``([], [])`` without a balance. ``k``: the engine's kernels;
    ``ex`` its colliders' struct."""
    if engine.c_shift.shape[0] == 0:
        return [], []
    Ft = wp.float32 if engine.precision == "f32" else wp.float64
    d, ng = engine.device, engine.n_grid
    g_dt = k.vec3(*[float(c) * engine.dt for c in engine.setup.gravity])
    fix = wp.launch(build_contact_fix(Ft), dim=1, device=d, record_cmd=True, inputs=[
        engine.grid_v, engine.grid_fbody, engine.c_shift, engine.c_jsums, engine.fr_sums, engine.fr_nodes,
        engine.c_mass, engine.c_reach, g_dt, lo_v, dx, ng, engine.n_sup, engine.grid_mf, engine.grid_dv,
        engine.c_rigid])
    pre = [wp.launch(k.contact_moments, dim=engine.n_material, device=d, record_cmd=True, inputs=[
               engine.x, engine.v, engine.C, engine.p_mass, engine.body, engine.p_contact, engine.planes,
               engine.plane_n, dt_f, dx, engine.c_sums, engine.c_jsums, ex, engine.colc, engine.n_sup]),
           wp.launch(k.contact_shift, dim=engine.c_shift.shape[0], device=d, record_cmd=True, inputs=[
               engine.c_sums, engine.c_shift])]
    return pre, [fix]
