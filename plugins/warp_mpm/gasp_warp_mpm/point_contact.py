"""Round 66: the rigid collider's contact of the soft points against the rigid body's shape
(``gasp_core.mpm.rigid_sdf``, switch ``POINT_CONTACT``; ``docs/rigid.md`` "Round 66: the point contact on a ball").

After G2P, one thread a material point (every kernel here but round 63's ``rc_solve`` / ``rc_coulomb``, reused one
thread a slot / pair): ``pc_mark`` finds the slot whose body's signed distance (each slot's lattice, read
trilinearly in its body frame, its centre moved by ``dt V*``) at the soft point is least and below ``SKIN`` cells,
and where the point approaches it adds the point to the slot's normal system (``rc_acc`` 20-61, round 63's layout);
``rc_solve`` mode 0; ``pc_layer`` the approaching points' tangential system; ``rc_solve`` mode 1; ``pc_fsum`` each
pair's normal and stuck tangential impulse into ``pc_pacc`` (round 65's ``NP`` layout); ``rc_coulomb``; ``pc_apply``
each approaching point's change (its velocity, and ``dt`` times it in its position) and the reaction to its slot's
body's projection sums (``acc_p``, ``acc_l``, float64 atomics), read by this substep's rigid projection; ``pc_node`` the
nodes' velocities take the points' changes, divided by each field's node mass ``pc_m`` (kept by ``pc_mass`` after
``rc_mark``, before the grid update and the fields' clear clear ``grid_mv`` and ``grid_sv``: round 66 pcfix).

The lattices of all slots lie in one array (``pc_phi`` float32 distance, ``pc_grad`` its gradient), slot ``s`` at
``pc_dim[4 s + 3]`` with ``pc_dim[4 s: 4 s + 3]`` voxels, origin ``pc_org[s]``, spacing ``pc_h[s]``.

This module must not use ``from __future__ import annotations`` (the warp modules' rule).
"""
import functools

import numpy as np
import warp as wp

from .collider_pair import NA, NP
from .fields import build_field_reads
from .precision import MODULE_OPTIONS, build_types
from .rigid_pairs import mat33d, vec3d
from .sdf_at import build_nearest
from .stencil import build_gather, build_stencil, build_stencil_at


@functools.cache
def build_point_contact(Ft):
    """``(pc_mark, pc_layer, pc_fsum, pc_apply, pc_node)`` for the scalar type ``Ft``. It is long because the
    kernels and their helpers are closures of the scalar type (``rigid_collider.build_collider``'s reason)."""
    vec3, vec4 = build_types(Ft)[:2]
    in_grid, weights = build_stencil(Ft)
    stencil_at = build_stencil_at(Ft)
    field_offset_base, gather = build_field_reads(Ft)[0], build_gather(Ft)
    nearest = build_nearest(Ft)

    @wp.func
    def body_v(acc: wp.array(dtype=wp.float64), at_v: int, at_w: int, r: vec3d):
        return vec3d(acc[at_v], acc[at_v + 1], acc[at_v + 2]) + wp.cross(
            vec3d(acc[at_w], acc[at_w + 1], acc[at_w + 2]), r)

    @wp.func
    def to64(a: vec3):
        return vec3d(wp.float64(a[0]), wp.float64(a[1]), wp.float64(a[2]))

    @wp.func
    def skew(r: vec3d):
        return mat33d(wp.float64(0.0), -r[2], r[1], r[2], wp.float64(0.0), -r[0], -r[1], r[0], wp.float64(0.0))

    @wp.func
    def add_system(acc: wp.array(dtype=wp.float64), o: int, P: mat33d, r: vec3d, b1: vec3d):
        """Round 63's sums of ``A`` and ``b`` (``rigid_collider.rc_layer``'s layout) for one point."""
        S = skew(r)
        A12 = -(P * S)
        A21 = S * P
        A22 = -(S * P * S)
        for p in range(3):
            for q in range(3):
                wp.atomic_add(acc, o + 20 + 3 * p + q, P[p, q])
                wp.atomic_add(acc, o + 29 + 3 * p + q, A12[p, q])
                wp.atomic_add(acc, o + 38 + 3 * p + q, A21[p, q])
                wp.atomic_add(acc, o + 47 + 3 * p + q, A22[p, q])
        b2 = wp.cross(r, b1)
        for ax in range(3):
            wp.atomic_add(acc, o + 56 + ax, b1[ax])
            wp.atomic_add(acc, o + 59 + ax, b2[ax])

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def pc_mark(x: wp.array(dtype=vec3), grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3),
                in_a: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft, n_grid: int, body: wp.array(dtype=wp.int32),
                p_mass: wp.array(dtype=Ft), rigid: wp.array(dtype=wp.int32), bodies: wp.array(dtype=wp.int32),
                ns: int, centre: wp.array(dtype=vec3d), rot: wp.array(dtype=mat33d), acc: wp.array(dtype=wp.float64),
                dt: wp.float64, skin: wp.float64, phi: wp.array(dtype=wp.float32), grad: wp.array(dtype=wp.vec3f),
                org: wp.array(dtype=vec3d), hs: wp.array(dtype=wp.float64), dims: wp.array(dtype=wp.int32),
                pc_s: wp.array(dtype=wp.int32), pc_n: wp.array(dtype=vec3d), pc_x: wp.array(dtype=vec3d),
                pc_v: wp.array(dtype=vec3d), bias: wp.float64, pc_b: wp.array(dtype=wp.float64),
                rc_pt: wp.array(dtype=wp.int32)):
        """A soft point's G2P velocity from its field (``pc_v``) and its position after it (``pc_x``); its slot
        (``pc_s``: -1 none, ``-2 - s`` touching slot ``s`` and not approaching, ``s``
        approaching: into its normal system) and its normal out of the body."""
        p = wp.tid()
        pc_s[p] = -1
        X = (x[p] - lo) * inv_dx
        if rigid[body[p]] == 0 and in_grid(X, n_grid):
            W, idx0, fx = stencil_at(X, n_grid)
            vg, B = gather(grid_v, grid_dv, field_offset_base(grid_dv, in_a, body[p], n_grid * n_grid * n_grid), W,
                           idx0, n_grid)
            vp = to64(vg)
            xp = to64(x[p]) + dt * vp
            pc_v[p] = vp
            pc_x[p] = xp
            # a body with faces (rc_pt 0, round 63's band) has a one-voxel lattice: no contact
            best, sb, nb = nearest(xp, wp.float64(skin), ns, rc_pt, bodies, centre, rot, acc, 1, dt, phi, grad, org,
                                   hs, dims)
            if sb >= 0:
                o = NA * sb
                rb = bodies[sb]
                r = xp - (centre[rb] + dt * vec3d(acc[o + 4], acc[o + 5], acc[o + 6]))
                u = vp - body_v(acc, o + 4, o + 62, r)
                bp = bias * (skin - best) / dt   # the penetration's way out (Baumgarte's; 0 at the skin)
                un = wp.dot(u, nb) - bp
                pc_n[p] = nb
                pc_b[p] = bp
                pc_s[p] = -2 - sb
                if un < wp.float64(0.0):
                    pc_s[p] = sb
                    m = wp.float64(p_mass[p])
                    add_system(acc, o, m * wp.outer(nb, nb), r, m * un * nb)

    @wp.func
    def arm(x: wp.array(dtype=vec3d), p: int, centre: wp.array(dtype=vec3d), rb: int,
            acc: wp.array(dtype=wp.float64), o: int, dt: wp.float64):
        return x[p] - (centre[rb] + dt * vec3d(acc[o + 4], acc[o + 5], acc[o + 6]))

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def pc_layer(x: wp.array(dtype=vec3d), v: wp.array(dtype=vec3d), p_mass: wp.array(dtype=Ft),
                 bodies: wp.array(dtype=wp.int32), centre: wp.array(dtype=vec3d), acc: wp.array(dtype=wp.float64),
                 dt: wp.float64, pc_s: wp.array(dtype=wp.int32), pc_n: wp.array(dtype=vec3d)):
        """The approaching points' tangential system against the normal solve's body (stuck along the surface)."""
        p = wp.tid()
        s = pc_s[p]
        if s >= 0:
            o = NA * s
            r = arm(x, p, centre, bodies[s], acc, o, dt)
            n = pc_n[p]
            u = v[p] - body_v(acc, o + 65, o + 68, r)
            m = wp.float64(p_mass[p])
            P = m * (wp.identity(3, wp.float64) - wp.outer(n, n))
            add_system(acc, o, P, r, m * (u - wp.dot(u, n) * n))

    @wp.func
    def change(x: wp.array(dtype=vec3d), v: wp.array(dtype=vec3d), p: int, centre: wp.array(dtype=vec3d), rb: int,
               acc: wp.array(dtype=wp.float64), o: int, dt: wp.float64, n: vec3d, bp: wp.float64):
        """(dv_n, dv_t, r): the point's normal change against the first solve's body, its stuck tangential change
        against the second's."""
        r = arm(x, p, centre, rb, acc, o, dt)
        u = v[p] - body_v(acc, o + 65, o + 68, r)
        u2 = v[p] - body_v(acc, o + 71, o + 74, r)
        return -(wp.dot(u, n) - bp) * n, -(u2 - wp.dot(u2, n) * n), r

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def pc_fsum(x: wp.array(dtype=vec3d), v: wp.array(dtype=vec3d), body: wp.array(dtype=wp.int32),
                p_mass: wp.array(dtype=Ft), bodies: wp.array(dtype=wp.int32), centre: wp.array(dtype=vec3d),
                acc: wp.array(dtype=wp.float64), dt: wp.float64, pc_s: wp.array(dtype=wp.int32),
                pc_n: wp.array(dtype=vec3d), pc_b: wp.array(dtype=wp.float64), cols: wp.array(dtype=wp.int32),
                n_cols: int,
                pacc: wp.array(dtype=wp.float64)):
        """Each pair's normal impulse (0) and stuck tangential one (1-3), round 65's layout."""
        p = wp.tid()
        s = pc_s[p]
        if s >= 0:
            n = pc_n[p]
            dvn, dvt, r = change(x, v, p, centre, bodies[s], acc, NA * s, dt, n, pc_b[p])
            q = NP * (s * n_cols + cols[body[p]])
            m = wp.float64(p_mass[p])
            wp.atomic_add(pacc, q, m * wp.dot(dvn, n))
            for ax in range(3):
                wp.atomic_add(pacc, q + 1 + ax, m * dvt[ax])

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def pc_apply(x: wp.array(dtype=vec3d), v: wp.array(dtype=vec3d), body: wp.array(dtype=wp.int32),
                 p_mass: wp.array(dtype=Ft), bodies: wp.array(dtype=wp.int32), centre: wp.array(dtype=vec3d),
                 acc: wp.array(dtype=wp.float64), dt: wp.float64, pc_s: wp.array(dtype=wp.int32),
                 pc_n: wp.array(dtype=vec3d), pc_b: wp.array(dtype=wp.float64), cols: wp.array(dtype=wp.int32),
                n_cols: int,
                 pacc: wp.array(dtype=wp.float64), acc_p: wp.array(dtype=vec3d), acc_l: wp.array(dtype=vec3d),
                 react: int, cap: int, x0: wp.array(dtype=vec3), in_a: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft,
                 n_grid: int, pc_g: wp.array(dtype=vec3d)):
        """Each approaching point's change of momentum to its field's nodes by its weights (``pc_g``, float64
        atomics; the nodes' velocities take it in ``pc_node``, so G2P gives the points their change and its
        gradient), the reaction to its body."""
        p = wp.tid()
        s = pc_s[p]
        if s >= 0:
            rb = bodies[s]
            n = pc_n[p]
            dvn, dvt, r = change(x, v, p, centre, rb, acc, NA * s, dt, n, pc_b[p])
            sc = pacc[NP * (s * n_cols + cols[body[p]]) + 4]
            if cap == 0:   # a broken variant: no Coulomb cap
                sc = wp.float64(1.0)
            J = -wp.float64(p_mass[p]) * (dvn + sc * dvt)
            X = (x0[p] - lo) * inv_dx
            W, idx0, fx = stencil_at(X, n_grid)
            off = n_grid * n_grid * n_grid   # the point's field: B unless its body is A's
            if in_a[body[p]] != 0:
                off = 0
            for i in range(3):
                for j in range(3):
                    for k in range(3):
                        w = wp.float64(W[i, 0] * W[j, 1] * W[k, 2])
                        wp.atomic_add(pc_g, off + idx0 + (i * n_grid + j) * n_grid + k, -w * J)
            if react != 0:
                wp.atomic_add(acc_p, rb, J)
                wp.atomic_add(acc_l, rb, wp.cross(centre[rb] + r, J))   # the arm from the moved centre

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def pc_node(pc_g: wp.array(dtype=vec3d), grid_dv: wp.array(dtype=vec3), pc_m: wp.array(dtype=Ft), soft: int):
        """A node's two fields' velocities take the points' momentum changes (``pc_g``, cleared here), each divided
        by its field's node mass as P2G gave it (``pc_m``, kept by ``pc_mass`` before the grid update clears
        ``grid_mv`` and the fields' clear ``grid_sv``). ``soft`` 0: a broken variant, the change dropped."""
        node = wp.tid()
        n = pc_m.shape[0] / 2
        for f in range(2):
            g = pc_g[f * n + node]
            if g[0] != wp.float64(0.0) or g[1] != wp.float64(0.0) or g[2] != wp.float64(0.0):
                m = pc_m[f * n + node]
                if m > Ft(0.0) and soft != 0:
                    grid_dv[f * n + node] = grid_dv[f * n + node] + vec3(Ft(g[0] / wp.float64(m)),
                                                                         Ft(g[1] / wp.float64(m)),
                                                                         Ft(g[2] / wp.float64(m)))
                pc_g[f * n + node] = vec3d(wp.float64(0.0))

    return pc_mark, pc_layer, pc_fsum, pc_apply, pc_node


@functools.cache
def build_pc_mass(Ft):
    """``pc_mass(grid_mv, grid_sv, pc_m)``: each node's field masses (A's at ``node``, B's at ``n_nodes + node``)
    kept after the fields' first pass (``collider_launch.with_mark``), for ``pc_node`` after the grid update."""
    vec4 = build_types(Ft)[1]

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def pc_mass(grid_mv: wp.array(dtype=vec4), grid_sv: wp.array(dtype=vec4), pc_m: wp.array(dtype=Ft)):
        node = wp.tid()
        m_a = grid_sv[node][3]
        pc_m[node] = m_a
        pc_m[grid_mv.shape[0] + node] = grid_mv[node][3] - m_a

    return pc_mass


def mass_launch(eng, Ft):
    """The recorded ``pc_mass`` (:func:`build_pc_mass`)."""
    return wp.launch(build_pc_mass(Ft), dim=eng.n_grid ** 3, device=eng.device, record_cmd=True, inputs=[
        eng.grid_mv, eng.grid_sv, eng.pc_m])


def allocate_points(eng) -> None:
    """Each slot's lattice (``gasp_core.mpm.rigid_sdf.point_data``, read with the collider's data) and the points'
    marks."""
    pts, d = eng.rc_points, eng.device
    eng.pc_phi = wp.array(pts["phi"], dtype=wp.float32, device=d)
    eng.pc_grad = wp.array(pts["grad"], dtype=wp.vec3f, device=d)
    eng.pc_org = wp.array(pts["origin"], dtype=vec3d, device=d)
    eng.pc_h = wp.array(pts["h"], dtype=wp.float64, device=d)
    eng.pc_dim = wp.array(pts["dims"], dtype=wp.int32, device=d)
    eng.pc_s = wp.zeros(eng.n_material, dtype=wp.int32, device=d)
    eng.pc_n = wp.zeros(eng.n_material, dtype=vec3d, device=d)
    eng.pc_b = wp.zeros(eng.n_material, dtype=wp.float64, device=d)
    eng.pc_x = wp.zeros(eng.n_material, dtype=vec3d, device=d)
    eng.pc_v = wp.zeros(eng.n_material, dtype=vec3d, device=d)
    eng.pc_g = wp.zeros(2 * eng.n_grid ** 3, dtype=vec3d, device=d)
    eng.pc_m = wp.zeros(2 * eng.n_grid ** 3, dtype=eng.p_mass.dtype, device=d)
    eng.pc_pacc = wp.zeros(int(NP) * eng.rc_ns * eng.rc_ncol, dtype=wp.float64, device=d)


def point_launches(eng, Ft, c_solve, c_coulomb) -> list:
    """The recorded point contact after the grid update, before G2P (module notes); ``c_solve``, ``c_coulomb``:
    round 63's kernels."""
    from gasp_core.mpm import rigid_sdf
    from gasp_core.mpm.rigid import affine_dx
    from . import rigid_collider as rc
    allocate_points(eng)
    mark, layer, fsum, apply, node = build_point_contact(Ft)
    d, n, ns, dt = eng.device, eng.n_material, eng.rc_ns, float(eng.dt)
    lo = eng.k.vec3(*[float(c) for c in eng.setup.domain_lo])
    geo = [eng.rc_bodies, eng.rb_c, eng.rc_acc, dt, eng.pc_s, eng.pc_n]
    solve = [eng.rc_acc, eng.rb_M, eng.rb_I0, eng.rb_R, eng.rc_bodies, affine_dx(eng.dx)]   # round 67: own I
    pairs = [eng.pc_b, eng.rc_cols, eng.rc_ncol, eng.pc_pacc]
    return [
        wp.launch(mark, dim=n, device=d, record_cmd=True, inputs=[
            eng.x, eng.grid_v, eng.grid_dv, eng.in_a, lo, Ft(eng.inv_dx), eng.n_grid, eng.body, eng.p_mass,
            eng.rb_rigid, eng.rc_bodies, ns, eng.rb_c, eng.rb_R, eng.rc_acc, dt, float(rigid_sdf.SKIN * eng.dx),
            eng.pc_phi, eng.pc_grad, eng.pc_org, eng.pc_h, eng.pc_dim, eng.pc_s, eng.pc_n, eng.pc_x, eng.pc_v,
            float(rigid_sdf.BIAS), eng.pc_b, eng.rc_pt]),
        wp.launch(c_solve, dim=ns, device=d, record_cmd=True, inputs=[*solve, 0, rc.IMPLICIT]),
        wp.launch(layer, dim=n, device=d, record_cmd=True, inputs=[eng.pc_x, eng.pc_v, eng.p_mass, *geo]),
        wp.launch(c_solve, dim=ns, device=d, record_cmd=True, inputs=[*solve, 1, rc.IMPLICIT]),
        wp.launch(fsum, dim=n, device=d, record_cmd=True, inputs=[eng.pc_x, eng.pc_v, eng.body, eng.p_mass, *geo,
                                                                  *pairs]),
        wp.launch(c_coulomb, dim=ns * eng.rc_ncol, device=d, record_cmd=True, inputs=[
            eng.pc_pacc, eng.rc_mus, float(rc.FRICTION)]),
        wp.launch(apply, dim=n, device=d, record_cmd=True, inputs=[
            eng.pc_x, eng.pc_v, eng.body, eng.p_mass, *geo, *pairs, eng.acc_p, eng.acc_l,
            rc.REACT * int(rigid_sdf.REACT_POINTS), int(rigid_sdf.FRICTION_CAP), eng.x, eng.in_a, lo,
            Ft(eng.inv_dx), eng.n_grid, eng.pc_g]),
        wp.launch(node, dim=eng.n_grid ** 3, device=d, record_cmd=True, inputs=[
            eng.pc_g, eng.grid_dv, eng.pc_m, int(rigid_sdf.SOFT_SIDE)])]
