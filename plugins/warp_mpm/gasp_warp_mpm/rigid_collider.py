"""Round 63-64: the rigid body as a moving collider of the soft field (``gasp_core.mpm.rigid_collider``,
``docs/rigid.md`` "Round 63", "Round 64") as Warp kernels; taichi_mpm's ``rigid_collider.py`` spells the same steps;
``collider_launch.py`` records them.

``rc_mark`` (after the first pass ``fields.field_contact``, before the fields' clear; one thread a node) finds the slot
a shared node serves (``owner``: the pair's one body, or round 64's lookup over the slots), gives the node its
fields' own velocities (no exchange) and marks the band's nodes with the rigid body's outward normal and the slot
(``rc_o``); after the grid update ``rc_sum`` (the pair: a node each) or ``rc_psum`` (round 64: a material point each,
its G2P of its field) sums each slot body's momentum and mass, ``rc_body`` (one thread a slot) turns them into
``V*``, ``rc_layer`` / ``rc_solve`` (a node each / a slot each) solve each body with its approaching layer,
``rc_fsum`` / ``rc_coulomb`` / ``rc_apply`` (``collider_pair.py``, round 65: Coulomb's cap per contact pair, the
soft body at a node from ``rc_sb``, which ``rc_mark`` clears and ``rc_psum``'s soft points write) take the soft
field's approach off at the marked nodes and add the reaction to the slot body's projection sums ``acc_p``,
``acc_l``. ``rc_acc`` (float64, ``NA`` = 86 a slot): 0-2 sum m_R v_R, 3 sum m_R, 4-6 V*, 7-9 the substep's reaction J,
10 the approaching soft mass, 11-14 the last substep's 7-10 (reading), 20-61 the 6 x 6 system's sums, 62-76 the spins
and solved bodies (77-85 unused since round 65: the pairs' ``rc_pacc``).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from gasp_core.mpm.fields import MIN_FRACTION, MIN_GRADIENT

from .collider_pair import NA, build_collider_funcs, build_pair
from .field_nodes import build_sweep
from .fields import build_b_normal, build_field_reads
from .face import build_faced
from .precision import MODULE_OPTIONS, build_types
from .rigid_pairs import mat33d, vec3d
from .stencil import build_gather, build_stencil, build_stencil_at
from .touch import build_held



@functools.cache
def build_collider(Ft):
    """``(rc_mark, rc_nodes, rc_body, rc_solve, rc_coulomb, rc_psum)`` for the scalar type ``Ft`` (round 69:
    ``rc_nodes`` runs the node passes ``rc_sum``, ``rc_layer``, ``rc_fsum``, ``rc_apply`` over the box sweep). It is long because the kernels and their helpers are closures of the scalar type."""
    vec3, vec4, mat33 = build_types(Ft)
    held_node = build_held(Ft)
    b_normal = build_b_normal(Ft)
    in_grid, weights = build_stencil(Ft)
    stencil_at = build_stencil_at(Ft)
    field_offset_base, gather = build_field_reads(Ft)[0], build_gather(Ft)
    field_v, node_x, relative = build_collider_funcs(Ft)[:3]
    box_units, unit_first, unit_len, box_q = build_sweep(Ft)

    @wp.func
    def owner(x: vec3d, in_a: wp.array(dtype=wp.int32), bodies: wp.array(dtype=wp.int32), ns: int, multi: int,
              centre: wp.array(dtype=vec3d), rot: wp.array(dtype=mat33d), box: wp.array(dtype=vec3d),
              pad: wp.float64):
        """(slot, d): the rigid body whose band the node may be in and its distance (m) to the body's box in its
        frame (Chebyshev). The pair (multi 0): slot 0. Round 64 (multi 1): the nearest rigid body of each field
        within ``pad`` (``rigid_pairs.node_bodies``); a slot where one field has one and the other none (its mass
        there soft), -1 where both (a rigid pair: ``rigid_pairs``) or neither (soft on soft: the exchange)."""
        sa = int(-1)
        sb = int(-1)
        da = wp.float64(1.0e30)
        db = wp.float64(1.0e30)
        for s in range(ns):
            if multi != 0 or s == 0:
                rb = bodies[s]
                q = wp.transpose(rot[rb]) * (x - centre[rb])
                d = wp.float64(-1.0e30)
                for ax in range(3):
                    d = wp.max(d, wp.max(box[2 * rb][ax] - q[ax], q[ax] - box[2 * rb + 1][ax]))
                if multi == 0 or d <= pad:
                    if in_a[rb] != 0:
                        if d < da:
                            da = d
                            sa = s
                    elif d < db:
                        db = d
                        sb = s
        best = sa
        dbest = da
        if sb >= 0:
            best = sb
            dbest = db
        if sa >= 0 and sb >= 0:
            best = -1
        return best, dbest

    faced = build_faced(Ft)[0]   # round 96 (face.py)

    @wp.func
    def mark_node(node: int, grid_mv: wp.array(dtype=vec4), grid_sv: wp.array(dtype=vec4), grid_vf: wp.array(dtype=Ft),
                  n_grid: int, ground: wp.array(dtype=vec3), cell: Ft, wall_lo: Ft, wall_hi: vec3, touch_frac: Ft,
                  ground_touch: wp.array(dtype=wp.int32), flow_touch: wp.array(dtype=wp.int32), free: int,
                  rc_m: wp.array(dtype=vec3), rc_n: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3),
                  in_a: wp.array(dtype=wp.int32), bodies: wp.array(dtype=wp.int32), ns: int, multi: int, mirror: int,
                  band: wp.float64, lo: vec3, dx: Ft, rc_o: wp.array(dtype=wp.int32), centre: wp.array(dtype=vec3d),
                  rot: wp.array(dtype=mat33d), box: wp.array(dtype=vec3d), pad: wp.float64,
                  rc_sb: wp.array(dtype=wp.int32), rc_pt: wp.array(dtype=wp.int32), band_b: wp.float64, face: Ft):
        """One node of ``rc_mark``: its soft bodies cleared (``rc_sb``), its slot (``rc_o``), its fields' own
        velocities, the band's mark and normal (``rc_m``, ``rc_n``); an empty node's defaults (no mass, no mark,
        slot -1)."""
        nn = n_grid * n_grid
        n_nodes = nn * n_grid
        rc_sb[node] = -1   # round 65: the nodes' soft bodies, written by rc_psum (collider_pair.py)
        rc_sb[n_nodes + node] = -1
        i = node / nn
        j = (node / n_grid) % n_grid
        k = node % n_grid
        m = grid_mv[node][3]
        m_a = grid_sv[node][3]
        m_b = m - m_a
        ra = in_a[bodies[0]]
        m_r = m_b
        if ra != 0:
            m_r = m_a
        if multi != 0:   # round 64: the rigid field's mass only at a node the rule takes (V* from the points)
            m_r = Ft(0.0)
        flag = Ft(0.0)
        nh = vec3(Ft(0.0))
        own = int(-1)
        inner = i > 0 and j > 0 and k > 0 and i < n_grid - 1 and j < n_grid - 1 and k < n_grid - 1
        if inner and m_a > Ft(MIN_FRACTION) * m and m_b > Ft(MIN_FRACTION) * m:
            held = held_node(i, j, k, ground, n_grid, ground_touch, free, vec3(Ft(i), Ft(j), Ft(k)),
                             vec3(wall_lo), wall_hi, 1)
            x = vec3d(wp.float64(lo[0] + dx * Ft(i)), wp.float64(lo[1] + dx * Ft(j)), wp.float64(lo[2] + dx * Ft(k)))
            s, d = owner(x, in_a, bodies, ns, multi, centre, rot, box, pad)
            if held == 0 and s >= 0:   # each field its own velocity: no exchange between them (module notes, step 1)
                own = s
                ra = in_a[bodies[s]]
                m_r = m_b
                if ra != 0:
                    m_r = m_a
                pa = grid_sv[node]
                g = grid_mv[node]
                u = vec3(pa[0], pa[1], pa[2]) / m_a - vec3(g[0] - pa[0], g[1] - pa[1], g[2] - pa[2]) / m_b
                grid_dv[node] = (m_b / m) * u
                grid_dv[n_nodes + node] = -(m_a / m) * u
                touch = bool(False)
                if band <= wp.float64(0.0):   # round 60's touch (an experiment: the slides -99.8 %, module notes)
                    touch = (grid_vf[node] + grid_vf[n_nodes + node]) >= touch_frac * cell
                    if flow_touch.shape[0] > 1:
                        touch = flow_touch[node] != 0
                else:   # the body's shape: within band (m) of its points' box, in its frame
                    reach = band
                    if ra == 0:   # round 96: a rigid field B's band reaches band_b, with the face test below
                        reach = band_b
                    touch = d <= reach and rc_pt[s] == 0   # round 66: not a round body's (point_contact.py)
                # field B's normal (fields.build_b_normal), as grad m_R: into the rigid body (the rigid field's own
                # mass gradient ploughed the slides, -97.7 %: docs/rigid.md "Round 63")
                gr = b_normal(grid_mv, grid_sv, ground, node, n_grid, mirror)
                if ra != 0:
                    gr = -gr
                ln = wp.length(gr)
                if touch and ln > Ft(MIN_GRADIENT) * m and (ra != 0 or faced(grid_sv, node, n_grid, gr, m_b, face)):
                    flag = Ft(1.0)
                    nh = -gr / ln   # out of the rigid body
        rc_m[node] = vec3(m_r, m - m_r, flag)
        rc_n[node] = nh
        rc_o[node] = own

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rc_mark(grid_mv: wp.array(dtype=vec4), grid_sv: wp.array(dtype=vec4), grid_vf: wp.array(dtype=Ft), n_grid: int,
                ground: wp.array(dtype=vec3), cell: Ft, wall_lo: Ft, wall_hi: vec3, touch_frac: Ft,
                ground_touch: wp.array(dtype=wp.int32), flow_touch: wp.array(dtype=wp.int32), free: int,
                rc_m: wp.array(dtype=vec3), rc_n: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3),
                in_a: wp.array(dtype=wp.int32), bodies: wp.array(dtype=wp.int32), ns: int, multi: int, mirror: int,
                band: wp.float64, lo: vec3, dx: Ft, rc_o: wp.array(dtype=wp.int32), centre: wp.array(dtype=vec3d),
                rot: wp.array(dtype=mat33d), boxes: wp.array(dtype=vec3d), pad: wp.float64,
                rc_sb: wp.array(dtype=wp.int32), rc_pt: wp.array(dtype=wp.int32), box: wp.array(dtype=wp.int32),
                threads: int, along: int, band_b: wp.float64, face: Ft):
        """``mark_node`` over the box sweep ``box`` (``field_nodes.build_sweep``; round 68: the hull of the boxes
        P2G touched this substep and the last, not the whole grid: outside it every node holds the empty node's
        defaults, which the last sweep over it wrote, field_nodes' module notes)."""
        n = box_units(box, along)
        run = (n + threads - 1) / threads
        for r in range(run):
            q = box_q(wp.tid(), r, run, threads, along)
            if q < n:
                first = unit_first(box, q, n_grid, along)
                for node in range(first, first + unit_len(box, along)):
                    mark_node(node, grid_mv, grid_sv, grid_vf, n_grid, ground, cell, wall_lo, wall_hi, touch_frac,
                              ground_touch, flow_touch, free, rc_m, rc_n, grid_dv, in_a, bodies, ns, multi, mirror,
                              band, lo, dx, rc_o, centre, rot, boxes, pad, rc_sb, rc_pt, band_b, face)

    @wp.func
    def sum_node(node: int, grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3), rc_m: wp.array(dtype=vec3),
                 ra: int, acc: wp.array(dtype=wp.float64)):
        """``rc_sum`` at ``node``: its rigid field's momentum and mass into the pair's sums (0-3)."""
        m_r = wp.float64(rc_m[node][0])
        if m_r > wp.float64(0.0):
            off = rc_m.shape[0]   # the rigid field's offsets: B's unless it is A
            if ra != 0:
                off = 0
            p = m_r * field_v(grid_v, grid_dv, node, off)
            for ax in range(3):
                wp.atomic_add(acc, ax, p[ax])
            wp.atomic_add(acc, 3, m_r)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rc_body(acc: wp.array(dtype=wp.float64), spin: wp.array(dtype=vec3d), bodies: wp.array(dtype=wp.int32)):
        """One thread a slot (a rigid body): ``V*`` (4-6) from its sums, its spin from its state (62-64)."""
        s = wp.tid()
        o = NA * s
        for q in range(4):   # the last substep's reaction and approaching mass kept at 11-14 (reading)
            acc[o + 11 + q] = acc[o + 7 + q]
            acc[o + 7 + q] = wp.float64(0.0)
        if acc[o + 3] > wp.float64(0.0):
            for ax in range(3):
                acc[o + 4 + ax] = acc[o + ax] / acc[o + 3]
        for ax in range(3):
            acc[o + 62 + ax] = spin[bodies[s]][ax]
        for q in range(4):
            acc[o + q] = wp.float64(0.0)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rc_psum(x: wp.array(dtype=vec3), body: wp.array(dtype=wp.int32), p_mass: wp.array(dtype=Ft),
                grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3), in_a: wp.array(dtype=wp.int32),
                slot: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft, n_grid: int, acc: wp.array(dtype=wp.float64),
                rc_sb: wp.array(dtype=wp.int32)):
        """Round 64: a slot body's ``sum m_p v_p`` and ``sum m_p`` from its points' G2P of its field (what the
        two-body rule's node sums give, each node's rigid mass its body's: a field may hold several bodies). Round
        65: a soft point's body into ``rc_sb`` at the nodes it weights (``collider_pair.py``)."""
        p = wp.tid()
        s = slot[body[p]]
        X = (x[p] - lo) * inv_dx
        if in_grid(X, n_grid):
            W, idx0, fx = stencil_at(X, n_grid)
            off = field_offset_base(grid_dv, in_a, body[p], n_grid * n_grid * n_grid)
            if s < 0:
                for i in range(3):
                    for j in range(3):
                        for k in range(3):
                            at = off + idx0 + (i * n_grid + j) * n_grid + k
                            if W[i, 0] * W[j, 1] * W[k, 2] > Ft(0.0) and rc_sb[at] != body[p]:
                                wp.atomic_max(rc_sb, at, body[p])
            else:
                v, B = gather(grid_v, grid_dv, off, W, idx0, n_grid)
                m = wp.float64(p_mass[p])
                for ax in range(3):
                    wp.atomic_add(acc, NA * s + ax, m * wp.float64(v[ax]))
                wp.atomic_add(acc, NA * s + 3, m)

    @wp.func
    def skew(r: vec3d):
        return mat33d(wp.float64(0.0), -r[2], r[1], r[2], wp.float64(0.0), -r[0], -r[1], r[0], wp.float64(0.0))

    @wp.func
    def add33(acc: wp.array(dtype=wp.float64), at: int, a: mat33d):
        for p in range(3):
            for q in range(3):
                wp.atomic_add(acc, at + 3 * p + q, a[p, q])

    @wp.func
    def get33(acc: wp.array(dtype=wp.float64), at: int):
        return mat33d(acc[at], acc[at + 1], acc[at + 2], acc[at + 3], acc[at + 4], acc[at + 5], acc[at + 6],
                      acc[at + 7], acc[at + 8])

    @wp.func
    def layer_node(node: int, grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3), rc_m: wp.array(dtype=vec3),
                   rc_n: wp.array(dtype=vec3), rc_o: wp.array(dtype=wp.int32), in_a: wp.array(dtype=wp.int32),
                   bodies: wp.array(dtype=wp.int32), centre: wp.array(dtype=vec3d), n_grid: int, lo: vec3, dx: Ft,
                   acc: wp.array(dtype=wp.float64), mode: int):
        """``rc_layer`` at ``node``: mode 0: an approaching node (marked 2) and the normal system against V*; 1: its
        tangential system against the normal solve's body; the node into its slot's sums (``rc_o``)."""
        f = rc_m[node][2]
        if f > Ft(0.0):
            o = NA * rc_o[node]
            rb = bodies[rc_o[node]]
            r = node_x(node, n_grid, lo, dx) - centre[rb]
            u, n = relative(grid_v, grid_dv, rc_m, rc_n, node, in_a[rb], acc, o + 4 + 61 * mode, o + 62 + 6 * mode,
                            r)
            un = wp.dot(u, n)
            m_s = wp.float64(rc_m[node][1])
            P = m_s * wp.outer(n, n)
            b1 = m_s * un * n
            use = mode == 0 and un < wp.float64(0.0)
            if mode == 0 and use:
                rc_m[node] = vec3(rc_m[node][0], rc_m[node][1], Ft(2.0))
            if mode == 1 and f > Ft(1.5):   # the node stuck along the surface (its normal held by the first solve)
                P = m_s * wp.identity(3, wp.float64) - P
                b1 = m_s * u - b1
                use = True
            if use:
                S = skew(r)
                add33(acc, o + 20, P)
                add33(acc, o + 29, -(P * S))
                add33(acc, o + 38, S * P)
                add33(acc, o + 47, -(S * P * S))
                b2 = wp.cross(r, b1)
                for ax in range(3):
                    wp.atomic_add(acc, o + 56 + ax, b1[ax])
                    wp.atomic_add(acc, o + 59 + ax, b2[ax])

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rc_solve(acc: wp.array(dtype=wp.float64), mass: wp.array(dtype=wp.float64),
                 inertia0: wp.array(dtype=mat33d), rot: wp.array(dtype=mat33d), bodies: wp.array(dtype=wp.int32),
                 dx: wp.float64, mode: int, implicit: int):
        """One thread a slot: the body's (dV, dw) from ``A x = b`` (module notes; Schur's complement, the spin
        first): mode 0 from (V*, w) at 4, 62 to 65, 68; mode 1 from there to 71, 74."""
        s = wp.tid()
        o = NA * s
        rb = bodies[s]
        M = mass[rb]
        R = rot[rb]
        eye = wp.identity(3, wp.float64)
        A11 = M * eye + get33(acc, o + 20)
        A12 = get33(acc, o + 29)
        A21 = get33(acc, o + 38)
        A22 = R * inertia0[rb] * wp.transpose(R) + wp.float64(0.5) * dx * dx * M * eye + get33(acc, o + 47)
        b1 = vec3d(acc[o + 56], acc[o + 57], acc[o + 58])
        b2 = vec3d(acc[o + 59], acc[o + 60], acc[o + 61])
        at_v = o + 4 + 61 * mode
        at_w = o + 62 + 6 * mode
        V = vec3d(acc[at_v], acc[at_v + 1], acc[at_v + 2])
        w = vec3d(acc[at_w], acc[at_w + 1], acc[at_w + 2])
        if implicit != 0 and acc[o + 20] + acc[o + 24] + acc[o + 28] > wp.float64(0.0):
            inv11 = wp.inverse(A11)
            dw = wp.inverse(A22 - A21 * inv11 * A12) * (b2 - A21 * (inv11 * b1))
            V = V + inv11 * (b1 - A12 * dw)
            w = w + dw
        for ax in range(3):
            acc[o + 65 + 6 * mode + ax] = V[ax]
            acc[o + 68 + 6 * mode + ax] = w[ax]
        for q in range(42):
            acc[o + 20 + q] = wp.float64(0.0)

    fsum_node, rc_coulomb, apply_node = build_pair(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rc_nodes(grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3), rc_m: wp.array(dtype=vec3),
                 rc_n: wp.array(dtype=vec3), rc_o: wp.array(dtype=wp.int32), in_a: wp.array(dtype=wp.int32),
                 bodies: wp.array(dtype=wp.int32), centre: wp.array(dtype=vec3d), n_grid: int, lo: vec3, dx: Ft,
                 acc: wp.array(dtype=wp.float64), rc_sb: wp.array(dtype=wp.int32), cols: wp.array(dtype=wp.int32),
                 n_cols: int, pacc: wp.array(dtype=wp.float64), acc_p: wp.array(dtype=vec3d),
                 acc_l: wp.array(dtype=vec3d), react: int, ra: int, job: int, box: wp.array(dtype=wp.int32),
                 threads: int, along: int):
        """Round 69: the collider's node passes over the box sweep (as ``rc_mark``: outside it no node is marked and
        none holds rigid mass): ``job`` 0 ``rc_sum``, 1 and 2 ``rc_layer``'s modes 0 and 1, 3 ``rc_fsum``, 4
        ``rc_apply``. On the CPU the nodes in the whole grid's order (the same sums, the same bits)."""
        n = box_units(box, along)
        run = (n + threads - 1) / threads
        for r in range(run):
            q = box_q(wp.tid(), r, run, threads, along)
            if q < n:
                first = unit_first(box, q, n_grid, along)
                for node in range(first, first + unit_len(box, along)):
                    m = rc_m[node]   # the unmarked node skipped here, not by the call (its arguments' copies)
                    if job == 0 and m[0] > Ft(0.0):
                        sum_node(node, grid_v, grid_dv, rc_m, ra, acc)
                    elif job > 0 and job < 3 and m[2] > Ft(0.0):
                        layer_node(node, grid_v, grid_dv, rc_m, rc_n, rc_o, in_a, bodies, centre, n_grid, lo, dx,
                                   acc, job - 1)
                    elif job == 3 and m[2] > Ft(1.5):
                        fsum_node(node, grid_v, grid_dv, rc_m, rc_n, rc_o, in_a, bodies, centre, n_grid, lo, dx,
                                  acc, rc_sb, cols, n_cols, pacc)
                    elif job == 4 and m[2] > Ft(1.5):
                        apply_node(node, grid_v, grid_dv, rc_m, rc_n, rc_o, in_a, bodies, centre, n_grid, lo, dx,
                                   acc, rc_sb, cols, n_cols, pacc, acc_p, acc_l, react)

    return rc_mark, rc_nodes, rc_body, rc_solve, rc_coulomb, rc_psum


#: Deliberately broken variants for the checks (tests/test_soft_on_rigid_rest.py): REACT 0 gives the body no
#: reaction; FRICTION 0 takes the collider frictionless.
REACT = 1
FRICTION = 1.0
IMPLICIT = 1   # the body solved with its layer (the rule); 0: no solve, the reaction explicit (broken: floats)
