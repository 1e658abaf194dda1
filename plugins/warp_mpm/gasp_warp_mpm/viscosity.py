"""Implicit Kelvin-Voigt viscosity on the grid, Warp kernels: the algorithm of ``gasp_taichi_mpm.viscosity``
(``docs/dissipation.md``, "Time step").

After P2G the grid holds each node's momentum ``m v*`` and mass (``grid_mv``) and viscous volume
``(eta V)_i = sum_p w_ip J_p V_p eta_p`` (``grid_eta``, Pa s m^3). One backward-Euler step of the viscous stress,

    (M + dt K) v = M v*,      (K v)_i = sum_c (eta V)_c (G_c + G_c^T) g_ic,

over the nodes with mass; ``c`` runs over the cells whose 8 corners all have mass and one body label (round 50,
``same_label``), ``G_c = sum_i v_i g_ic^T``
(trilinear shape functions at the cell centre, ``g_ic = (+-1, +-1, +-1) / (4 dx)``), ``(eta V)_c = sum_corners
(eta V)_i / n_i`` (``n_i`` valid cells at node ``i``). Solved by conjugate gradients with the diagonal
``m_i + dt sum_c (eta V)_c / (4 dx^2)`` as preconditioner from ``v*``, until ``r.z`` falls below ``TOL^2`` of its
start (at most ``MAX_ITERS``).

This module holds the kernels both schedules launch (:mod:`gasp_warp_mpm.schedule`) and the step's arrays
(:class:`ImplicitViscosity`). The lists of nodes and cells (in node order) and the CG's dot products are each
schedule's own: on the cpu schedule built and summed by one thread in node order
(:mod:`gasp_warp_mpm.schedule.ordered`, ``CpuViscosity``), on the gpu schedule by compaction and block sums
(:mod:`gasp_warp_mpm.schedule.gpu`, ``GpuViscosity``); either gives the same result on every run.

The CG stops at ``TOL``, so its iterate ``u`` leaves the residual ``r = M v* - (M + dt K) u``, whose sum is the
momentum ``M u`` lacks (``K`` sums to zero); with :attr:`ImplicitViscosity.conserve` (the default) ``finish`` adds one
uniform velocity per body, ``du_b = sum_{i in b} r_i / sum_{i in b} m_i`` over the solved nodes labelled ``b``
(``label``: the least body id among the points whose stencil reaches the node with a positive weight, an
order-free ``atomic_min``; a node no point labelled joins the last body's), summed by the schedule in a fixed order
(``mom``, one row a label). The labels partition the solved nodes, so ``sum_b du_b M_b = sum_i r_i``: the step
conserves total momentum to round-off, and a body the solve left alone (``r = 0`` on its nodes) gets ``du = 0``
however another body's solve ends (round 50, docs/dissipation.md; round 49's one ``du`` over the grid moved a
resting cube beside a sheared one). As ``gasp_taichi_mpm.viscosity``.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import numpy as np
import warp as wp

from . import field_nodes as FN
from .field_nodes import build_sweep
from .precision import MODULE_OPTIONS, build_types
from .stencil import build_stencil

#: CG stops when sqrt(r.z) has fallen to this fraction of its value at v* (as gasp_taichi_mpm.viscosity.TOL).
TOL = 1e-2
#: At most this many CG iterations per substep (on CUDA, inside a captured graph, always this many; the
#: iterations after convergence change nothing).
MAX_ITERS = 200
MAX_ITERS_GRAPH = 30


@functools.cache
def build_viscosity(Ft):
    """The kernels of the implicit viscous step for scalar type ``Ft`` (a namespace).

    long because the Warp kernels and functions are closures over ``Ft`` and its vector types, built together."""
    import types
    vec3, vec4, mat33 = build_types(Ft)
    in_grid, weights = build_stencil(Ft)
    box_units, unit_first, unit_len, box_q = build_sweep(Ft)

    @wp.func
    def corner(c: int, a: int, b: int, e: int, ng: int):
        return c + (a * ng + b) * ng + e

    @wp.func
    def grad(a: int, b: int, e: int, q: Ft):
        return vec3(Ft(2 * a - 1), Ft(2 * b - 1), Ft(2 * e - 1)) * q

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def cell_weights(grid_eta: wp.array(dtype=Ft), valid: wp.array(dtype=wp.int32), cells: wp.array(dtype=wp.int32),
                     counts: wp.array(dtype=wp.int32), wc: wp.array(dtype=Ft), ng: int):
        t = wp.tid()
        if t >= counts[1]:
            return
        c = cells[t]
        w = Ft(0.0)
        for a in range(2):
            for b in range(2):
                for e in range(2):
                    J = corner(c, a, b, e, ng)
                    n = int(0)
                    for a2 in range(2):
                        for b2 in range(2):
                            for e2 in range(2):
                                n = n + valid[J - (a2 * ng + b2) * ng - e2]
                    w = w + grid_eta[J] / Ft(n)
        wc[c] = w

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def cell_stress(field: wp.array(dtype=vec3), wc: wp.array(dtype=Ft), cells: wp.array(dtype=wp.int32),
                    counts: wp.array(dtype=wp.int32), S: wp.array(dtype=mat33), ng: int, inv_dx: Ft):
        t = wp.tid()
        if t >= counts[1]:
            return
        c = cells[t]
        q = Ft(0.25) * inv_dx
        G = mat33()
        for a in range(2):
            for b in range(2):
                for e in range(2):
                    G = G + wp.outer(field[corner(c, a, b, e, ng)], grad(a, b, e, q))
        S[c] = wc[c] * (G + wp.transpose(G))

    @wp.func
    def node_force(I: int, S: wp.array(dtype=mat33), valid: wp.array(dtype=wp.int32), ng: int, q: Ft):
        f = vec3()
        for a in range(2):
            for b in range(2):
                for e in range(2):
                    c = I - (a * ng + b) * ng - e
                    if c >= 0:
                        if valid[c] != 0:
                            f = f + S[c] * grad(a, b, e, q)
        return f

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def start(grid_mv: wp.array(dtype=vec4), wc: wp.array(dtype=Ft), valid: wp.array(dtype=wp.int32),
              S: wp.array(dtype=mat33), nodes: wp.array(dtype=wp.int32), counts: wp.array(dtype=wp.int32),
              diag: wp.array(dtype=Ft), r: wp.array(dtype=vec3), z: wp.array(dtype=vec3), p: wp.array(dtype=vec3),
              ng: int, dt: Ft, inv_dx: Ft):
        t = wp.tid()
        if t >= counts[0]:
            return
        I = nodes[t]
        q = Ft(0.25) * inv_dx
        wsum = Ft(0.0)
        for a in range(2):
            for b in range(2):
                for e in range(2):
                    c = I - (a * ng + b) * ng - e
                    if c >= 0:
                        if valid[c] != 0:
                            wsum = wsum + wc[c]
        d = grid_mv[I][3] + Ft(0.25) * dt * inv_dx * inv_dx * wsum
        ri = -dt * node_force(I, S, valid, ng, q)
        diag[I] = d
        r[I] = ri
        z[I] = ri / d
        p[I] = ri / d

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def apply(grid_mv: wp.array(dtype=vec4), S: wp.array(dtype=mat33), valid: wp.array(dtype=wp.int32),
              nodes: wp.array(dtype=wp.int32), counts: wp.array(dtype=wp.int32), p: wp.array(dtype=vec3),
              Ap: wp.array(dtype=vec3), ng: int, dt: Ft, inv_dx: Ft):
        t = wp.tid()
        if t >= counts[0]:
            return
        I = nodes[t]
        Ap[I] = grid_mv[I][3] * p[I] + dt * node_force(I, S, valid, ng, Ft(0.25) * inv_dx)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def step_alpha(scal: wp.array(dtype=Ft), done: wp.array(dtype=wp.int32)):
        # scal: [rz, rz0, pAp, alpha, rz_new, beta]
        scal[3] = Ft(0.0)
        if done[0] == 0:
            if scal[2] > Ft(0.0):
                scal[3] = scal[0] / scal[2]
            else:
                done[0] = 1

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def update(u: wp.array(dtype=vec3), r: wp.array(dtype=vec3), z: wp.array(dtype=vec3), p: wp.array(dtype=vec3),
               Ap: wp.array(dtype=vec3), diag: wp.array(dtype=Ft), nodes: wp.array(dtype=wp.int32),
               counts: wp.array(dtype=wp.int32), scal: wp.array(dtype=Ft)):
        t = wp.tid()
        if t >= counts[0]:
            return
        I = nodes[t]
        alpha = scal[3]
        u[I] = u[I] + alpha * p[I]
        ri = r[I] - alpha * Ap[I]
        r[I] = ri
        z[I] = ri / diag[I]

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def step_beta(scal: wp.array(dtype=Ft), done: wp.array(dtype=wp.int32), tol2: Ft):
        scal[5] = Ft(0.0)
        if done[0] == 0:
            if scal[0] > Ft(0.0):
                scal[5] = scal[4] / scal[0]
            scal[0] = scal[4]
            if scal[4] <= tol2 * scal[1]:
                done[0] = 1

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def direction(z: wp.array(dtype=vec3), p: wp.array(dtype=vec3), nodes: wp.array(dtype=wp.int32),
                  counts: wp.array(dtype=wp.int32), scal: wp.array(dtype=Ft)):
        t = wp.tid()
        if t >= counts[0]:
            return
        I = nodes[t]
        p[I] = z[I] + scal[5] * p[I]

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def begin(scal: wp.array(dtype=Ft), done: wp.array(dtype=wp.int32)):
        # after the first r.z (in scal[0]): remember it, converged already when it is zero
        scal[1] = scal[0]
        done[0] = 0
        if scal[0] <= Ft(0.0):
            done[0] = 1

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def label_clear(label: wp.array(dtype=wp.int32), none: int, ng: int, box: wp.array(dtype=wp.int32), threads: int,
                    along: int):
        n = box_units(box, along)   # round 65: over the step's box (ImplicitViscosity.box), not the whole grid
        run = (n + threads - 1) / threads
        for r in range(run):
            q = box_q(wp.tid(), r, run, threads, along)
            if q < n:
                first = unit_first(box, q, ng, along)
                for node in range(first, first + unit_len(box, along)):
                    label[node] = none

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def label_points(x: wp.array(dtype=vec3), p_mass: wp.array(dtype=Ft), body: wp.array(dtype=wp.int32),
                     label: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft, ng: int):
        # each node a point reaches with a positive weight (P2G's stencil) gets the least body id there
        p = wp.tid()
        X = (x[p] - lo) * inv_dx
        if not in_grid(X, ng) or p_mass[p] <= Ft(0.0):
            return
        base = wp.vec3i(int(wp.floor(X[0] - Ft(0.5))), int(wp.floor(X[1] - Ft(0.5))), int(wp.floor(X[2] - Ft(0.5))))
        W = weights(X - vec3(Ft(base[0]), Ft(base[1]), Ft(base[2])))
        b = body[p]
        for a in range(3):
            for c in range(3):
                for e in range(3):
                    if W[a, 0] * W[c, 1] * W[e, 2] > Ft(0.0):
                        wp.atomic_min(label, ((base[0] + a) * ng + base[1] + c) * ng + base[2] + e, b)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def finish(grid_mv: wp.array(dtype=vec4), grid_eta: wp.array(dtype=Ft), u: wp.array(dtype=vec3),
               nodes: wp.array(dtype=wp.int32), counts: wp.array(dtype=wp.int32), mom: wp.array(dtype=vec4),
               label: wp.array(dtype=wp.int32), conserve: int):
        # momentum m (u + du) back (the grid update divides by m again), du = sum r / sum m over the node's label
        # (mom[label], the schedule's fixed-order sums) when conserve, else 0; the viscous volume cleared for the
        # next P2G
        t = wp.tid()
        if t >= counts[0]:
            return
        I = nodes[t]
        s = mom[label[I]]
        du = vec3()
        if conserve != 0 and s[3] > Ft(0.0):
            du = vec3(s[0], s[1], s[2]) / s[3]
        m = grid_mv[I][3]
        v = u[I] + du
        grid_mv[I] = vec4(m * v[0], m * v[1], m * v[2], m)
        grid_eta[I] = Ft(0.0)

    return types.SimpleNamespace(corner=corner, cell_weights=cell_weights, cell_stress=cell_stress, start=start,
                                 apply=apply, step_alpha=step_alpha, update=update, step_beta=step_beta,
                                 direction=direction, begin=begin, finish=finish, label_clear=label_clear,
                                 label_points=label_points)


class ImplicitViscosity:
    """The viscous step of one :class:`gasp_warp_mpm.engine.WarpMPMEngine`: its arrays and the shared kernels
    (``k``); the schedule's subclass launches them (:meth:`solve`).

    Parameters
    ----------
    eng : WarpMPMEngine
        Its ``grid_mv`` (momentum, mass), ``grid_eta`` (viscous volume), ``n_grid``, ``dt``, ``inv_dx``, ``device``.
    Ft : warp scalar type
    """

    #: True: the step returns ``m (u + du_b)``, ``du_b = sum r / sum m`` over the nodes labelled ``b`` (total momentum
    #: conserved whatever ``TOL``, each body's own); False: ``m u``, the rule before round 49 (the damped jelly slid
    #: 23 % fast on n_grid 48).
    conserve = True
    #: True: one ``du`` per label (body); False: one over all solved nodes, round 49's rule (a resting cube beside a
    #: sheared one moved: docs/dissipation.md "Round 50").
    per_body = True
    #: True: a valid cell's 8 corners share one label (no viscous bridge between two bodies across empty cells);
    #: False: any 8 corners with mass, the rule before (docs/dissipation.md "Round 50: ... inside material only").
    same_label = True

    def __init__(self, eng, Ft):
        self.e, self.Ft = eng, Ft
        self.k = build_viscosity(Ft)
        vec3, vec4, mat33 = build_types(Ft)
        d, n = eng.device, eng.n_grid ** 3
        self.u, self.r, self.z, self.p, self.Ap = (wp.zeros(n, dtype=vec3, device=d) for _ in range(5))
        self.diag = wp.zeros(n, dtype=Ft, device=d)
        self.wc = wp.zeros(n, dtype=Ft, device=d)
        self.S = wp.zeros(n, dtype=mat33, device=d)
        self.valid = wp.zeros(n, dtype=wp.int32, device=d)
        self.nodes = wp.zeros(n, dtype=wp.int32, device=d)
        self.cells = wp.zeros(n, dtype=wp.int32, device=d)
        self.counts = wp.zeros(2, dtype=wp.int32, device=d)
        self.scal = wp.zeros(6, dtype=Ft, device=d)
        self.done = wp.zeros(1, dtype=wp.int32, device=d)
        # each solved node's label (the least body id there; none: the last) and (sum r, sum m) per label
        self.n_labels = int(eng.mat_par.shape[0])
        self.label = wp.full(n, self.n_labels - 1, dtype=wp.int32, device=d)
        self.mom = wp.zeros(self.n_labels, dtype=vec4, device=d)
        self.iters = 0
        self.solves = 0
        self.allocate_box()

    def allocate_box(self) -> None:
        """``box`` (12 int32, ``field_nodes``' layout: this step's P2G box, then the last's): round 65, the step's
        lists (the cpu schedule's) and labels over its hull, not the whole grid (``docs/performance.md`` "Round 65");
        the whole grid with ``grid_box.VISC_BOX`` off (no box launches then, :meth:`box_launch`)."""
        from .grid_box import VISC_BOX
        ng = self.e.n_grid
        self.boxed = bool(VISC_BOX)
        box = [ng] * 3 + [-1] * 3 + [ng] * 3 + [-1] * 3 if self.boxed else [0, 0, 0, ng - 1, ng - 1, ng - 1] * 2
        self.box = wp.array(np.array(box, np.int32), dtype=wp.int32, device=self.e.device)

    def box_launch(self) -> None:
        """Launch ``field_nodes``' ``box_reset`` and ``field_box`` on :attr:`box` (this step's points, P2G's), where
        :meth:`allocate_box` made it a box. Its hull holds every node with mass (the solved nodes, the valid cells'
        corners, the labelled nodes) and every node the last step wrote ``valid`` 1 or a label at."""
        if not self.boxed:
            return
        e = self.e
        box_reset, field_box = FN.build_field_box(self.Ft)
        lo = build_types(self.Ft)[0](*[float(c) for c in e.setup.domain_lo])
        wp.launch(box_reset, dim=1, device=e.device, inputs=[self.box, e.n_grid])
        wp.launch(field_box, dim=e.n_material, device=e.device, inputs=[e.x, self.box, lo, self.Ft(e.inv_dx), e.n_grid])

    def label_nodes(self) -> None:
        """Launch the labels of this substep's nodes (after P2G, on the points P2G read): every node cleared to the
        last body's, then each point's body id into its stencil's nodes by ``atomic_min`` (the same on every run).
        One body: nothing launched (every label 0 from the start)."""
        e, d = self.e, self.e.device
        self.box_launch()   # round 65: the step's box (its hull: the labels' and the cpu schedule's lists)
        if self.n_labels == 1:
            return
        sweep = [e.n_grid, self.box, FN.shared_threads(e), int(not d.is_cuda)]
        if not self.per_body:   # one group: round 49's rule
            wp.launch(self.k.label_clear, dim=sweep[2], device=d, inputs=[self.label, 0, *sweep])
            return
        lo = build_types(self.Ft)[0](*[float(c) for c in e.setup.domain_lo])
        wp.launch(self.k.label_clear, dim=sweep[2], device=d, inputs=[self.label, self.n_labels - 1, *sweep])
        wp.launch(self.k.label_points, dim=e.n_material, device=d, inputs=[e.x, e.p_mass, e.body, self.label, lo,
                                                                           self.Ft(e.inv_dx), e.n_grid])

    def solve(self, capturing: bool) -> None:
        """Launch one viscous step (between P2G and the grid update): the schedule's subclass,
        :class:`gasp_warp_mpm.schedule.ordered.CpuViscosity` or :class:`gasp_warp_mpm.schedule.gpu.GpuViscosity`
        (:func:`gasp_warp_mpm.schedule.viscosity_for`). Raises NotImplementedError here."""
        raise NotImplementedError("ImplicitViscosity.solve: use the schedule's subclass (schedule.viscosity_for)")
