"""A rigid body's lift-off and friction with its supports as one body (issue 53's twist, issue 67's Coulomb by force
balance) as Warp functions per scalar type, called by ``rigid.build_rigid_update``; the NumPy reference is
:mod:`gasp_core.mpm.rigid_friction`, taichi_mpm's ``rigid_friction.py`` spells the same steps.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from gasp_core.mpm.rigid_friction import FLAT_FROM, FLAT_TO, TIP_SHARED

from .precision import MODULE_OPTIONS, build_types
from .foot import foot_arms, foot_point, foot_push
from .rigid_support import (Hollow, body_inv, pair_gap, roll_flat, roll_point, round_normal, slip_at,
                            tip)

vec3d = wp.types.vector(3, wp.float64)
FLAT_0 = wp.constant(wp.float64(FLAT_FROM))   # gasp_core.mpm.rigid_friction.contact_flatness's bounds
FLAT_W = wp.constant(wp.float64(FLAT_TO - FLAT_FROM))
TIP_SHARE = wp.constant(int(TIP_SHARED))   # gasp_core.mpm.rigid_friction.TIP_SHARED
mat33d = wp.types.matrix((3, 3), wp.float64)


@functools.cache
def build_rigid_contact(Ft):
    """``(lift_off, twist_brake, slide_brake)``, Warp functions of the scalar type ``Ft`` (taichi_mpm's
    ``Rigid.lift_off``, ``RigidFriction.twist_brake`` and ``RigidFriction.slide_brake``). It is long because the three
    are closures of the scalar type, built together."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def lift_off(V: vec3d, c: vec3d, c0: vec3d, jn: vec3, e_pair: Ft, vin_f: Ft, v_rest: Ft, gravity: vec3d,
                 T: wp.float64, rule: int, V0: vec3d, jsup: wp.float64, M: wp.float64, dt: wp.float64):
        # taichi_mpm's Rigid.lift_off: the normal part of V along the contact's mean normal made the speed with which
        # the free flights cross as an instantaneous bounce of restitution e (gasp_core.mpm.restitution.
        # lift_off_speed); e 0 below v_rest; by restitution.LIFT_OFF's rule (lift_off_normal; taichi_mpm's
        # RigidLift.lift_normal: J_o the other bodies' normal impulse over the contact)
        out = V
        n = vec3d(wp.float64(jn[0]), wp.float64(jn[1]), wp.float64(jn[2]))
        ln = wp.length(n)
        if ln > wp.float64(0.0):
            n = n / ln
            e = wp.float64(e_pair)
            vin = wp.float64(vin_f)
            if e * vin < wp.float64(v_rest):
                e = wp.float64(0.0)
            g_n = -wp.dot(gravity, n)
            one = wp.float64(1.0)
            B = vin * (one - e) - (one + e) * g_n * T
            C = e * vin * vin - (one + e) * g_n * (wp.dot(c - c0, n) + wp.float64(0.5) * g_n * T * T)
            u_out = wp.float64(0.5) * (-B + wp.sqrt(wp.max(B * B + wp.float64(4.0) * C, wp.float64(0.0)))) - g_n * T
            u = wp.dot(V, n)
            if u > wp.float64(0.0):
                u_new = wp.max(u_out, wp.float64(0.0))
                if rule == 2:
                    u_new = wp.min(u_new, u)
                elif rule == 1:
                    j_o = M * wp.dot(V - V0, n) - jsup + M * g_n * (T + dt)
                    u_new = wp.min(u_new, wp.max(u, u_new + j_o / M))
                out = V + (u_new - u) * n
        return out

    @wp.func
    def twist_brake(w: vec3d, inertia: mat33d, jn: vec3, tw: wp.float64):
        # taichi_mpm's Rigid.twist_brake: the spin about the contact's mean normal brought towards 0 by at most
        # tw / (n . I n), never reversed
        out = w
        n = vec3d(wp.float64(jn[0]), wp.float64(jn[1]), wp.float64(jn[2]))
        ln = wp.length(n)
        if tw > wp.float64(0.0) and ln > wp.float64(0.0):
            n = n / ln
            wn = wp.dot(w, n)
            In = wp.dot(n, inertia * n)
            if In > wp.float64(0.0) and wn != wp.float64(0.0):
                out = w - n * wp.sign(wn) * wp.min(wp.abs(wn), tw / In)
        return out

    @wp.func
    def slide_brake(V: vec3d, w: vec3d, inertia: mat33d, M: wp.float64, c: vec3d, jn: vec3,
                    fx: wp.vec4d, fv: vec3d, jx: wp.array(dtype=wp.float64), b: int,
                    deep: wp.array(dtype=wp.float64), flat: wp.array(dtype=wp.float64), xf: wp.array(dtype=vec3d)):
        # taichi_mpm's Rigid.slide_brake (gasp_core.mpm.rigid_friction.coulomb_friction): Coulomb's friction on the body
        # as one, decided by force balance: the impulse along -u_t at the budget-weighted contact point that stops
        # u_t (relative to the supports) when within the budget sum mu j (it sticks), else the budget (it slides);
        # its tipping moment held by the normal contact up to J a (a the patch's half-width along u_t)
        Vo = V
        wo = w
        n = vec3d(wp.float64(jn[0]), wp.float64(jn[1]), wp.float64(jn[2]))
        ln = wp.length(n)
        k0 = 10 * b
        J = jx[k0]
        if fx[3] > wp.float64(0.0) and ln > wp.float64(0.0) and J > wp.float64(0.0):
            n = n / ln
            r = vec3d(fx[0], fx[1], fx[2]) / fx[3] - c
            u = V + wp.cross(w, r) - fv / fx[3]
            ut = u - wp.dot(u, n) * n
            lt = wp.length(ut)
            if lt > wp.float64(0.0):
                t = ut / lt
                rt = wp.cross(r, t)
                rh = rt - wp.dot(rt, n) * n   # the tipping part of the moment arm
                inv = wp.inverse(inertia)
                k_a = wp.float64(1.0) / M + wp.dot(rt, inv * rt)   # free to turn: 1 / the effective mass at x_f
                m = wp.dot(rt, inv * rh)
                k_b = wp.max(k_a - m, wp.float64(1.0) / M)   # its tipping moment held by the normal contact
                xm = vec3d(jx[k0 + 1], jx[k0 + 2], jx[k0 + 3]) / J
                S = mat33d(jx[k0 + 4], jx[k0 + 5], jx[k0 + 6], jx[k0 + 5], jx[k0 + 7], jx[k0 + 8],
                           jx[k0 + 6], jx[k0 + 8], jx[k0 + 9]) / J - wp.outer(xm, xm)
                s3 = wp.max(wp.float64(3.0) * wp.dot(t, S * t), wp.float64(0.0))
                # a face holds the moment, a rounded contact rolls (gasp_core.mpm.rigid_friction.
                # contact_flatness): the patch's radius of curvature s3 / depth against the mass centre's height
                f = wp.float64(1.0)
                h = wp.abs(wp.dot(xm - c, n))
                if deep[b] > wp.float64(0.0) and h > wp.float64(0.0):
                    f = wp.min(wp.max((s3 / (deep[b] * h) - FLAT_0) / FLAT_W, wp.float64(0.0)), wp.float64(1.0))
                flat[b] = f
                xf[b] = xm
                a = wp.sqrt(s3) * f
                lh = wp.length(rh)
                hold = J * a   # round 85 (TIP_SHARED): less the moment the normal impulses already hold
                if TIP_SHARE != 0 and lh > wp.float64(0.0):
                    hold = wp.max(hold - wp.max(J * wp.dot(wp.cross(xm - c, n), rh) / lh, wp.float64(0.0)),
                                  wp.float64(0.0))
                p = lt / k_b
                held = p
                if hold < p * lh:   # more than the contact holds: the rest turns the body
                    ph = hold / lh
                    p = (lt + ph * m) / k_a
                    held = ph
                p = wp.min(p, fx[3])
                held = wp.min(held, p)
                Vo = V - (p / M) * t
                wo = w + inv * (held * rh - p * rt)
        return Vo, wo

    return lift_off, twist_brake, slide_brake


@functools.cache
def build_rigid_pair(Ft):
    """``rigid_pair`` (float64; ``gasp_core.mpm.rigid_friction.pair_contact``, taichi_mpm's ``rigid_pair``), one thread
    after ``rigid_update``: the contact from the nodes' sums ``acc`` (cleared), the approach removed through the
    centres (round 94: at a cylinder's foot, ``foot.foot_push``), Coulomb's friction (round 65: a round body rolls,
    the support tables ``t_*``); the centres advance. It is long because the law's steps (round 91's normal and gap, the approach, the friction, the rolling, the advance)
    share the one kernel's locals, as taichi_mpm's ``rigid_pair`` does."""

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rigid_pair(in_a: wp.array(dtype=wp.int32), mass: wp.array(dtype=wp.float64),
                   inertia0: wp.array(dtype=mat33d), centre: wp.array(dtype=vec3d), rot: wp.array(dtype=mat33d),
                   vel: wp.array(dtype=vec3d), spin: wp.array(dtype=vec3d), dt: wp.float64, dx: wp.float64,
                   mu: wp.float64, acc: wp.array(dtype=wp.float64), t_dirs: wp.array(dtype=vec3d),
                   t_h: wp.array(dtype=wp.float64), t_curv: wp.array(dtype=mat33d), t_delta: wp.array(dtype=wp.float64),
                   nd: int, t_round: wp.array(dtype=wp.float64), cos_cone: wp.float64, hol: Hollow):
        a = int(1)
        if in_a[0] != 0:
            a = 0
        b = 1 - a
        W = acc[0]
        n = vec3d(acc[4], acc[5], acc[6])
        ln = wp.length(n)
        if W > wp.float64(0.0) and ln > wp.float64(0.0):
            # round 91: the normal from the shapes; with a gap known, only the approach that closes it this substep
            n, foot, side = round_normal(t_dirs, t_h, t_round, nd, cos_cone, a, b, rot[a], rot[b], centre[a], centre[b],
                                   n / ln, hol)
            g = pair_gap(t_dirs, t_h, t_round, nd, cos_cone, a, b, rot[a], rot[b], centre[a], centre[b], n, hol)
            x_c = vec3d(acc[1], acc[2], acc[3]) / W
            MA = mass[a]
            MB = mass[b]
            VA = vel[a]
            VB = vel[b]
            wA = spin[a]
            wB = spin[b]
            # round 94 (foot.py): at a cylinder's foot, with its moment; else through the centres
            armA, armB = foot_arms(t_round, hol, a, b, rot[a], rot[b], foot)
            iA = body_inv(inertia0[a], rot[a], MA, wp.float64(0.5) * dx * dx)
            iB = body_inv(inertia0[b], rot[b], MB, wp.float64(0.5) * dx * dx)
            VA, wA, VB, wB, P = foot_push(VA, wA, VB, wB, MA, MB, iA, iB, armA, armB, n, g, dt)
            x_c = foot_point(x_c, centre[a], centre[b], armA, armB)
            rA = x_c - centre[a]
            rB = x_c - centre[b]
            u = VA + wp.cross(wA, rA) - VB - wp.cross(wB, rB)
            ut = u - wp.dot(u, n) * n
            lt = wp.length(ut)
            if P > wp.float64(0.0) and mu > wp.float64(0.0) and lt > wp.float64(0.0):
                t = ut / lt
                RA = rot[a]
                RB = rot[b]
                # round 65: a round body rolls (gasp_core.mpm.rigid_support.pair_flatness) on its surface
                # (contact_plane): the contact point moved onto it, the slip taken there; f 1 as before
                f = roll_flat(t_dirs, t_h, t_curv, t_delta, nd, a, b, RA, RB, n, ut, lt, vec3d())
                if side == wp.float64(1.0):   # round 94: a point at a cylinder's foot holds no tipping moment
                    f = wp.float64(0.0)
                if f < wp.float64(1.0):
                    x_c = roll_point(t_dirs, t_h, t_round, nd, a, b, RA, RB, centre[a], centre[b], n, x_c)
                    rA, rB, ut = slip_at(x_c, VA, wA, centre[a], VB, wB, centre[b], n)
                    lt = wp.length(ut)
                    t = ut / wp.max(lt, wp.float64(1.0e-300))
                nIA = wp.dot(n, RA * inertia0[a] * wp.transpose(RA) * n) + wp.float64(0.5) * dx * dx * MA
                nIB = wp.dot(n, RB * inertia0[b] * wp.transpose(RB) * n) + wp.float64(0.5) * dx * dx * MB
                sA = wp.dot(wp.cross(rA, t), n)   # the twist arms about n
                sB = wp.dot(wp.cross(rB, t), n)
                k = wp.float64(1.0) / MA + wp.float64(1.0) / MB + sA * sA / nIA + sB * sB / nIB
                gA = vec3d()   # (1 - f) of the tipping moment turns each body through its full inverse inertia
                gB = vec3d()
                if f < wp.float64(1.0):
                    gA = tip(f, iA, wp.cross(rA, t), n)   # iA, iB: the normal's inverse inertias, above
                    gB = tip(f, iB, wp.cross(rB, t), n)
                    k = k + (wp.dot(gA, wp.cross(rA, t)) + wp.dot(gB, wp.cross(rB, t)))
                p = wp.min(lt / k, mu * P)   # stick when within mu P, else slide at mu P
                VA = VA - (p / MA) * t
                VB = VB + (p / MB) * t
                wA = wA - (p * sA / nIA) * n
                wB = wB + (p * sB / nIB) * n
                if f < wp.float64(1.0):
                    wA = wA - p * gA
                    wB = wB + p * gB
            centre[a] = centre[a] + dt * (VA - vel[a])
            centre[b] = centre[b] + dt * (VB - vel[b])
            vel[a] = VA
            vel[b] = VB
            spin[a] = wA
            spin[b] = wB
        for q in range(7):
            acc[q] = wp.float64(0.0)

    return rigid_pair
