"""Round 65: the rigid collider's Coulomb cap per contact pair (rigid body, soft body) (``gasp_core.mpm.rigid_collider``
module notes "The pair's friction", ``docs/rigid.md`` "Round 65: the pair's friction in the collider"), and the
node helpers the collider's kernels share (``rigid_collider.py``; taichi_mpm's ``collider_pair.py`` spells the same).

Which soft body a band node's soft-field mass is of: ``rc_sb`` (int32, 2 n_grid^3: field A's nodes, then B's), -1
at every node (``rc_mark``'s clear), then in ``rc_psum`` (a material point each) every soft point writes its body
at the nodes its stencil weights (``wp.atomic_max``, read first so a node already holding the body takes no atomic;
round 61/62's colouring keeps a field's bodies 3 cells apart, so the writers of a node's field are one body, and
where the colouring shares a field (an odd cycle) the largest body index, deterministically). The pair of a band
node: ``slot * n_cols + cols[rc_sb]`` (``collider_data``'s ``cols``: one column a body with ``PAIR_MU``, else one
column; the two-body pair one column and no write: its one soft body).

``rc_fsum`` (a node each) sums each pair's normal impulse and stuck tangential impulse into ``rc_pacc`` (float64,
``NP`` = 9 a pair: 0 N, 1-3 T, 4 the scale, 5-8 the last substep's 0-3, reading), ``rc_coulomb`` (one thread a pair)
scales each pair's tangential part to at most its ``mu`` times its ``N``, ``rc_apply`` (a node each) applies the
node's normal change and its pair's scaled tangential one and gives the reaction to the slot's body.

This module must not use ``from __future__ import annotations`` (the warp modules' rule).
"""
import functools

import warp as wp

from .precision import MODULE_OPTIONS, build_types
from .rigid_pairs import vec3d

#: The floats of a slot (a rigid body) in ``rc_acc`` (``rigid_collider.py``'s layout).
NA = wp.constant(86)
#: The floats of a pair (rigid body, soft body) in ``rc_pacc`` (the module notes' layout).
NP = wp.constant(9)


@functools.cache
def build_collider_funcs(Ft):
    """``(field_v, node_x, relative, node_change, pair_of)``: the node helpers of the collider's kernels, scalar
    type ``Ft``."""
    vec3 = build_types(Ft)[0]

    @wp.func
    def field_v(grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3), node: int, off: int):
        g = grid_v[node] + grid_dv[off + node]
        return vec3d(wp.float64(g[0]), wp.float64(g[1]), wp.float64(g[2]))

    @wp.func
    def node_x(node: int, n_grid: int, lo: vec3, dx: Ft):
        nn = n_grid * n_grid
        return vec3d(wp.float64(lo[0] + dx * Ft(node / nn)), wp.float64(lo[1] + dx * Ft((node / n_grid) % n_grid)),
                     wp.float64(lo[2] + dx * Ft(node % n_grid)))

    @wp.func
    def relative(grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3), rc_m: wp.array(dtype=vec3),
                 rc_n: wp.array(dtype=vec3), node: int, ra: int, acc: wp.array(dtype=wp.float64), at_v: int,
                 at_w: int, r: vec3d):
        """(u, n): the soft field's velocity less the body's (``acc[at_v:]``, spin ``acc[at_w:]``), the normal."""
        off_s = rc_m.shape[0]   # the soft field: B where the rigid body is A
        if ra == 0:
            off_s = 0
        nq = rc_n[node]
        body = vec3d(acc[at_v], acc[at_v + 1], acc[at_v + 2]) + wp.cross(
            vec3d(acc[at_w], acc[at_w + 1], acc[at_w + 2]), r)
        return field_v(grid_v, grid_dv, node, off_s) - body, vec3d(wp.float64(nq[0]), wp.float64(nq[1]),
                                                                   wp.float64(nq[2]))

    @wp.func
    def node_change(grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3), rc_m: wp.array(dtype=vec3),
                    rc_n: wp.array(dtype=vec3), node: int, ra: int, acc: wp.array(dtype=wp.float64), o: int,
                    r: vec3d):
        """(dv_n, dv_t): a marked node's normal change against the first solve's body and its stuck tangential change
        against the second's (its slot's sums from ``o``)."""
        u, n = relative(grid_v, grid_dv, rc_m, rc_n, node, ra, acc, o + 65, o + 68, r)
        ut2, n2 = relative(grid_v, grid_dv, rc_m, rc_n, node, ra, acc, o + 71, o + 74, r)
        return -wp.dot(u, n) * n, -(ut2 - wp.dot(ut2, n) * n)

    @wp.func
    def pair_of(rc_sb: wp.array(dtype=wp.int32), cols: wp.array(dtype=wp.int32), n_cols: int, node: int, ra: int,
                slot: int):
        """The pair (the rigid body's slot, the soft body's column) of a band node: its soft field's body (``rc_sb``;
        column 0 where none is written: the two-body pair, or one column)."""
        off_s = rc_sb.shape[0] / 2   # the soft field: B where the rigid body is A
        if ra == 0:
            off_s = 0
        sb = rc_sb[off_s + node]
        c = int(0)
        if sb >= 0:
            c = cols[sb]
        return slot * n_cols + c

    return field_v, node_x, relative, node_change, pair_of


@functools.cache
def build_pair(Ft):
    """``(fsum_node, rc_coulomb, apply_node)`` for the scalar type ``Ft`` (module notes): ``rc_fsum``'s and
    ``rc_apply``'s work at one node (``wp.func``; round 69: ``rigid_collider.rc_nodes`` runs them over the box
    sweep) and the pairs' kernel."""
    vec3 = build_types(Ft)[0]
    field_v, node_x, relative, node_change, pair_of = build_collider_funcs(Ft)

    @wp.func
    def fsum_node(node: int, grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3), rc_m: wp.array(dtype=vec3),
                  rc_n: wp.array(dtype=vec3), rc_o: wp.array(dtype=wp.int32), in_a: wp.array(dtype=wp.int32),
                  bodies: wp.array(dtype=wp.int32), centre: wp.array(dtype=vec3d), n_grid: int, lo: vec3, dx: Ft,
                  acc: wp.array(dtype=wp.float64), rc_sb: wp.array(dtype=wp.int32), cols: wp.array(dtype=wp.int32),
                  n_cols: int, pacc: wp.array(dtype=wp.float64)):
        """``rc_fsum`` at ``node``: its pair's normal impulse ``N = sum m dv_n . n`` (0) and its stuck tangential
        one (1-3)."""
        if rc_m[node][2] > Ft(1.5):
            s = rc_o[node]
            o = NA * s
            rb = bodies[s]
            r = node_x(node, n_grid, lo, dx) - centre[rb]
            dvn, dvt = node_change(grid_v, grid_dv, rc_m, rc_n, node, in_a[rb], acc, o, r)
            q = NP * pair_of(rc_sb, cols, n_cols, node, in_a[rb], s)
            m_s = wp.float64(rc_m[node][1])
            nq = rc_n[node]
            wp.atomic_add(pacc, q, m_s * (dvn[0] * wp.float64(nq[0]) + dvn[1] * wp.float64(nq[1])
                                          + dvn[2] * wp.float64(nq[2])))
            for ax in range(3):
                wp.atomic_add(pacc, q + 1 + ax, m_s * dvt[ax])

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rc_coulomb(pacc: wp.array(dtype=wp.float64), mus: wp.array(dtype=wp.float64), friction: wp.float64):
        """One thread a pair: Coulomb's on the pair, its stuck tangential impulse scaled to at most ``mu N`` (4;
        ``mu`` the pair's times ``friction``, 1 but in a broken variant)."""
        o = NP * wp.tid()
        mu = mus[wp.tid()] * friction
        lt = wp.length(vec3d(pacc[o + 1], pacc[o + 2], pacc[o + 3]))
        sc = wp.float64(1.0)
        if lt > mu * wp.max(pacc[o], wp.float64(0.0)):
            sc = mu * wp.max(pacc[o], wp.float64(0.0)) / lt
        pacc[o + 4] = sc
        for q in range(4):
            pacc[o + 5 + q] = pacc[o + q]   # kept for reading
            pacc[o + q] = wp.float64(0.0)

    @wp.func
    def apply_node(node: int, grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3),
                   rc_m: wp.array(dtype=vec3), rc_n: wp.array(dtype=vec3), rc_o: wp.array(dtype=wp.int32),
                   in_a: wp.array(dtype=wp.int32), bodies: wp.array(dtype=wp.int32), centre: wp.array(dtype=vec3d),
                   n_grid: int, lo: vec3, dx: Ft, acc: wp.array(dtype=wp.float64), rc_sb: wp.array(dtype=wp.int32),
                   cols: wp.array(dtype=wp.int32), n_cols: int, pacc: wp.array(dtype=wp.float64),
                   acc_p: wp.array(dtype=vec3d), acc_l: wp.array(dtype=vec3d), react: int):
        """``rc_apply`` at ``node``: if it approaches, the normal change and its pair's scaled tangential one; the
        reaction to its body."""
        if rc_m[node][2] > Ft(1.5):
            s = rc_o[node]
            o = NA * s
            rb = bodies[s]
            ra = in_a[rb]
            x = node_x(node, n_grid, lo, dx)
            dvn, dvt = node_change(grid_v, grid_dv, rc_m, rc_n, node, ra, acc, o, x - centre[rb])
            dv = dvn + pacc[NP * pair_of(rc_sb, cols, n_cols, node, ra, s) + 4] * dvt
            off_s = rc_m.shape[0]
            if ra == 0:
                off_s = 0
            grid_dv[off_s + node] = grid_dv[off_s + node] + vec3(Ft(dv[0]), Ft(dv[1]), Ft(dv[2]))
            m_s = wp.float64(rc_m[node][1])
            J = -m_s * dv
            if react != 0:   # Newton's third law: to the body's projection sums (rigid.py)
                wp.atomic_add(acc_p, rb, J)
                wp.atomic_add(acc_l, rb, wp.cross(x, J))
            for ax in range(3):
                wp.atomic_add(acc, o + 7 + ax, J[ax])
            wp.atomic_add(acc, o + 10, m_s)

    return fsum_node, rc_coulomb, apply_node
