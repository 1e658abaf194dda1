"""The rigid limit (``material.model = "rigid"``, ``gasp_core.mpm.rigid``, ``docs/rigid.md``) as Warp kernels per
scalar type; taichi_mpm's ``rigid.py`` spells the same steps.

After each G2P: ``rigid_reduce`` sums each rigid body's momentum and angular momentum about the origin (APIC's
affine part included) over its points into float64 accumulators (atomic adds: on the CPU Warp runs a launch
serially, so the order is the point order); ``rigid_update`` (one thread a body) turns them into the body's velocity
and spin and advances its centre and rotation; ``rigid_apply`` puts every point of the body (its passive points too) on
the rigid pose ``c + R X0`` with the rigid velocity, ``C`` the spin's skew matrix times its body's carried share
(``gasp_core.mpm.spin_booking.spin_shares``: 1 for a body alone in its field since round 76, ``rigid_update`` taking P2G's
booking of it back; else ``APIC_SPIN``, 0) and ``F = R``. With the particle
contact's planes, ``rigid_depth`` and ``rigid_lift`` (:func:`build_rigid_lift`) then move a resting body deeper than
the slop out without speed (``gasp_core.mpm.rigid_friction.settle_projection``, Bullet's split impulse; issue 53) and
``rigid_apply`` runs again.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from gasp_core.mpm.restitution import lift_off_rule

from .round_collider import round_point
from .precision import MODULE_OPTIONS, build_types
from .rigid_friction import build_rigid_contact, build_rigid_pair

vec3d = wp.types.vector(3, wp.float64)
mat33d = wp.types.matrix((3, 3), wp.float64)


@functools.cache
def build_rigid_update(Ft):
    """``rigid_update`` (one thread over the bodies: velocity, spin, centre and rotation from the sums; the contact's
    lift-off, twist brake and bookkeeping, ``gasp_core.mpm.restitution``) for the scalar type ``Ft``.
    It is long because the kernel and its helper are closures of the scalar type."""
    vec3, vec4, mat33 = build_types(Ft)
    lift_off, twist_brake, slide_brake = build_rigid_contact(Ft)

    @wp.func
    def rotation_of(a: vec3d):
        th = wp.length(a)
        K = mat33d(wp.float64(0.0), -a[2], a[1], a[2], wp.float64(0.0), -a[0], -a[1], a[0], wp.float64(0.0))
        s = wp.float64(1.0) - th * th / wp.float64(6.0)
        c = wp.float64(0.5) - th * th / wp.float64(24.0)
        if th > wp.float64(1e-4):
            s = wp.sin(th) / th
            c = (wp.float64(1.0) - wp.cos(th)) / (th * th)
        return wp.identity(3, wp.float64) + s * K + c * (K * K)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rigid_update(rigid: wp.array(dtype=wp.int32), mass: wp.array(dtype=wp.float64),
                     inertia0: wp.array(dtype=mat33d), acc_p: wp.array(dtype=vec3d), acc_l: wp.array(dtype=vec3d),
                     centre: wp.array(dtype=vec3d), rot: wp.array(dtype=mat33d), vel: wp.array(dtype=vec3d),
                     spin: wp.array(dtype=vec3d), dt: wp.float64, dx: wp.float64, n_bodies: int,
                     vin: wp.array(dtype=Ft), vin_next: wp.array(dtype=Ft), touch: wp.array(dtype=wp.int32),
                     was: wp.array(dtype=wp.int32), c0: wp.array(dtype=vec3d), jn: wp.array(dtype=vec3),
                     je: wp.array(dtype=Ft), jsum: wp.array(dtype=Ft), e_body: wp.array(dtype=Ft), v_rest: Ft,
                     lift_rule: int, gravity: vec3d, steps: wp.array(dtype=wp.int32), count: wp.array(dtype=wp.int32),
                     nlast: wp.array(dtype=wp.int32), twist: wp.array(dtype=wp.float64),
                     fx: wp.array(dtype=wp.vec4d), ndepth: wp.array(dtype=wp.int32), fv: wp.array(dtype=vec3d),
                     jx: wp.array(dtype=wp.float64), deep: wp.array(dtype=wp.float64),
                     flat: wp.array(dtype=wp.float64), xf: wp.array(dtype=vec3d), V0: wp.array(dtype=vec3d),
                     jsup: wp.array(dtype=wp.float64), passes: int, dxf: wp.float64,
                     book: wp.array(dtype=wp.float64)):
        b = wp.tid()   # one thread a body: each writes its own rows (dim = n_bodies)
        M = mass[b]
        if rigid[b] != 0 and M > wp.float64(0.0):
            P = acc_p[b]
            c = centre[b]
            # the body's own angular momentum: what the grid gave back less the affine parts' booking of the spin the
            # points carried (round 76, gasp_core.mpm.spin_booking.spin_shares: C = [w], their book M dx^2 / 2 w by P2G)
            Lc = acc_l[b] - wp.cross(c, P) - wp.float64(0.5) * book[b] * dxf * dxf * M * spin[b]
            R = rot[b]
            extra = wp.float64(0.5) * dx * dx * M * wp.identity(3, wp.float64)
            # round 67: the rotation by the implicit midpoint (the spin at exp(dt w / 2) R, ROTATION_PASSES fixed-point
            # passes): a tumbling body keeps its energy (the explicit step, the spin at R: +7.6 % in a second)
            w_pred = wp.inverse(R * inertia0[b] * wp.transpose(R) + extra) * Lc
            for _q in range(4):   # at most 4 (a literal bound: warp_layout's rule)
                if _q < passes:
                    R_h = rotation_of(wp.float64(0.5) * dt * w_pred) * R
                    w_pred = wp.inverse(R_h * inertia0[b] * wp.transpose(R_h) + extra) * Lc
            R_new = rotation_of(dt * w_pred) * R
            inertia = R_new * inertia0[b] * wp.transpose(R_new) + extra
            w = wp.inverse(inertia) * Lc
            V = P / M
            j_sup = jx[10 * b]   # this substep's supports' normal impulse (cleared below)
            if e_body[b] >= Ft(0.0):
                w = twist_brake(w, inertia, jn[b], twist[b])
                V, w = slide_brake(V, w, inertia, M, c, jn[b], fx[b], fv[b], jx, b, deep, flat, xf)
            fx[b] = wp.vec4d()
            fv[b] = vec3d()
            for q in range(10):
                jx[10 * b + q] = wp.float64(0.0)
            deep[b] = wp.float64(0.0)
            if touch[b] != 0 and was[b] == 0:
                c0[b] = c
                steps[b] = 0
                V0[b] = vel[b]
                jsup[b] = wp.float64(0.0)
            jsup[b] = jsup[b] + j_sup
            if e_body[b] >= Ft(0.0) and touch[b] == 0 and was[b] != 0 and jsum[b] > Ft(0.0):
                V = lift_off(V, c, c0[b], jn[b], e_body[b] * je[b] / jsum[b], vin[b], v_rest, gravity,
                             dt * wp.float64(steps[b]), lift_rule, V0[b], jsup[b], M, dt)
            steps[b] = steps[b] + touch[b]
            vel[b] = V
            spin[b] = w
            centre[b] = c + dt * V
            rot[b] = R_new
        acc_p[b] = vec3d()
        acc_l[b] = vec3d()
        # the contact's approach speed (contact.build_unloading): its first substep's, kept while a point
        # touches; 0 once the body is free (taichi_mpm's Rigid.rigid_update)
        if touch[b] != 0:
            if was[b] == 0:
                vin[b] = vin_next[b]
        else:
            vin[b] = Ft(0.0)
            jn[b] = vec3(Ft(0.0))
            je[b] = Ft(0.0)
            jsum[b] = Ft(0.0)
        was[b] = touch[b]
        twist[b] = wp.float64(0.0)
        nlast[b] = count[b]
        count[b] = 0
        ndepth[b] = 0
        vin_next[b] = Ft(0.0)
        touch[b] = 0

    return rigid_update


@functools.cache
def build_rigid_lift(Ft):
    """``(rigid_depth, rigid_lift)`` for the scalar type ``Ft``: the position-level non-penetration of a resting rigid body
    (``gasp_core.mpm.rigid_friction.settle_projection``, issue 53; taichi_mpm's ``Rigid.rigid_depth`` and ``Rigid.rigid_lift``).
    ``rigid_depth`` (one thread a point) takes each rigid body's deepest penetration into each plane of the particle contact
    (a round body's at its exact shape, round 88: ``round_collider.round_point``) and the penetration-weighted sum of its touching
    points; ``rigid_lift`` (one thread a body) moves a body that is not bouncing out along the plane's normal to ``slop`` (m)
    of it, without speed, and removes its centre's approach (through the centre: no spin), with Coulomb's friction of that
    impulse at the touching points' penetration-weighted centre. It is long because both kernels are closures of Ft."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rigid_depth(x: wp.array(dtype=vec3), body: wp.array(dtype=wp.int32), rigid: wp.array(dtype=wp.int32),
                    p_contact: wp.array(dtype=vec3), planes: wp.array(dtype=vec3), plane_n: wp.array(dtype=vec3),
                    dmax: wp.array(dtype=wp.float64), dsum: wp.array(dtype=wp.vec4d), ndepth: wp.array(dtype=wp.int32),
                    centre: wp.array(dtype=vec3d), rad: wp.array(dtype=wp.float64), ax: wp.array(dtype=vec3d),
                    rot: wp.array(dtype=mat33d), band: wp.array(dtype=wp.float64)):
        p = wp.tid()
        b = body[p]
        kcs = p_contact[p]
        if rigid[b] == 0 or kcs[0] <= Ft(0.0):
            return
        n_pl = planes.shape[0]
        inside = int(0)
        for q in range(n_pl):
            nq = vec3d(wp.float64(plane_n[q][0]), wp.float64(plane_n[q][1]), wp.float64(plane_n[q][2]))
            xp = vec3d(wp.float64(x[p][0]), wp.float64(x[p][1]), wp.float64(x[p][2]))
            skin = wp.float64(kcs[2])
            if rad[b] > wp.float64(0.0):   # round 88: a round body at its exact shape's point (contact.plane_point)
                xp, on = round_point(centre[b], rad[b], ax[b], rot[b], xp, nq, band[b])
                skin = skin * wp.float64(1 - on)
            d = wp.float64(planes[q][0]) + skin - wp.dot(nq, xp)
            if d > wp.float64(0.0):
                wp.atomic_max(dmax, b * n_pl + q, d)
                wp.atomic_add(dsum, b * n_pl + q, wp.vec4d(d * xp[0], d * xp[1], d * xp[2], d))
                inside = 1
        if inside != 0:
            wp.atomic_add(ndepth, b, 1)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rigid_lift(rigid: wp.array(dtype=wp.int32), mass: wp.array(dtype=wp.float64),
                   inertia0: wp.array(dtype=mat33d), centre: wp.array(dtype=vec3d), rot: wp.array(dtype=mat33d),
                   vel: wp.array(dtype=vec3d), spin: wp.array(dtype=vec3d), dx: wp.float64, n_bodies: int,
                   planes: wp.array(dtype=vec3), plane_n: wp.array(dtype=vec3), dmax: wp.array(dtype=wp.float64),
                   dsum: wp.array(dtype=wp.vec4d), e_body: wp.array(dtype=Ft), vin: wp.array(dtype=Ft),
                   plane_e: wp.array(dtype=Ft), v_rest: Ft, slop: wp.float64):
        n_pl = planes.shape[0]
        b = wp.tid()   # one thread a body: each writes its own rows (dim = n_bodies)
        M = mass[b]
        if rigid[b] != 0 and M > wp.float64(0.0):
            c = centre[b]
            V = vel[b]
            w = spin[b]
            R = rot[b]
            inertia = R * inertia0[b] * wp.transpose(R) + wp.float64(0.5) * dx * dx * M * wp.identity(
                3, wp.float64)
            inv = wp.inverse(inertia)
            shift = vec3d()
            for q in range(n_pl):
                d = dmax[b * n_pl + q]
                sq = dsum[b * n_pl + q]
                if d > slop and sq[3] > wp.float64(0.0):
                    n = vec3d(wp.float64(plane_n[q][0]), wp.float64(plane_n[q][1]), wp.float64(plane_n[q][2]))
                    r = vec3d(sq[0], sq[1], sq[2]) / sq[3] - c
                    un = wp.dot(V, n)
                    # a bouncing contact keeps its restitution's law: e times the approach (its ongoing
                    # contact's, or its centre's now) at least v_rest (taichi_mpm's Rigid.rigid_lift)
                    e = wp.float64(e_body[b]) * wp.float64(plane_e[q])
                    if e_body[b] >= Ft(0.0) and e * wp.max(wp.float64(vin[b]), -un) < wp.float64(v_rest):
                        shift = shift + (d - slop) * n
                        if un < wp.float64(0.0):   # the centre's approach, through the centre: no spin
                            P = -un * M
                            V = V - un * n
                            mu = wp.float64(planes[q][1])
                            u = V + wp.cross(w, r)
                            ut = u - wp.dot(u, n) * n
                            lt = wp.length(ut)
                            if lt > wp.float64(0.0) and mu > wp.float64(0.0):
                                t = ut / lt
                                rt = wp.cross(r, t)
                                Pt = -wp.min(mu * P, lt / (wp.float64(1.0) / M + wp.dot(rt, inv * rt))) * t
                                V = V + Pt / M
                                w = w + inv * wp.cross(r, Pt)
            centre[b] = c + shift
            vel[b] = V
            spin[b] = w
        for q in range(n_pl):
            dmax[b * n_pl + q] = wp.float64(0.0)
            dsum[b * n_pl + q] = wp.vec4d()

    return rigid_depth, rigid_lift


@functools.cache
def build_rigid(Ft):
    """``(rigid_reduce, rigid_update, rigid_apply)`` for the scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)
    rigid_update = build_rigid_update(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rigid_reduce(x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), C: wp.array(dtype=mat33),
                     p_mass: wp.array(dtype=Ft), body: wp.array(dtype=wp.int32), rigid: wp.array(dtype=wp.int32),
                     dx: wp.float64, acc_p: wp.array(dtype=vec3d), acc_l: wp.array(dtype=vec3d)):
        p = wp.tid()
        b = body[p]
        if rigid[b] == 0:
            return
        m = wp.float64(p_mass[p])
        xp = vec3d(wp.float64(x[p][0]), wp.float64(x[p][1]), wp.float64(x[p][2]))
        vp = vec3d(wp.float64(v[p][0]), wp.float64(v[p][1]), wp.float64(v[p][2]))
        c = C[p]
        aff = vec3d(wp.float64(c[2, 1] - c[1, 2]), wp.float64(c[0, 2] - c[2, 0]), wp.float64(c[1, 0] - c[0, 1]))
        wp.atomic_add(acc_p, b, m * vp)
        wp.atomic_add(acc_l, b, m * wp.cross(xp, vp) + (m * wp.float64(0.25) * dx * dx) * aff)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rigid_apply(x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), C: wp.array(dtype=mat33),
                    F: wp.array(dtype=mat33), body: wp.array(dtype=wp.int32), rigid: wp.array(dtype=wp.int32),
                    X0: wp.array(dtype=vec3d), centre: wp.array(dtype=vec3d), rot: wp.array(dtype=mat33d),
                    vel: wp.array(dtype=vec3d), spin: wp.array(dtype=vec3d), carry: wp.array(dtype=wp.float64)):
        p = wp.tid()
        b = body[p]
        if rigid[b] == 0:
            return
        R = rot[b]
        w = spin[b]
        wc = carry[b] * w   # the spin the affine parts carry (gasp_core.mpm.spin_booking.spin_shares, round 76)
        r = R * X0[p]
        xn = centre[b] + r
        vn = vel[b] + wp.cross(w, r)
        x[p] = vec3(Ft(xn[0]), Ft(xn[1]), Ft(xn[2]))
        v[p] = vec3(Ft(vn[0]), Ft(vn[1]), Ft(vn[2]))
        C[p] = mat33(Ft(0.0), Ft(-wc[2]), Ft(wc[1]), Ft(wc[2]), Ft(0.0), Ft(-wc[0]), Ft(-wc[1]), Ft(wc[0]), Ft(0.0))
        F[p] = mat33(Ft(R[0, 0]), Ft(R[0, 1]), Ft(R[0, 2]), Ft(R[1, 0]), Ft(R[1, 1]), Ft(R[1, 2]),
                     Ft(R[2, 0]), Ft(R[2, 1]), Ft(R[2, 2]))

    return rigid_reduce, rigid_update, rigid_apply


class _Both:
    """Two recorded launches as one (``.launch()`` each in turn)."""

    def __init__(self, first, then):
        self.first, self.then = first, then

    def launch(self) -> None:
        self.first.launch()
        self.then.launch()


class RigidBodies:
    """The host side of the rigid limit, mixed into :class:`gasp_warp_mpm.engine.WarpMPMEngine`: the bodies' arrays
    (:meth:`_upload_rigid`), their launches after G2P (:meth:`_rigid_launches`), their share of a saved state."""

    def _upload_rigid(self) -> None:
        """Which bodies are rigid and their rest frames (``gasp_core.mpm.rigid.body_frames``, setup order)."""
        import numpy as np
        from gasp_core.mpm.rigid import body_frames, rigid_mask
        setup, d = self.setup, self.device
        rigid = rigid_mask(setup.materials)
        self.any_rigid = bool(rigid.any())
        if not self.any_rigid:
            return
        centre, self._X0_setup, inertia0, mass = body_frames(setup.x, setup.p_mass, setup.body_id, rigid)
        nb = len(rigid)
        self.rb_rigid = wp.array(rigid.astype(np.int32), dtype=wp.int32, device=d)
        self.rb_M = wp.array(mass, dtype=wp.float64, device=d)
        self.rb_I0 = wp.array(inertia0, dtype=mat33d, device=d)
        self.rb_c = wp.array(centre, dtype=vec3d, device=d)
        self.rb_R = wp.array(np.broadcast_to(np.eye(3), (nb, 3, 3)).copy(), dtype=mat33d, device=d)
        self.rb_V, self.rb_w, self.acc_p, self.acc_l = (wp.zeros(nb, dtype=t, device=d) for t in (vec3d,) * 4)
        self.X0 = wp.array(self._X0_setup[self._order], dtype=vec3d, device=d)

    def then_pose(self, passive_launch):
        """``passive_launch`` (the passive points' G2P of a substep), then, with rigid bodies, the rigid pose again
        (``rigid_apply``): the passive G2P runs after the substep's rigid launches and would move a rigid body's
        passive points (its mesh vertices, its surface) by the grid, off the pose (measured: 12.8 mm after one
        frame of the cup, ``tests/test_rigid_passive.py``); taichi_mpm projects after its passive G2P."""
        pose = getattr(self, "_rigid_pose", None)
        if pose is None:
            return passive_launch
        return _Both(passive_launch, pose)

    def _rigid_launches(self, Ft) -> list:
        """The launches of the rigid projection after G2P and of the bodies' hold (none without a rigid body)."""
        self._rigid_pose = None
        if not self.any_rigid:
            return []
        reduce_k, update_k, apply_k = build_rigid(Ft)
        from gasp_core.mpm import rigid as core_rigid   # APIC_SPIN read when built (a test sets it)
        d, dx, dt, ex = self.device, float(self.dx), float(self.dt), self._ex
        dxa = core_rigid.affine_dx(dx)   # the inertia's M dxa^2 / 2 (0 since round 67: the body's own inertia)
        self.rb_was = wp.zeros(len(self.setup.materials), dtype=wp.int32, device=d)
        self.rb_c0 = wp.zeros(len(self.setup.materials), dtype=vec3d, device=d)
        self.rb_steps = wp.zeros(len(self.setup.materials), dtype=wp.int32, device=d)
        self.rb_V0 = wp.zeros(len(self.setup.materials), dtype=vec3d, device=d)   # the velocity before the contact
        self.rb_jsup = wp.zeros(len(self.setup.materials), dtype=wp.float64, device=d)   # its supports' sum j
        from gasp_core.mpm import spin_booking
        carry, book = spin_booking.spin_shares(self.setup)   # round 76: the spin the points carry, and its booking
        self.rb_carry, self.rb_book = (wp.array(a, dtype=wp.float64, device=d) for a in (carry, book))
        out = [wp.launch(reduce_k, dim=self.n_material, device=d, record_cmd=True, inputs=[
                    self.x, self.v, self.C, self.p_mass, self.body, self.rb_rigid, dx, self.acc_p, self.acc_l]),
                wp.launch(update_k, dim=len(self.setup.materials), device=d, record_cmd=True, inputs=[
                    self.rb_rigid, self.rb_M, self.rb_I0, self.acc_p, self.acc_l, self.rb_c, self.rb_R, self.rb_V,
                    self.rb_w, dt, dxa, len(self.setup.materials), ex.rb_vin, ex.rb_vin_next, ex.rb_touch, self.rb_was,
                    self.rb_c0, ex.rb_jn, ex.rb_je, ex.rb_j, ex.rb_e, ex.v_rest, lift_off_rule(),
                    vec3d(*[float(g) for g in self.setup.gravity]), self.rb_steps, ex.rb_count, ex.rb_nlast,
                    ex.rb_twist, ex.rb_fx, ex.rb_ndepth, ex.rb_fv, ex.rb_jx, ex.rb_deep, ex.rb_flat, ex.rb_xf,
                    self.rb_V0, self.rb_jsup, int(core_rigid.ROTATION_PASSES), dx, self.rb_book]),
                wp.launch(apply_k, dim=self.n_points, device=d, record_cmd=True, inputs=[
                    self.x, self.v, self.C, self.F, self.body, self.rb_rigid, self.X0, self.rb_c, self.rb_R,
                    self.rb_V, self.rb_w, self.rb_carry])]
        self._rigid_pose = out[-1]   # rigid_apply: every point of a rigid body on its pose
        if self.pair == 1:   # two rigid bodies: their contact as one, before their points take the pose
            from gasp_core.mpm.rigid_pairs import support_data   # round 65: the bodies' support tables (rolling)
            from .rigid_support import support_arrays
            self.rb_tables = support_arrays(support_data(self.setup), d, len(self.setup.materials), self.setup)
            out.insert(2, wp.launch(build_rigid_pair(Ft), dim=1, device=d, record_cmd=True, inputs=[
                self.in_a, self.rb_M, self.rb_I0, self.rb_c, self.rb_R, self.rb_V, self.rb_w, dt, dxa,
                float(self.field_mu), self.pair_acc, *self.rb_tables]))
        elif self.pair == 2:   # round 62: rigid bodies among three or more, their pairs solved together
            from .rigid_pairs import pairs_launches   # round 81: the islands' launches on the gpu schedule
            out[2:2] = pairs_launches(self, Ft)
        n_pl = self.planes.shape[0] if self.p_contact.shape[0] == self.n_points else 0
        if n_pl:   # the resting bodies' position-level non-penetration, then their points on the pose again
            from gasp_core.mpm.rigid import RIGID_SLOP
            depth_k, lift_k = build_rigid_lift(Ft)
            nb = len(self.setup.materials)
            self.rb_dmax = wp.zeros(nb * n_pl, dtype=wp.float64, device=d)
            self.rb_dsum = wp.zeros(nb * n_pl, dtype=wp.vec4d, device=d)
            out += [wp.launch(depth_k, dim=self.n_material, device=d, record_cmd=True, inputs=[
                        self.x, self.body, self.rb_rigid, self.p_contact, self.planes, self.plane_n, self.rb_dmax,
                        self.rb_dsum, ex.rb_ndepth, self.rb_c, ex.rb_rad, ex.rb_ax, self.rb_R, ex.rb_band]),
                    wp.launch(lift_k, dim=nb, device=d, record_cmd=True, inputs=[
                        self.rb_rigid, self.rb_M, self.rb_I0, self.rb_c, self.rb_R, self.rb_V, self.rb_w, dxa, nb,
                        self.planes, self.plane_n, self.rb_dmax, self.rb_dsum, ex.rb_e, ex.rb_vin, ex.plane_e,
                        ex.v_rest, RIGID_SLOP * dx]),
                    out[-1]]
        from .rigid_hold import rigid_hold_launches   # then the flowing points held out of the bodies
        return out + rigid_hold_launches(self, Ft)

    def _contact_arrays(self) -> dict:
        """The rigid bodies' ongoing contact (the restitution's state, ``contact.build_contact_impulse``), by state
        key (taichi_mpm's ``Rigid._contact_fields``)."""
        ex = self._ex
        return {"rigid_vin": ex.rb_vin, "rigid_was": self.rb_was, "rigid_steps": self.rb_steps, "rigid_c0": self.rb_c0,
                "rigid_jn": ex.rb_jn, "rigid_je": ex.rb_je, "rigid_j": ex.rb_j, "rigid_nlast": ex.rb_nlast,
                "rigid_ndepth": ex.rb_ndepth, "rigid_w": self.rb_w, "rigid_flat": ex.rb_flat, "rigid_xf": ex.rb_xf,
                "rigid_V0": self.rb_V0, "rigid_jsup": self.rb_jsup}

    def rigid_state(self) -> dict:
        """``rigid_c`` and ``rigid_R`` of the bodies and their ongoing contact's state (``rigid_vin``, ...; empty
        without a rigid body)."""
        if not self.any_rigid:
            return {}
        return {"rigid_c": self.rb_c.numpy().copy(), "rigid_R": self.rb_R.numpy().copy(),
                **{k: a.numpy().copy() for k, a in self._contact_arrays().items()}}

    def set_rigid_state(self, state: dict) -> None:
        """Restore :meth:`rigid_state`; ``X0`` follows the restored point order (a state saved before issue 53 has
        no contact state: a body free then)."""
        if self.any_rigid:
            self.rb_c.assign(state["rigid_c"])
            self.rb_R.assign(state["rigid_R"])
            self.X0.assign(self._X0_setup[self._order])
            for k, a in self._contact_arrays().items():
                if k in state:
                    a.assign(state[k])
