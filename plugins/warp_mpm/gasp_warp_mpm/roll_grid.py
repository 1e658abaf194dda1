"""Round 70: the engine option ``roll_contact`` (``gasp_core.mpm.roll_contact``; ``docs/rigid.md`` "Round 70"): a
round rigid body's exact sphere against the soft points' patches (``point_grid.pg_mark``'s ``sph``), round 67's
constraint of the grid frictionless, then the friction one impulse a patch (a pair: a slot's body and a soft body).

Per substep, after round 67's normal passes (``point_grid.grid_launches`` with no friction): ``rg_clear`` (a pair
each) clears the pairs' sums; ``rg_sum`` (a point each) adds each touching point's normal impulse ``lambda_p`` and
``lambda_p r_p`` to its pair; ``rg_share`` scatters its share ``a_p = lambda_p / Lambda`` by its weights to its
field's nodes (``tw``); ``rg_resp`` gathers the patch's grid response ``G = sum_p a_p sum_i w_ip T_i / m_i``. Then
:data:`gasp_core.mpm.roll_contact.FRICTION_PASSES` times: ``rg_slip`` (a point each: the patch's mean slip ``sum_p
a_p u_t,p``), ``rg_solve`` (a pair each: ``J <- J - u_t / S``, ``S = G + 1/M + (r_c x t) I^-1 (r_c x t)`` at the
patch's centre ``r_c``, capped at ``mu Lambda``; the step ``dJ`` kept), ``rg_apply`` (a point each: ``a_p dJ`` to its
nodes by its weights, the opposite to the body, as ``pg_pass``), ``pg_body`` and ``pg_node``.

Pair data ``rg_T`` (float64, :data:`NT` a pair): 0-2 the mean slip, 3 ``Lambda``, 4-6 ``sum lambda r``, 7 ``G``,
8-10 ``J``, 11-13 ``dJ``. One thread a point, node or pair; float64 atomics; no ordered loop.

This module must not use ``from __future__ import annotations`` (the warp modules' rule).
"""
import functools

import warp as wp

from .fields import build_field_reads
from .point_grid import NS, build_point_grid
from .precision import MODULE_OPTIONS, build_types
from .rigid_pairs import mat33d, vec3d
from .stencil import build_gather, build_stencil_at

NT = wp.constant(16)


@functools.cache
def build_roll_grid(Ft):
    """``(rg_clear, rg_sum, rg_share, rg_resp, rg_slip, rg_solve, rg_apply)`` for the scalar type ``Ft``.
    It is long because the kernels and their helpers are closures of the scalar type (``point_grid.build_point_grid``'s
    reason)."""
    vec3 = build_types(Ft)[0]
    stencil_at = build_stencil_at(Ft)
    field_offset_base, gather = build_field_reads(Ft)[0], build_gather(Ft)

    @wp.func
    def to64(a: vec3):
        return vec3d(wp.float64(a[0]), wp.float64(a[1]), wp.float64(a[2]))

    @wp.func
    def pair_of(p: int, pc_s: wp.array(dtype=wp.int32), ln: wp.array(dtype=wp.float64),
                body: wp.array(dtype=wp.int32), cols: wp.array(dtype=wp.int32), n_cols: int):
        k = int(-1)
        if pc_s[p] >= 0 and ln[p] > wp.float64(0.0):
            k = pc_s[p] * n_cols + cols[body[p]]
        return k

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rg_clear(T: wp.array(dtype=wp.float64)):
        k = wp.tid()
        for q in range(16):   # NT
            T[NT * k + q] = wp.float64(0.0)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rg_sum(x: wp.array(dtype=vec3), body: wp.array(dtype=wp.int32), bodies: wp.array(dtype=wp.int32),
               centre: wp.array(dtype=vec3d), pc_s: wp.array(dtype=wp.int32), ln: wp.array(dtype=wp.float64),
               pc_x: wp.array(dtype=vec3d), cols: wp.array(dtype=wp.int32), n_cols: int,
               T: wp.array(dtype=wp.float64)):
        p = wp.tid()
        k = pair_of(p, pc_s, ln, body, cols, n_cols)
        if k >= 0:
            r = to64(x[p]) + pc_x[p] - centre[bodies[pc_s[p]]]
            wp.atomic_add(T, NT * k + 3, ln[p])
            for ax in range(3):
                wp.atomic_add(T, NT * k + 4 + ax, ln[p] * r[ax])

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rg_share(x: wp.array(dtype=vec3), in_a: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft, n_grid: int,
                 body: wp.array(dtype=wp.int32), pc_s: wp.array(dtype=wp.int32), ln: wp.array(dtype=wp.float64),
                 cols: wp.array(dtype=wp.int32), n_cols: int, T: wp.array(dtype=wp.float64),
                 tw: wp.array(dtype=wp.float64), grid_dv: wp.array(dtype=vec3)):
        p = wp.tid()
        k = pair_of(p, pc_s, ln, body, cols, n_cols)
        if k >= 0:
            a = ln[p] / T[NT * k + 3]
            W, idx0, fx = stencil_at((x[p] - lo) * inv_dx, n_grid)
            off = field_offset_base(grid_dv, in_a, body[p], n_grid * n_grid * n_grid)
            for i in range(3):
                for j in range(3):
                    for q in range(3):
                        wp.atomic_add(tw, off + idx0 + (i * n_grid + j) * n_grid + q,
                                      a * wp.float64(W[i, 0] * W[j, 1] * W[q, 2]))

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rg_resp(x: wp.array(dtype=vec3), in_a: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft, n_grid: int,
                body: wp.array(dtype=wp.int32), pc_s: wp.array(dtype=wp.int32), ln: wp.array(dtype=wp.float64),
                cols: wp.array(dtype=wp.int32), n_cols: int, T: wp.array(dtype=wp.float64),
                tw: wp.array(dtype=wp.float64), pc_m: wp.array(dtype=Ft), grid_dv: wp.array(dtype=vec3)):
        p = wp.tid()
        k = pair_of(p, pc_s, ln, body, cols, n_cols)
        if k >= 0:
            a = ln[p] / T[NT * k + 3]
            W, idx0, fx = stencil_at((x[p] - lo) * inv_dx, n_grid)
            off = field_offset_base(grid_dv, in_a, body[p], n_grid * n_grid * n_grid)
            g = wp.float64(0.0)
            for i in range(3):
                for j in range(3):
                    for q in range(3):
                        at = off + idx0 + (i * n_grid + j) * n_grid + q
                        m = wp.float64(pc_m[at])
                        if m > wp.float64(0.0):
                            g = g + wp.float64(W[i, 0] * W[j, 1] * W[q, 2]) * tw[at] / m
            wp.atomic_add(T, NT * k + 7, a * g)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rg_slip(x: wp.array(dtype=vec3), grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3),
                in_a: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft, n_grid: int, body: wp.array(dtype=wp.int32),
                bodies: wp.array(dtype=wp.int32), centre: wp.array(dtype=vec3d), sl: wp.array(dtype=wp.float64),
                pc_s: wp.array(dtype=wp.int32), pc_n: wp.array(dtype=vec3d), ln: wp.array(dtype=wp.float64),
                pc_x: wp.array(dtype=vec3d), cols: wp.array(dtype=wp.int32), n_cols: int,
                T: wp.array(dtype=wp.float64)):
        p = wp.tid()
        k = pair_of(p, pc_s, ln, body, cols, n_cols)
        if k >= 0:
            W, idx0, fx = stencil_at((x[p] - lo) * inv_dx, n_grid)
            off = field_offset_base(grid_dv, in_a, body[p], n_grid * n_grid * n_grid)
            vg, B = gather(grid_v, grid_dv, off, W, idx0, n_grid)
            o = NS * pc_s[p]
            r = to64(x[p]) + pc_x[p] - centre[bodies[pc_s[p]]]
            u = to64(vg) - (vec3d(sl[o + 10], sl[o + 11], sl[o + 12]) +
                            wp.cross(vec3d(sl[o + 13], sl[o + 14], sl[o + 15]), r))
            n = pc_n[p]
            ut = (u - wp.dot(u, n) * n) * (ln[p] / T[NT * k + 3])
            for ax in range(3):
                wp.atomic_add(T, NT * k + ax, ut[ax])

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rg_solve(T: wp.array(dtype=wp.float64), sl: wp.array(dtype=wp.float64), mass: wp.array(dtype=wp.float64),
                 bodies: wp.array(dtype=wp.int32), n_cols: int, mus: wp.array(dtype=wp.float64), fric: wp.float64):
        k = wp.tid()
        t = NT * k
        L = T[t + 3]
        for ax in range(3):
            T[t + 11 + ax] = wp.float64(0.0)
        us = vec3d(T[t], T[t + 1], T[t + 2])
        if L > wp.float64(0.0) and wp.length(us) > wp.float64(0.0):
            s = k // n_cols
            o = NS * s
            Ii = mat33d(sl[o + 16], sl[o + 17], sl[o + 18], sl[o + 19], sl[o + 20], sl[o + 21], sl[o + 22],
                        sl[o + 23], sl[o + 24])
            rc = vec3d(T[t + 4], T[t + 5], T[t + 6]) / L
            a = wp.cross(rc, wp.normalize(us))
            S = T[t + 7] + wp.float64(1.0) / mass[bodies[s]] + wp.dot(a, Ii * a)
            J0 = vec3d(T[t + 8], T[t + 9], T[t + 10])
            J1 = J0 - us / S
            cap = fric * mus[k] * L
            if wp.length(J1) > cap:
                J1 = J1 * (cap / wp.length(J1))
            for ax in range(3):
                T[t + 8 + ax] = J1[ax]
                T[t + 11 + ax] = J1[ax] - J0[ax]
        for ax in range(3):
            T[t + ax] = wp.float64(0.0)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rg_apply(x: wp.array(dtype=vec3), in_a: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft, n_grid: int,
                 body: wp.array(dtype=wp.int32), bodies: wp.array(dtype=wp.int32), centre: wp.array(dtype=vec3d),
                 sl: wp.array(dtype=wp.float64), pc_s: wp.array(dtype=wp.int32), ln: wp.array(dtype=wp.float64),
                 pc_x: wp.array(dtype=vec3d), cols: wp.array(dtype=wp.int32), n_cols: int,
                 T: wp.array(dtype=wp.float64), react: int, pc_g: wp.array(dtype=vec3d),
                 acc_p: wp.array(dtype=vec3d), acc_l: wp.array(dtype=vec3d), grid_dv: wp.array(dtype=vec3)):
        p = wp.tid()
        k = pair_of(p, pc_s, ln, body, cols, n_cols)
        if k >= 0:
            D = vec3d(T[NT * k + 11], T[NT * k + 12], T[NT * k + 13]) * (ln[p] / T[NT * k + 3])
            W, idx0, fx = stencil_at((x[p] - lo) * inv_dx, n_grid)
            off = field_offset_base(grid_dv, in_a, body[p], n_grid * n_grid * n_grid)
            for i in range(3):
                for j in range(3):
                    for q in range(3):
                        wp.atomic_add(pc_g, off + idx0 + (i * n_grid + j) * n_grid + q,
                                      wp.float64(W[i, 0] * W[j, 1] * W[q, 2]) * D)
            if react != 0:
                s = pc_s[p]
                rb = bodies[s]
                xr = to64(x[p]) + pc_x[p]
                L = wp.cross(xr - centre[rb], -D)
                for ax in range(3):
                    wp.atomic_add(sl, NS * s + ax, -D[ax])
                    wp.atomic_add(sl, NS * s + 3 + ax, L[ax])
                wp.atomic_add(acc_p, rb, -D)
                wp.atomic_add(acc_l, rb, wp.cross(xr, -D))

    return rg_clear, rg_sum, rg_share, rg_resp, rg_slip, rg_solve, rg_apply


def roll_launches(eng, Ft) -> list:
    """The recorded contact of the option ``roll_contact`` (module notes): round 67's normal passes with the exact
    spheres and the patches, then the friction one impulse a patch."""
    from gasp_core.mpm import rigid_sdf
    from gasp_core.mpm import roll_contact as roll
    from gasp_core.mpm.rigid import affine_dx
    from . import rigid_collider as rc
    from .point_grid import grid_launches
    patch_f = bool(roll.PATCH_FRICTION)
    out = grid_launches(eng, Ft, roll.NORMAL_PASSES, roll.PATCH, 0.0 if patch_f else rc.FRICTION)
    if not patch_f:
        return out
    clear, add, share, resp, slip, solve, apply = build_roll_grid(Ft)
    body, node = build_point_grid(Ft)[0], build_point_grid(Ft)[4]
    d, n, ng, npair = eng.device, eng.n_material, eng.n_grid, eng.rc_ns * eng.rc_ncol
    eng.rg_T = wp.zeros(int(NT) * npair, dtype=wp.float64, device=d)
    lo = eng.k.vec3(*[float(c) for c in eng.setup.domain_lo])
    at = [eng.x, eng.in_a, lo, Ft(eng.inv_dx), ng, eng.body]
    pair = [eng.rc_cols, eng.rc_ncol if roll.PAIRS else 0, eng.rg_T]   # round 71: PAIRS 0, every slot's patch one
    bod = [eng.pg_sl, eng.rc_acc, eng.rb_M, eng.rb_I0, eng.rb_R, eng.rc_bodies, affine_dx(eng.dx), 0]
    react = rc.REACT * int(rigid_sdf.REACT_POINTS)
    out += [wp.launch(clear, dim=npair, device=d, record_cmd=True, inputs=[eng.rg_T]),
            wp.launch(add, dim=n, device=d, record_cmd=True, inputs=[
                eng.x, eng.body, eng.rc_bodies, eng.rb_c, eng.pc_s, eng.pg_ln, eng.pc_x, *pair]),
            wp.launch(share, dim=n, device=d, record_cmd=True, inputs=[
                *at, eng.pc_s, eng.pg_ln, *pair, eng.pg_tw, eng.grid_dv]),
            wp.launch(resp, dim=n, device=d, record_cmd=True, inputs=[
                *at, eng.pc_s, eng.pg_ln, *pair, eng.pg_tw, eng.pc_m, eng.grid_dv]),
            wp.launch(node, dim=ng ** 3, device=d, record_cmd=True, inputs=[   # tw cleared (nothing to apply)
                eng.pc_g, eng.grid_dv, eng.pc_m, eng.pg_tw, int(rigid_sdf.SOFT_SIDE)])]
    for _ in range(roll.FRICTION_PASSES):
        out += [
            wp.launch(slip, dim=n, device=d, record_cmd=True, inputs=[
                eng.x, eng.grid_v, eng.grid_dv, eng.in_a, lo, Ft(eng.inv_dx), ng, eng.body, eng.rc_bodies, eng.rb_c,
                eng.pg_sl, eng.pc_s, eng.pc_n, eng.pg_ln, eng.pc_x, *pair]),
            wp.launch(solve, dim=npair, device=d, record_cmd=True, inputs=[
                eng.rg_T, eng.pg_sl, eng.rb_M, eng.rc_bodies, eng.rc_ncol, eng.rc_mus, float(rc.FRICTION)]),
            wp.launch(apply, dim=n, device=d, record_cmd=True, inputs=[
                *at, eng.rc_bodies, eng.rb_c, eng.pg_sl, eng.pc_s, eng.pg_ln, eng.pc_x, *pair, react, eng.pc_g,
                eng.acc_p, eng.acc_l, eng.grid_dv]),
            wp.launch(body, dim=eng.rc_ns, device=d, record_cmd=True, inputs=bod),
            wp.launch(node, dim=ng ** 3, device=d, record_cmd=True, inputs=[
                eng.pc_g, eng.grid_dv, eng.pc_m, eng.pg_tw, int(rigid_sdf.SOFT_SIDE)])]
    return out
