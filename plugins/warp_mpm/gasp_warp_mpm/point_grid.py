"""Round 67: the point contact as a constraint of the grid velocities (``gasp_core.mpm.rigid_sdf.GRID_PASSES`` > 0;
``docs/rigid.md`` "Round 67: the point contact as a constraint of the grid").

Round 66's point contact (``point_contact.py``) gave each touching soft point the change that stops its approach,
then spread it over the point's nodes, whose other points dilute it: after G2P the point still approached (the
contact's dashpot part) and the soft body crept through a ball under it. Here the touching points' impulses
``lambda_p`` are solved against the grid: a few Jacobi passes of *gather* (each touching point's velocity from its
field's nodes, as G2P will give it), *residual* (its approach against the body's current velocity, less the way out)
and *scatter* (the change of its impulse to its nodes by its weights and the opposite to the body), each point's step
divided by a row-sum bound of the system's response (``S_p``: the grid's ``sum_i w_ip T_i / m_i``, ``T_i`` the
touching points' weights at node ``i``, plus the body's ``N_t / M`` and its spin's bound), so a pass never overshoots
and a uniform patch is solved in one. ``lambda_n >= 0`` accumulated (a point pulled back lets go), the tangential
impulse capped per point at ``mu lambda_n`` (Coulomb's). The contact is speculative: a point ``d = phi - SKIN dx``
outside may approach by ``d / dt`` (it closes the gap within the substep), one inside leaves at ``BIAS |d| / dt``.

Kernels, one thread a point (``pg_mark``, ``pg_pre``, ``pg_pass``), a node (``pg_node``) or a slot (``pg_body``);
float64 atomics, no ordered loop. Slot data ``pg_sl`` (float64, ``NS`` a slot): 0-2 the body's impulse from the
points this substep, 3-5 its moment about the body's centre, 6 the touching points' count, 7 ``sum |r x n|``, 8
``sum |r|``, 10-12 the body's velocity, 13-15 its spin, 16-24 its inverse inertia, 25 its max-row-sum norm.

This module must not use ``from __future__ import annotations`` (the warp modules' rule).
"""
import functools

import numpy as np
import warp as wp

from .collider_pair import NA
from .fields import build_field_reads
from .precision import MODULE_OPTIONS, build_types
from .rigid_pairs import mat33d, vec3d
from .roll_shape import cyl_near, cyl_rot, cyl_take, patch_tangents, sph_take
from .sdf_at import build_nearest, build_sdf_at
from .stencil import build_gather, build_stencil, build_stencil_at

#: The floats of a slot in ``pg_sl``.
NS = wp.constant(32)


@functools.cache
def build_point_grid(Ft):
    """``(pg_body, pg_mark, pg_pre, pg_pass, pg_node)`` for the scalar type ``Ft``. It is long because the kernels
    and their helpers are closures of the scalar type (``rigid_collider.build_collider``'s reason)."""
    vec3 = build_types(Ft)[0]
    in_grid, weights = build_stencil(Ft)
    stencil_at = build_stencil_at(Ft)
    field_offset_base, gather = build_field_reads(Ft)[0], build_gather(Ft)
    sdf_at = build_sdf_at(Ft)
    nearest = build_nearest(Ft)

    @wp.func
    def to64(a: vec3):
        return vec3d(wp.float64(a[0]), wp.float64(a[1]), wp.float64(a[2]))

    @wp.func
    def absv(a: vec3d):
        return vec3d(wp.abs(a[0]), wp.abs(a[1]), wp.abs(a[2]))

    @wp.func
    def slot_v(sl: wp.array(dtype=wp.float64), o: int, r: vec3d):
        return vec3d(sl[o + 10], sl[o + 11], sl[o + 12]) + wp.cross(vec3d(sl[o + 13], sl[o + 14], sl[o + 15]), r)

    @wp.func
    def w1(f: Ft, i: int):
        r = Ft(0.5) * (Ft(1.5) - f) * (Ft(1.5) - f)
        if i == 1:
            r = Ft(0.75) - (f - Ft(1.0)) * (f - Ft(1.0))
        if i == 2:
            r = Ft(0.5) * (f - Ft(0.5)) * (f - Ft(0.5))
        return r

    @wp.func
    def dw1(f: Ft, i: int):
        r = -(Ft(1.5) - f)
        if i == 1:
            r = Ft(-2.0) * (f - Ft(1.0))
        if i == 2:
            r = f - Ft(0.5)
        return r

    @wp.func
    def soft_normal(pc_m: wp.array(dtype=Ft), off: int, idx0: int, f: vec3, n_grid: int):
        """The point's field's outward surface normal: minus its node masses' gradient at the point (0 if none)."""
        g = vec3d(wp.float64(0.0))
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    m = wp.float64(pc_m[off + idx0 + (i * n_grid + j) * n_grid + k])
                    g = g + m * vec3d(wp.float64(dw1(f[0], i) * w1(f[1], j) * w1(f[2], k)),
                                      wp.float64(w1(f[0], i) * dw1(f[1], j) * w1(f[2], k)),
                                      wp.float64(w1(f[0], i) * w1(f[1], j) * dw1(f[2], k)))
        if wp.length(g) > wp.float64(0.0):
            g = -wp.normalize(g)
        return g

    @wp.func
    def patch_least(xr: vec3d, m: vec3d, patch: wp.float64, R: mat33d, s: int, best: wp.float64, nb: vec3d,
                    phi: wp.array(dtype=wp.float32), grad: wp.array(dtype=wp.vec3f), org: wp.array(dtype=vec3d),
                    hs: wp.array(dtype=wp.float64), dims: wp.array(dtype=wp.int32)):
        """(distance, normal, offset): the point (at ``xr`` from the body's centre) as its patch of the soft body's
        surface (half-size ``patch``, normal ``m``): the body's least distance over it (5 x 5 reads), so a lattice
        of points reads as a flat face; ``best``, ``nb`` and no offset where the point's own is least."""
        t1, t2 = patch_tangents(m)
        dlt = vec3d(wp.float64(0.0))
        for a in range(5):
            for c in range(5):
                q = (wp.float64(a - 2) * t1 + wp.float64(c - 2) * t2) * (patch * wp.float64(0.5))
                d, g = sdf_at(wp.transpose(R) * (xr + q), s, phi, grad, org, hs, dims)
                if d < best and wp.length(g) > wp.float64(0.0):
                    best = d
                    nb = wp.normalize(R * g)
                    dlt = q
        return best, nb, dlt

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def pg_body(sl: wp.array(dtype=wp.float64), acc: wp.array(dtype=wp.float64), mass: wp.array(dtype=wp.float64),
                inertia0: wp.array(dtype=mat33d), rot: wp.array(dtype=mat33d), bodies: wp.array(dtype=wp.int32),
                dx: wp.float64, init: int):
        """One thread a slot: init 1 clears the sums and takes ``V*`` and the spin (``rc_acc`` 4-6, 62-64) and the
        inverse inertia (round 63's ``rc_solve``'s: ``dx`` is ``rigid.affine_dx``, 0 since round 67's own inertia);
        else the body's velocity from them and the points' impulses so far."""
        s = wp.tid()
        o = NS * s
        oa = NA * s
        rb = bodies[s]
        M = mass[rb]
        if init != 0:
            R = rot[rb]
            Ii = wp.inverse(R * inertia0[rb] * wp.transpose(R) + wp.float64(0.5) * dx * dx * M *
                            wp.identity(3, wp.float64))
            nrm = wp.float64(0.0)
            for a in range(3):
                row = wp.float64(0.0)
                for b in range(3):
                    sl[o + 16 + 3 * a + b] = Ii[a, b]
                    row = row + wp.abs(Ii[a, b])
                nrm = wp.max(nrm, row)
            sl[o + 25] = nrm
            for q in range(10):
                sl[o + q] = wp.float64(0.0)
        Ii = mat33d(sl[o + 16], sl[o + 17], sl[o + 18], sl[o + 19], sl[o + 20], sl[o + 21], sl[o + 22], sl[o + 23],
                    sl[o + 24])
        dw = Ii * vec3d(sl[o + 3], sl[o + 4], sl[o + 5])
        for ax in range(3):
            sl[o + 10 + ax] = acc[oa + 4 + ax] + sl[o + ax] / M
            sl[o + 13 + ax] = acc[oa + 62 + ax] + dw[ax]

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def pg_mark(x: wp.array(dtype=vec3), grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3),
                in_a: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft, n_grid: int, body: wp.array(dtype=wp.int32),
                rigid: wp.array(dtype=wp.int32), bodies: wp.array(dtype=wp.int32), ns: int,
                centre: wp.array(dtype=vec3d), rot: wp.array(dtype=mat33d), dt: wp.float64, skin: wp.float64,
                bias: wp.float64, phi: wp.array(dtype=wp.float32), grad: wp.array(dtype=wp.vec3f),
                org: wp.array(dtype=vec3d), hs: wp.array(dtype=wp.float64), dims: wp.array(dtype=wp.int32),
                rc_pt: wp.array(dtype=wp.int32), sl: wp.array(dtype=wp.float64), pc_s: wp.array(dtype=wp.int32),
                pc_n: wp.array(dtype=vec3d), pc_b: wp.array(dtype=wp.float64), ln: wp.array(dtype=wp.float64),
                lt: wp.array(dtype=vec3d), tw: wp.array(dtype=wp.float64), soft_c: wp.array(dtype=wp.float64),
                pc_m: wp.array(dtype=Ft), patch: wp.float64, pc_x: wp.array(dtype=vec3d),
                sph: wp.array(dtype=wp.float64), sarm: int, cyl: wp.array(dtype=wp.float64), sweeps: int, turn: int,
                dom: int):
        """A soft point's slot (``pc_s``: -1 none; the slot whose body's distance at it is least) where it is within
        the skin by the substep's end at its G2P velocity (linearly: ``phi + dt u_n < SKIN dx``), its normal, its
        target ``b`` (``u_n >= b``), its impulses cleared; its weights into ``tw`` (its field's nodes) and its arm
        into the slot's bounds."""
        p = wp.tid()
        pc_s[p] = -1
        X = (x[p] - lo) * inv_dx
        if rigid[body[p]] == 0 and in_grid(X, n_grid):
            W, idx0, fx = stencil_at(X, n_grid)
            off = field_offset_base(grid_dv, in_a, body[p], n_grid * n_grid * n_grid)
            xp = to64(x[p])
            best, sb, nb = nearest(xp, wp.float64(1.0e30), ns, rc_pt, bodies, centre, rot, sl, 0, dt, phi, grad, org,
                                   hs, dims)
            dlt = vec3d(wp.float64(0.0))
            if sb >= 0 and patch > wp.float64(0.0) and best < skin + wp.float64(2.0) * patch:
                m = soft_normal(pc_m, off, idx0, fx, n_grid)
                if wp.length(m) > wp.float64(0.0):
                    rb = bodies[sb]
                    best, nb, dlt = patch_least(xp - centre[rb], m, patch, rot[rb], sb, best, nb, phi, grad, org, hs,
                                                dims)
            for s in range(ns):   # round 70 (roll_contact): a sphere's exact patch distance (roll_contact.py)
                c = centre[bodies[s]]   # a point farther than the skin, its patch and a cell (4 patches) cannot touch
                if rc_pt[s] != 0 and sph[s] > wp.float64(0.0) and wp.length(xp - c) < sph[s] + skin + wp.float64(
                        6.0) * patch:
                    m = vec3d(wp.float64(0.0))
                    if dom == 0:   # the broken variant's patch normal (round 83: DOMAIN 0)
                        m = soft_normal(pc_m, off, idx0, fx, n_grid)
                    best, sb, nb, dlt = sph_take(xp, m, dom, patch, c, sph[s], s, sweeps, sarm, best, sb, nb, dlt)
                if rc_pt[s] != 0 and cyl_near(xp, c, cyl, s, skin, patch):   # round 72: a cylinder's (roll_shape.py)
                    m = vec3d(wp.float64(0.0))
                    if dom == 0:
                        m = soft_normal(pc_m, off, idx0, fx, n_grid)
                    best, sb, nb, dlt = cyl_take(xp, m, patch, c, cyl_rot(rot[bodies[s]], turn), cyl, s, sweeps, sarm,
                                                 best, sb, nb, dlt, dom)
            pc_x[p] = dlt
            if sb >= 0:
                vg, B = gather(grid_v, grid_dv, off, W, idx0, n_grid)
                o = NS * sb
                r = xp + dlt - centre[bodies[sb]]
                un = wp.dot(to64(vg) - slot_v(sl, o, r), nb)
                gap = best - skin
                if gap + dt * wp.min(un, wp.float64(0.0)) < wp.float64(0.0):
                    pc_s[p] = sb
                    pc_n[p] = nb
                    bp = -gap / dt   # the gap closed within the substep (a compliant contact: its spring's)
                    if gap < wp.float64(0.0) and soft_c[body[p]] == wp.float64(0.0):
                        bp = -bias * gap / dt   # the way out of a penetration
                    pc_b[p] = bp
                    ln[p] = wp.float64(0.0)
                    lt[p] = vec3d(wp.float64(0.0))
                    for i in range(3):
                        for j in range(3):
                            for k in range(3):
                                w = wp.float64(W[i, 0] * W[j, 1] * W[k, 2])
                                wp.atomic_add(tw, off + idx0 + (i * n_grid + j) * n_grid + k, w)
                    wp.atomic_add(sl, o + 6, wp.float64(1.0))
                    wp.atomic_add(sl, o + 7, wp.length(wp.cross(r, nb)))
                    wp.atomic_add(sl, o + 8, wp.length(r))

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def pg_pre(x: wp.array(dtype=vec3), in_a: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft, n_grid: int,
               body: wp.array(dtype=wp.int32), bodies: wp.array(dtype=wp.int32), centre: wp.array(dtype=vec3d),
               mass: wp.array(dtype=wp.float64), sl: wp.array(dtype=wp.float64), pc_s: wp.array(dtype=wp.int32),
               pc_n: wp.array(dtype=vec3d), tw: wp.array(dtype=wp.float64), pc_m: wp.array(dtype=Ft),
               S: wp.array(dtype=wp.float64), grid_dv: wp.array(dtype=vec3), pc_x: wp.array(dtype=vec3d)):
        """Each touching point's row-sum bounds of the response (``S``: 2 p the normal's, 2 p + 1 the tangent's)."""
        p = wp.tid()
        s = pc_s[p]
        if s >= 0:
            X = (x[p] - lo) * inv_dx
            W, idx0, fx = stencil_at(X, n_grid)
            off = field_offset_base(grid_dv, in_a, body[p], n_grid * n_grid * n_grid)
            g = wp.float64(0.0)
            for i in range(3):
                for j in range(3):
                    for k in range(3):
                        at = off + idx0 + (i * n_grid + j) * n_grid + k
                        m = wp.float64(pc_m[at])
                        if m > wp.float64(0.0):
                            g = g + wp.float64(W[i, 0] * W[j, 1] * W[k, 2]) * tw[at] / m
            o = NS * s
            r = to64(x[p]) + pc_x[p] - centre[bodies[s]]
            lin = sl[o + 6] / mass[bodies[s]]
            S[2 * p] = g + lin + wp.length(wp.cross(r, pc_n[p])) * sl[o + 25] * sl[o + 7]
            S[2 * p + 1] = g + lin + wp.length(r) * sl[o + 25] * sl[o + 8]

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def pg_pass(x: wp.array(dtype=vec3), grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3),
                in_a: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft, n_grid: int, body: wp.array(dtype=wp.int32),
                bodies: wp.array(dtype=wp.int32), centre: wp.array(dtype=vec3d), sl: wp.array(dtype=wp.float64),
                pc_s: wp.array(dtype=wp.int32), pc_n: wp.array(dtype=vec3d), pc_b: wp.array(dtype=wp.float64),
                ln: wp.array(dtype=wp.float64), lt: wp.array(dtype=vec3d), S: wp.array(dtype=wp.float64),
                cols: wp.array(dtype=wp.int32), n_cols: int, mus: wp.array(dtype=wp.float64), fric: wp.float64,
                cap: int, react: int, pc_g: wp.array(dtype=vec3d), acc_p: wp.array(dtype=vec3d),
                acc_l: wp.array(dtype=vec3d), soft_c: wp.array(dtype=wp.float64), dt: wp.float64,
                pc_x: wp.array(dtype=vec3d)):
        """One Jacobi pass for a touching point: its velocity from its field's nodes (gather), its residual against
        the body's current velocity, its impulses' step (``lambda_n >= 0``, the tangent's capped at ``mu
        lambda_n``), the step to its nodes (``pc_g``, by its weights) and the opposite to the body (the slot's sums
        and the projection's ``acc_p``, ``acc_l``)."""
        p = wp.tid()
        s = pc_s[p]
        if s >= 0:
            X = (x[p] - lo) * inv_dx
            W, idx0, fx = stencil_at(X, n_grid)
            off = field_offset_base(grid_dv, in_a, body[p], n_grid * n_grid * n_grid)
            vg, B = gather(grid_v, grid_dv, off, W, idx0, n_grid)
            o = NS * s
            rb = bodies[s]
            r = to64(x[p]) + pc_x[p] - centre[rb]
            n = pc_n[p]
            u = to64(vg) - slot_v(sl, o, r)
            un = wp.dot(u, n)
            l0 = ln[p]
            c = soft_c[body[p]] / (dt * dt)   # 1 / (k dt^2), k the point's own stiffness (0: hard)
            l1 = wp.max(l0 - (un - pc_b[p] + c * l0) / (S[2 * p] + c), wp.float64(0.0))
            t0 = lt[p]
            t1 = t0 - (u - un * n) / S[2 * p + 1]
            mu = fric * mus[s * n_cols + cols[body[p]]]
            tl = wp.length(t1)
            if cap != 0 and tl > mu * l1:
                if tl > wp.float64(0.0):
                    t1 = t1 * (mu * l1 / tl)
            ln[p] = l1
            lt[p] = t1
            D = (l1 - l0) * n + (t1 - t0)   # the point's impulse step (kg m/s)
            for i in range(3):
                for j in range(3):
                    for k in range(3):
                        w = wp.float64(W[i, 0] * W[j, 1] * W[k, 2])
                        wp.atomic_add(pc_g, off + idx0 + (i * n_grid + j) * n_grid + k, w * D)
            if react != 0:
                L = wp.cross(r, -D)
                for ax in range(3):
                    wp.atomic_add(sl, o + ax, -D[ax])
                    wp.atomic_add(sl, o + 3 + ax, L[ax])
                wp.atomic_add(acc_p, rb, -D)
                wp.atomic_add(acc_l, rb, wp.cross(to64(x[p]) + pc_x[p], -D))

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def pg_node(pc_g: wp.array(dtype=vec3d), grid_dv: wp.array(dtype=vec3), pc_m: wp.array(dtype=Ft),
                tw: wp.array(dtype=wp.float64), soft: int):
        """A node's two fields' velocities take the pass's impulse steps (``pc_g``, cleared here) over each field's
        node mass from P2G (``pc_m``); ``tw`` cleared for the next substep. ``soft`` 0: a broken variant, dropped."""
        node = wp.tid()
        n = pc_m.shape[0] / 2
        for f in range(2):
            at = f * n + node
            g = pc_g[at]
            m = pc_m[at]
            if m > Ft(0.0) and soft != 0:
                grid_dv[at] = grid_dv[at] + vec3(Ft(g[0] / wp.float64(m)), Ft(g[1] / wp.float64(m)),
                                                 Ft(g[2] / wp.float64(m)))
            pc_g[at] = vec3d(wp.float64(0.0))
            tw[at] = wp.float64(0.0)

    return pg_body, pg_mark, pg_pre, pg_pass, pg_node


def grid_launches(eng, Ft, passes: int, patch: float | None = None, fric: float | None = None) -> list:
    """The recorded contact (module notes) after the grid update and ``V*``, before G2P: ``passes`` Jacobi passes
    (round 70, ``roll_grid.py``: ``patch`` cells and the friction ``fric`` its, else ``rigid_sdf``'s)."""
    from gasp_core.mpm import rigid_sdf
    import gasp_core.mpm.roll_contact as roll
    from gasp_core.mpm.rigid import affine_dx
    from . import rigid_collider as rc
    from .point_contact import allocate_points
    allocate_points(eng)
    patch = rigid_sdf.PATCH if patch is None else patch
    fric = rc.FRICTION if fric is None else fric
    eng.pg_sph = wp.array(np.asarray(eng.rc_points.get("sphere", np.zeros(eng.rc_ns)), np.float64),
                          dtype=wp.float64, device=eng.device)
    eng.pg_cyl = wp.array(np.asarray(eng.rc_points.get("cylinder", np.zeros((eng.rc_ns, 5))), np.float64).reshape(-1),
                          dtype=wp.float64, device=eng.device)   # round 72 (roll_shape.py)
    n, d, ns, ng = eng.n_material, eng.device, eng.rc_ns, eng.n_grid
    eng.pg_sl = wp.zeros(int(NS) * ns, dtype=wp.float64, device=d)
    eng.pg_ln = wp.zeros(n, dtype=wp.float64, device=d)
    eng.pg_lt = wp.zeros(n, dtype=vec3d, device=d)
    eng.pg_S = wp.zeros(2 * n, dtype=wp.float64, device=d)
    eng.pg_tw = wp.zeros(2 * ng ** 3, dtype=wp.float64, device=d)
    eng.pg_c = wp.array(np.asarray(eng.rc_points["comp"], np.float64), dtype=wp.float64, device=d)
    body, mark, pre, step, node = build_point_grid(Ft)
    lo = eng.k.vec3(*[float(c) for c in eng.setup.domain_lo])
    dt = float(eng.dt)
    at = [eng.x, eng.grid_v, eng.grid_dv, eng.in_a, lo, Ft(eng.inv_dx), ng, eng.body]
    bod = [eng.pg_sl, eng.rc_acc, eng.rb_M, eng.rb_I0, eng.rb_R, eng.rc_bodies, affine_dx(eng.dx)]   # own I
    out = [
        wp.launch(body, dim=ns, device=d, record_cmd=True, inputs=[*bod, 1]),
        wp.launch(mark, dim=n, device=d, record_cmd=True, inputs=[
            *at, eng.rb_rigid, eng.rc_bodies, ns, eng.rb_c, eng.rb_R, dt, float(rigid_sdf.SKIN * eng.dx),
            float(rigid_sdf.BIAS), eng.pc_phi, eng.pc_grad, eng.pc_org, eng.pc_h, eng.pc_dim, eng.rc_pt, eng.pg_sl,
            eng.pc_s, eng.pc_n, eng.pc_b, eng.pg_ln, eng.pg_lt, eng.pg_tw, eng.pg_c, eng.pc_m,
            float(patch * eng.dx), eng.pc_x, eng.pg_sph, int(roll.SURFACE_ARM), eng.pg_cyl, int(roll.CYL_SWEEPS),
            int(roll.CYL_TURN), int(roll.DOMAIN)]),
        wp.launch(pre, dim=n, device=d, record_cmd=True, inputs=[
            eng.x, eng.in_a, lo, Ft(eng.inv_dx), ng, eng.body, eng.rc_bodies, eng.rb_c, eng.rb_M, eng.pg_sl,
            eng.pc_s, eng.pc_n, eng.pg_tw, eng.pc_m, eng.pg_S, eng.grid_dv, eng.pc_x])]
    react = rc.REACT * int(rigid_sdf.REACT_POINTS)
    for _ in range(passes):
        out += [
            wp.launch(step, dim=n, device=d, record_cmd=True, inputs=[
                *at, eng.rc_bodies, eng.rb_c, eng.pg_sl, eng.pc_s, eng.pc_n, eng.pc_b, eng.pg_ln, eng.pg_lt,
                eng.pg_S, eng.rc_cols, eng.rc_ncol, eng.rc_mus, float(fric), int(rigid_sdf.FRICTION_CAP),
                react, eng.pc_g, eng.acc_p, eng.acc_l, eng.pg_c, dt, eng.pc_x]),
            wp.launch(body, dim=ns, device=d, record_cmd=True, inputs=[*bod, 0]),
            wp.launch(node, dim=ng ** 3, device=d, record_cmd=True, inputs=[
                eng.pc_g, eng.grid_dv, eng.pc_m, eng.pg_tw, int(rigid_sdf.SOFT_SIDE)])]
    return out
