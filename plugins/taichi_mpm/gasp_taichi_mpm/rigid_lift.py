"""The position-level non-penetration of a resting rigid body (issue 53, ``gasp_core.mpm.rigid_friction.settle_projection``)
as Taichi kernels; warp_mpm's ``rigid.build_rigid_lift`` spells the same steps.

``rigid_depth`` (the CPU schedule's, ordered: :mod:`gasp_taichi_mpm.schedule.ordered`) or
:meth:`RigidLift.rigid_depth_gpu` takes each rigid body's deepest penetration into each plane of the particle
contact and the penetration-weighted sum of its touching points (and counts them for the next P2G's stiffness,
``gasp_core.mpm.rigid.support_scale``); :meth:`RigidLift.rigid_lift` moves a resting body deeper than the slop out
along the plane's normal without speed (Bullet's split impulse). Both run in :meth:`gasp_taichi_mpm.rigid.Rigid.
rigid_step` after the rigid update, then the points are put on the pose again. Here too the rebound at the end of a
contact, :meth:`RigidLift.lift_off` (called by ``Rigid.rigid_update``; ``gasp_core.mpm.restitution.LIFT_OFF``).

Mixed into :class:`gasp_taichi_mpm.rigid.Rigid` (so into :class:`gasp_taichi_mpm.solver.MPMSolver`), whose fields
(``rb_*``, ``p_contact``, ``plane_n``, ``plane_row``) it reads.
"""
import numpy as np
import taichi as ti

from gasp_core.mpm.contact import DAMPING
from gasp_core.mpm.rigid import RIGID_OMEGA_DT, RIGID_SLOP
from gasp_core.mpm.grid_tables import COL_POSE, FT_POSES, PO_W
import gasp_core.mpm.round_ground as round_ground
from gasp_core.mpm.round_ground import CYL_LINE, level_band

#: A signed distance at or above this (m) is off the field's grid (``colliders.field_at`` gives 1e30 there).
OFF_GRID = 1.0e29


class RigidLift:
    """The two kernels of the resting bodies' non-penetration."""

    #: Round 89: a round body meets the colliders on its exact shape too (``round_ground.ROUND_COLLIDER``, read when
    #: the kernels compile: :meth:`set_round`).
    round_col = False

    @ti.func
    def is_sphere(self, p) -> bool:
        """Whether point p belongs to a rigid sphere or solid cylinder met on its exact shape (``rb_rad`` > 0, round
        88)."""
        out = False
        if ti.static(self.any_rigid):
            out = self.rb_rad[self.body[p]] > 0.0
        return out

    @ti.func
    def plane_point(self, p, n):
        """``(x, v, kcs, own)``: where point p meets a plane of normal ``n``, its velocity there, its contact row and
        whether that row is its own (not scaled by ``contact_impulse``). A rigid sphere's or cylinder's points (round
        88, ``gasp_core.mpm.round_ground``): its exact contact point ``x*`` (:meth:`round_point`), moving at ``v + w x
        (x* - x)``,
        each its mass's share of the body's stiffness ``(w2 m, 2 DAMPING sqrt(w2) m, 0)``, ``w2 = (RIGID_OMEGA_DT /
        dt)^2``; every other point at itself with ``p_contact[p]`` (warp_mpm's ``contact.build_plane_point``)."""
        x = self.x[p]
        v = self.v[p]
        kcs = self.p_contact[p]
        own = 0
        xq = ti.cast(x, ti.f64)
        if self.is_sphere(p):
            xq, own = self.round_point(self.body[p], xq, ti.cast(n, ti.f64))
        if own != 0:
            b = self.body[p]
            v += ti.cast(self.rb_w[b].cross(xq - ti.cast(x, ti.f64)), self.real)
            x = ti.cast(xq, self.real)
            dt = self.dt[None]
            m = self.p_mass[p]
            k = (RIGID_OMEGA_DT / dt) ** 2 * m
            kcs = ti.Vector([k, 2.0 * DAMPING * ti.sqrt(k * m), 0.0], self.real)
        return x, v, kcs, own

    @ti.func
    def round_point(self, b, x, n):
        """``(x*, on)``: where point ``x`` (f64) of round body b meets a plane of normal ``n`` on its exact shape (round
        88, ``gasp_core.mpm.round_ground``): a sphere at ``c - R n``; a cylinder (its rest axis ``rb_ax[b]`` turned by
        ``rb_R[b]`` to ``e``) on the line under its axis at the point's slice, ``c + (e . (x - c)) e - R n_perp``; ``on``
        0 (the point itself) within ``CYL_LINE`` of standing on an end (warp_mpm's ``contact.round_point``)."""
        c = self.rb_c[b]
        u = n
        on = 1
        if self.rb_ax[b].norm() > 0.0:
            e = self.rb_R[b] @ self.rb_ax[b]
            ne = n.dot(e)
            if ti.abs(ne) < CYL_LINE:   # level within rb_band (round_ground.level_band), tilted by the rest
                sl = (x - c).dot(e)
                c += sl * e - sl * (ne - ti.math.sign(ne) * ti.max(ti.abs(ne) - self.rb_band[b], 0.0)) * n
                u = (n - ne * e) / ti.sqrt(1.0 - ne * ne)
            else:
                on = 0
        out = x
        if on != 0:
            out = c - self.rb_rad[b] * u
        return out, on

    @ti.func
    def round_collider(self, p, c, base):
        """``(on, depth, n, v_c, x*, v*, kcs*)``: where point p of a round rigid body meets collider c (its pose at the
        time-table row ``base``) on the body's exact shape (round 89, ``gasp_core.mpm.round_ground.collider_reach``):
        the field read at the centre (a sphere) or at the point's slice of the axis ``y`` (a cylinder), the depth ``-
        (phi(y) + n . (x* - y))`` (m), the field's unit gradient ``n`` there, the collider's velocity at the contact
        point ``x*`` (:meth:`round_point`), the point's velocity moved there and its mass's share of the body's stiffness
        (as :meth:`plane_point`); ``on`` 0 where it keeps its own contact (the field off its grid at ``y``, a cylinder
        near standing on an end). warp_mpm's ``round_collider.build_round_collider``."""
        b = self.body[p]
        x = self.x[p]
        v = self.v[p]
        xd = ti.cast(x, ti.f64)
        y = self.rb_c[b]
        if self.rb_ax[b].norm() > 0.0:   # a cylinder: its slice of the axis
            e = self.rb_R[b] @ self.rb_ax[b]
            y += (xd - y).dot(e) * e
        R = self.rb_rad[b]
        yf = ti.cast(y, self.real)
        phi, n, vcy = self.collider_at(yf, c, base, ti.cast(2.0 * R, self.real))   # wherever it may touch (warp's)
        on = 0
        depth = ti.cast(0.0, self.real)
        xq, vq, vc = x, v, vcy
        kq = ti.Vector.zero(self.real, 3)
        if phi < OFF_GRID:
            on = 1   # held: the exact shape decides, touching or not
            if phi <= 2.0 * R:
                nd = ti.cast(n, ti.f64)
                q, at = self.round_point(b, xd, nd)
                on = at
                if at != 0:
                    depth = ti.cast(-(ti.cast(phi, ti.f64) + nd.dot(q - y)), self.real)
                    xq = ti.cast(q, self.real)
                    vq = v + ti.cast(self.rb_w[b].cross(q - xd), self.real)
                    p0 = base + FT_POSES + COL_POSE * c
                    om = ti.Vector([self.ex_tab[p0 + PO_W], self.ex_tab[p0 + PO_W + 1], self.ex_tab[p0 + PO_W + 2]])
                    vc = vcy + om.cross(xq - yf)
                    m = self.p_mass[p]
                    k = (RIGID_OMEGA_DT / self.dt[None]) ** 2 * m
                    kq = ti.Vector([k, 2.0 * DAMPING * ti.sqrt(k * m), 0.0], self.real)
            else:
                depth = ti.cast(R, self.real) - phi   # apart: no contact
        return on, depth, n, vc, xq, vq, kq

    @ti.func
    def collider_point(self, p, c, base):
        """``(depth, n, v_c, x*, v*, kcs*, own)`` of point p against collider c: a round rigid body's on its exact shape
        (:meth:`round_collider`, ``own`` 1), every other point at itself with ``p_contact[p]``, ``depth = skin - phi``
        (``contact.point_contact``)."""
        kcs = self.p_contact[p]
        on = 0
        depth = ti.cast(0.0, self.real)
        n = ti.Vector.zero(self.real, 3)
        vc = ti.Vector.zero(self.real, 3)
        xq, vq, kq = self.x[p], self.v[p], kcs
        if ti.static(self.round_col):
            if self.is_sphere(p):
                on, depth, n, vc, xq, vq, kq = self.round_collider(p, c, base)
        if on == 0:
            phi, n0, vc0 = self.collider_at(self.x[p], c, base, kcs[2])
            depth = kcs[2] - phi
            n, vc, xq, vq, kq = n0, vc0, self.x[p], self.v[p], kcs
        return depth, n, vc, xq, vq, kq, on

    def set_round(self, shapes) -> None:
        """The rigid bodies' exact round shapes (``gasp_core.mpm.round_ground.ground_shapes``, shape (n_bodies, 5))
        and their cylinders' level bands (``level_band``); whether they meet the colliders on them too
        (:data:`gasp_core.mpm.round_ground.ROUND_COLLIDER`, :meth:`round_collider`)."""
        shapes = np.asarray(shapes, np.float64)
        self.round_col = bool(round_ground.ROUND_COLLIDER) and bool(np.any(shapes[:, 0] > 0.0))
        self.rb_rad.from_numpy(shapes[:, 0])
        self.rb_ax.from_numpy(shapes[:, 2:])
        self.rb_band.from_numpy(level_band(shapes, RIGID_SLOP * float(self.dx[None])))

    @ti.func
    def depth_point(self, p, t, sliced: ti.template()):
        """Point p's penetration into each plane: the deepest (an atomic max: the same in any order), the count,
        and the weighted sums into ``rb_dsum`` (serial) or slice t's row of ``rb_dsums`` (``sliced``)."""
        b = self.body[p]
        kcs = self.p_contact[p]
        if self.rb_rigid[b] != 0 and kcs[0] > 0.0:
            inside = 0
            for q in range(self.n_planes):
                n = ti.cast(self.plane_n[q], ti.f64)
                x = ti.cast(self.x[p], ti.f64)
                skin = ti.cast(kcs[2], ti.f64)
                if self.rb_rad[b] > 0.0:   # round 88: a round body at its exact shape's point (plane_point)
                    xq, on = self.round_point(b, x, n)
                    if on != 0:
                        x = xq
                        skin = 0.0
                d = ti.cast(self.plane_row[q][0], ti.f64) + skin - n.dot(x)
                if d > 0.0:
                    k = b * self.n_planes + q
                    ti.atomic_max(self.rb_dmax[k], d)
                    w = ti.Vector([d * x[0], d * x[1], d * x[2], d], ti.f64)
                    if ti.static(sliced):
                        for c in ti.static(range(4)):
                            self.rb_dsums.part[t, k * 4 + c] += w[c]
                    else:
                        self.rb_dsum[k] += w
                    inside = 1
            if inside != 0:
                ti.atomic_add(self.rb_ndepth[b], 1)

    @ti.kernel
    def rigid_depth_gpu(self):
        """:meth:`rigid_depth` on the GPU schedule: slices of ``rb_slice`` points, one thread a slice; the weighted
        sums by a fixed tree; the deepest and the count by integer-exact atomics."""
        n = self.n_points[None]
        nt = (n + self.rb_slice - 1) // self.rb_slice
        self.rb_dsums.clear(nt)
        for t in range(nt):
            for p in range(t * self.rb_slice, ti.min(t * self.rb_slice + self.rb_slice, n)):
                self.depth_point(p, t, True)
        self.rb_dsums.reduce(nt)
        for k in range(self.n_bodies * self.n_planes):
            self.rb_dsum[k] = ti.Vector([self.rb_dsums.out[k * 4 + c] for c in ti.static(range(4))], ti.f64)

    @ti.kernel
    def rigid_lift(self):
        """The position-level non-penetration of a resting rigid body (``gasp_core.mpm.rigid_friction.settle_projection``,
        issue 53; warp_mpm's ``rigid_lift``): a body that is not bouncing (``e`` times its approach, the ongoing
        contact's ``v_in`` or its centre's now, under ``v_rest``, as :meth:`lift_off`) whose deepest point is more
        than ``RIGID_SLOP`` cells into a plane is moved out along its normal to that depth, its velocity untouched by
        the move (Bullet's split impulse, no Baumgarte term), and its centre's approach removed (an impulse through
        the centre: no spin), with Coulomb's friction of that impulse at the touching points' penetration-weighted
        centre."""
        dx = ti.cast(self.dx[None], ti.f64)
        slop = RIGID_SLOP * dx
        # each body its own (writes only its own rows): parallel on both schedules, the same bits
        for b in range(self.n_bodies):
            M = self.rb_M[b]
            if self.rb_rigid[b] != 0 and M > 0.0:
                c = self.rb_c[b]
                V = self.rb_V[b]
                w = self.rb_w[b]
                R = self.rb_R[b]
                inertia = R @ self.rb_I0[b] @ R.transpose() + 0.5 * self.rb_aff[None] * dx * dx * M * ti.Matrix.identity(
                    ti.f64, 3)
                inv = inertia.inverse()
                shift = ti.Vector.zero(ti.f64, 3)
                for q in range(self.n_planes):
                    d = self.rb_dmax[b * self.n_planes + q]
                    sq = self.rb_dsum[b * self.n_planes + q]
                    if d > slop and sq[3] > 0.0:
                        n = ti.cast(self.plane_n[q], ti.f64)
                        r = ti.Vector([sq[0], sq[1], sq[2]]) / sq[3] - c
                        un = V.dot(n)
                        # a bouncing contact keeps its restitution's law: e times the approach (its ongoing
                        # contact's, or its centre's now) at least v_rest
                        e = ti.cast(self.rb_e[b], ti.f64) * ti.cast(self.plane_e[q], ti.f64)
                        vin = ti.max(ti.cast(self.rb_vin[b], ti.f64), -un)
                        if self.rb_e[b] >= 0.0 and e * vin < ti.cast(self.v_rest[None], ti.f64):
                            shift += (d - slop) * n
                            if un < 0.0:   # the centre's approach, through the centre: no spin
                                P = -un * M
                                V = V - un * n
                                mu = ti.cast(self.plane_row[q][1], ti.f64)
                                u = V + w.cross(r)
                                ut = u - u.dot(n) * n
                                lt = ut.norm()
                                if lt > 0.0 and mu > 0.0:
                                    t = ut / lt
                                    rt = r.cross(t)
                                    Pt = -ti.min(mu * P, lt / (1.0 / M + rt.dot(inv @ rt))) * t
                                    V = V + Pt / M
                                    w = w + inv @ r.cross(Pt)
                self.rb_c[b] = c + shift
                self.rb_V[b] = V
                self.rb_w[b] = w
            for q in range(self.n_planes):
                self.rb_dmax[b * self.n_planes + q] = 0.0
                self.rb_dsum[b * self.n_planes + q] = ti.Vector.zero(ti.f64, 4)

    @ti.func
    def lift_off(self, b, V, c, T):
        """Body b's velocity ``V`` (m/s, float64) at the substep its contact ends (no point touched in this P2G,
        one did in the last), its centre at ``c`` (m), ``T`` (s) after the contact began: its normal part along the
        contact's mean normal ``n`` made :func:`gasp_core.mpm.restitution.lift_off_speed`'s, with which its free
        flights before and after cross as an instantaneous bounce of restitution ``e`` (the body's times its
        supports' impulse-weighted; 0 when ``e v_in`` is below ``v_rest``): the restitution at the impulse level,
        whatever the hysteresis gave back in a contact of a few substeps; by ``restitution.LIFT_OFF``'s rule
        (:meth:`lift_normal`)."""
        out = V
        if self.rb_e[b] >= 0.0 and self.rb_touch[b] == 0 and self.rb_was[b] != 0 and self.rb_j[b] > 0.0:
            jn = ti.cast(self.rb_jn[b], ti.f64)
            if jn.norm() > 0.0:
                n = jn / jn.norm()
                e = ti.cast(self.rb_e[b] * self.rb_je[b] / self.rb_j[b], ti.f64)
                vin = ti.cast(self.rb_vin[b], ti.f64)
                if e * vin < ti.cast(self.v_rest[None], ti.f64):
                    e = 0.0
                g_n = -ti.cast(self.gravity[None], ti.f64).dot(n)
                # A^2 + B A - C = 0, u = A - g_n T (gasp_core.mpm.restitution.lift_off_speed)
                B = vin * (1.0 - e) - (1.0 + e) * g_n * T
                C = e * vin * vin - (1.0 + e) * g_n * ((c - self.rb_c0[b]).dot(n) + 0.5 * g_n * T * T)
                u_out = 0.5 * (-B + ti.sqrt(ti.max(B * B + 4.0 * C, 0.0))) - g_n * T
                u = V.dot(n)
                if u > 0.0:
                    out = V + (self.lift_normal(b, u, ti.max(u_out, 0.0), V, n, g_n, T) - u) * n
        return out

    @ti.func
    def lift_normal(self, b, u, u_out, V, n, g_n, T):
        """Body b's normal speed (m/s) at lift-off by ``restitution.LIFT_OFF``'s rule
        (``gasp_core.mpm.restitution.lift_off_normal``): ``u`` now, ``u_out`` the free flights', along ``n``, ``g_n``
        gravity's pull (m/s^2), ``T`` (s) the contact's touching substeps; the other bodies' normal impulse over the
        contact ``J_o = M (V - V_0) . n - J_sup + M g_n (T + dt)`` (``V_0`` before its first substep, ``J_sup`` the
        supports' summed ``j``: a patch's normals taken as ``n``)."""
        out = u_out
        rule = self.lift_rule[None]
        if rule == 2:
            out = ti.min(u, u_out)
        elif rule == 1:
            M = self.rb_M[b]
            dt = ti.cast(self.dt[None], ti.f64)
            j_o = M * (V - self.rb_V0[b]).dot(n) - self.rb_jsup[b] + M * g_n * (T + dt)
            out = ti.min(u_out, ti.max(u, u_out + j_o / M))
        return out
