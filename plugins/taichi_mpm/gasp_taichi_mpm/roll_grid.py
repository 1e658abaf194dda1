"""Round 70: the engine option ``roll_contact`` in Taichi (``gasp_core.mpm.roll_contact``; ``docs/rigid.md`` "Round
70"), warp_mpm's ``roll_grid.py`` (its module notes): after round 67's normal passes (frictionless, ``point_grid.py``
with the spheres' exact patches), friction one impulse a patch (a pair: a slot's body and a soft body): ``rg_clear``,
``rg_sum`` (the patch's normal impulse and centre), ``rg_share`` and ``rg_resp`` (the patch's grid response), then
``FRICTION_PASSES`` times ``rg_slip`` (its mean slip), ``rg_solve`` (one thread a pair: the step, capped at ``mu
Lambda``), ``rg_apply`` (the step to the points' nodes by their shares, the opposite to the body), ``pg_body``,
``pg_node``. Pair data ``rg_T``: warp_mpm's layout (0-2 the mean slip, 3 ``Lambda``, 4-6 ``sum lambda r``, 7 ``G``,
8-10 ``J``, 11-13 ``dJ``). Mixed into ``point_grid.PointGrid``.
"""
import taichi as ti

#: The floats of a pair in ``rg_T`` (warp_mpm's ``roll_grid.NT``); a slot's in ``pg_sl`` (``point_grid.NS``).
NT = 16
NS = 32


@ti.data_oriented
class RollGrid:
    """The patch friction's fields and kernels (``pg_pf`` False: none)."""

    pg_pf = False
    rg_pmul = 1

    def allocate_roll(self) -> None:
        import gasp_core.mpm.roll_contact as roll
        self.rg_npair = int(self.rc_ns) * int(self.rc_ncol)
        self.rg_T = ti.field(ti.f64, shape=NT * self.rg_npair)
        self.rg_passes = int(roll.FRICTION_PASSES)
        self.rg_pmul = 1 if roll.PAIRS else 0   # round 71: the broken variant PAIRS 0 (every slot's patch one)

    @ti.func
    def rg_frame(self, base, fx, w, f):
        """A soft point's patch frame (round 67's, shared by ``pg_mark`` and the exact shapes): its field ``f``'s outward
        normal ``-grad m`` from the node masses ``pc_m`` over its stencil (``base``, ``fx``, weights ``w``), and two
        unit tangents ``t1, t2`` across it; ``(has, t1, t2)``, ``has`` 0 where the mass has no gradient (the
        tangents then unused)."""
        dw = [fx - 1.5, -2.0 * (fx - 1.0), fx - 0.5]
        gm = ti.Vector.zero(ti.f64, 3)
        for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
            m = ti.cast(self.pc_m[f, base + ti.Vector([i, j, k])], ti.f64)
            gm += m * ti.cast(ti.Vector([dw[i][0] * w[j][1] * w[k][2], w[i][0] * dw[j][1] * w[k][2],
                                         w[i][0] * w[j][1] * dw[k][2]]), ti.f64)
        has = 0
        t1 = ti.Vector([1.0, 0.0, 0.0], ti.f64)
        t2 = ti.Vector([0.0, 1.0, 0.0], ti.f64)
        if gm.norm() > 0.0:
            has = 1
            mn = -gm.normalized()
            t1 = mn.cross(ti.Vector([1.0, 0.0, 0.0], ti.f64))
            if ti.abs(mn[0]) > 0.9:
                t1 = mn.cross(ti.Vector([0.0, 1.0, 0.0], ti.f64))
            t1 = t1.normalized()
            t2 = mn.cross(t1)
        return has, t1, t2

    @ti.func
    def rg_domain(self, xp, a, c, e):
        """Round 83 (``gasp_core.mpm.roll_contact.domain_point``; warp_mpm's ``roll_shape.domain_near``): the offset
        of the point of a soft point's domain (the cube ``xp + u``, ``|u_k| <= a`` on the fill's axes) nearest the
        point ``c`` (``e`` zero: the clamp) or the line through ``c`` along the unit ``e`` (``rg_bisect`` bisections
        of the convex distance's derivative along the line)."""
        b = c - xp
        if e.norm() > 0.0:
            t0 = -b.dot(e)
            h = ti.sqrt(3.0) * a
            lo, hi = t0 - h, t0 + h
            for _ in range(self.rg_bisect):
                t = 0.5 * (lo + hi)
                l = b + t * e
                if (l - ti.min(ti.max(l, -a), a)).dot(e) < 0.0:
                    lo = t
                else:
                    hi = t
            b = b + 0.5 * (lo + hi) * e
        return ti.min(ti.max(b, -a), a)

    @ti.func
    def rg_sphere(self, xp, base, fx, w, f, skin, best, sb, nb, dlt):
        """``pg_mark``'s read of the round bodies that are spheres (``pg_sph``): the soft point at ``xp`` as its
        patch (its field ``f``'s outward normal from the node masses ``pc_m``), the least distance over it exactly
        (warp_mpm's ``pg_mark``); ``(best, sb, nb, dlt)`` where nearer than ``best``."""
        pm = self.pg_patch * ti.cast(self.dx[None], ti.f64)
        b_out, s_out, n_out, d_out = best, sb, nb, dlt
        for s in range(self.rc_ns):
            c = self.rb_c[self.rc_bodies[s]]
            if self.rc_pt[s] != 0 and self.pg_sph[s] > 0.0 and (xp - c).norm() < self.pg_sph[s] + skin + \
                    6.0 * pm:
                q = ti.Vector.zero(ti.f64, 3)
                lift = ti.cast(0.0, ti.f64)
                if ti.static(self.rg_dom != 0):   # round 83: the point as its domain, compared as a face's patch
                    q = self.rg_domain(xp, pm, c, ti.Vector.zero(ti.f64, 3))
                    lift = pm
                else:
                    has, t1, t2 = self.rg_frame(base, fx, w, f)
                    if has != 0 and pm > 0.0:
                        q = ti.min(ti.max((c - xp).dot(t1), -pm), pm) * t1 + ti.min(ti.max((c - xp).dot(t2),
                                                                                           -pm), pm) * t2
                rq = xp + q - c
                if rq.norm() - self.pg_sph[s] + lift < b_out and rq.norm() > 0.0:
                    b_out = rq.norm() - self.pg_sph[s] + lift
                    s_out = s
                    n_out = rq.normalized()
                    d_out = q
                    if ti.static(self.pg_sarm != 0):   # the arm to the sphere's surface
                        d_out = c + self.pg_sph[s] * n_out - xp
                    elif ti.static(self.rg_dom != 0):   # the broken variant's: a quarter cell under the face (round 83)
                        d_out = q + lift * n_out
        return b_out, s_out, n_out, d_out

    @ti.func
    def rg_cylinder(self, xp, base, fx, w, f, skin, best, sb, nb, dlt):
        """Round 72: ``pg_mark``'s read of the solid cylinders (``pg_cyl``: radius, half-length, rest-frame axis; the
        axis turned by the body's rotation): the patch's point nearest the axis's line (``CYL_SWEEPS`` sweeps of
        coordinate descent), the capped cylinder's signed distance and normal there, the arm at its surface point
        (warp_mpm's ``roll_shape.cyl_patch``; ``gasp_core.mpm.roll_contact.cylinder_patch``)."""
        pm = self.pg_patch * ti.cast(self.dx[None], ti.f64)
        b_out, s_out, n_out, d_out = best, sb, nb, dlt
        for s in range(self.rc_ns):
            rb = self.rc_bodies[s]
            c = self.rb_c[rb]
            R, h = self.pg_cyl[s, 0], self.pg_cyl[s, 1]
            if self.rc_pt[s] != 0 and R > 0.0 and (xp - c).norm() < ti.sqrt(R * R + h * h) + skin + 6.0 * pm:
                Rb = self.rb_R[rb]
                if ti.static(self.rg_turn == 0):   # a broken variant: the axis turned the wrong way
                    Rb = Rb.transpose()
                e = (Rb @ ti.Vector([self.pg_cyl[s, 2], self.pg_cyl[s, 3], self.pg_cyl[s, 4]])).normalized()
                d = xp - c
                q = ti.Vector.zero(ti.f64, 3)
                lift = ti.cast(0.0, ti.f64)
                if ti.static(self.rg_dom != 0):   # round 83: the point as its domain, compared as a face's patch
                    q = self.rg_domain(xp, pm, c, e)
                    lift = pm
                else:
                    has, t1, t2 = self.rg_frame(base, fx, w, f)
                    if has != 0 and pm > 0.0:
                        a1, a2, b = t1 - t1.dot(e) * e, t2 - t2.dot(e) * e, d - d.dot(e) * e
                        u, v = ti.cast(0.0, ti.f64), ti.cast(0.0, ti.f64)
                        for _ in range(self.rg_sweeps):
                            if a1.dot(a1) > 1.0e-12:
                                u = ti.min(ti.max(-a1.dot(b + v * a2) / a1.dot(a1), -pm), pm)
                            if a2.dot(a2) > 1.0e-12:
                                v = ti.min(ti.max(-a2.dot(b + u * a1) / a2.dot(a2), -pm), pm)
                        q = u * t1 + v * t2
                y = d + q
                z = y.dot(e)
                rr = y - z * e
                rho = rr.norm()
                dr, dz = rho - R, ti.abs(z) - h
                er = rr / ti.max(rho, 1.0e-300)
                ez = e if z >= 0.0 else -e
                phi, n = dz, ez
                if dr > 0.0 and dz > 0.0:
                    phi = ti.sqrt(dr * dr + dz * dz)
                    n = (dr * er + dz * ez) / phi
                elif dr >= dz:
                    phi, n = dr, er
                if phi + lift < b_out:
                    b_out, s_out, n_out, d_out = phi + lift, s, n, q
                    if ti.static(self.pg_sarm != 0):   # the arm to the cylinder's surface point
                        d_out = q - phi * n
                    elif ti.static(self.rg_dom != 0):   # the broken variant's: a quarter cell under the face (round 83)
                        d_out = q + lift * n
        return b_out, s_out, n_out, d_out

    @ti.func
    def rg_pair(self, p):
        k = -1
        if self.pc_s[p] >= 0 and self.pg_ln[p] > 0.0:
            k = self.pc_s[p] * self.rc_ncol * self.rg_pmul + self.rc_cols[self.body[p]]   # round 71: roll.PAIRS
        return k

    @ti.kernel
    def rg_clear(self):
        for i in range(NT * self.rg_npair):
            self.rg_T[i] = 0.0

    @ti.kernel
    def rg_sum(self):
        for p in range(self.n_points[None]):
            k = self.rg_pair(p)
            if k >= 0:
                r = ti.cast(self.x[p], ti.f64) + self.pc_x[p] - self.rb_c[self.rc_bodies[self.pc_s[p]]]
                self.rg_T[NT * k + 3] += self.pg_ln[p]
                for ax in ti.static(range(3)):
                    self.rg_T[NT * k + 4 + ax] += self.pg_ln[p] * r[ax]

    @ti.kernel
    def rg_share(self):
        for p in range(self.n_points[None]):
            k = self.rg_pair(p)
            if k >= 0:
                a = self.pg_ln[p] / self.rg_T[NT * k + 3]
                base, fx, ok = self.base_fx(self.x[p])
                w = self.weights(fx)
                f = 1 - self.in_a[self.body[p]]
                for i, j, q in ti.static(ti.ndrange(3, 3, 3)):
                    self.pg_tw[f, base + ti.Vector([i, j, q])] += a * ti.cast(w[i][0] * w[j][1] * w[q][2], ti.f64)

    @ti.kernel
    def rg_resp(self):
        for p in range(self.n_points[None]):
            k = self.rg_pair(p)
            if k >= 0:
                a = self.pg_ln[p] / self.rg_T[NT * k + 3]
                base, fx, ok = self.base_fx(self.x[p])
                w = self.weights(fx)
                f = 1 - self.in_a[self.body[p]]
                g = ti.cast(0.0, ti.f64)
                for i, j, q in ti.static(ti.ndrange(3, 3, 3)):
                    I = base + ti.Vector([i, j, q])
                    m = ti.cast(self.pc_m[f, I], ti.f64)
                    if m > 0.0:
                        g += ti.cast(w[i][0] * w[j][1] * w[q][2], ti.f64) * self.pg_tw[f, I] / m
                self.rg_T[NT * k + 7] += a * g

    @ti.kernel
    def rg_slip(self):
        for p in range(self.n_points[None]):
            k = self.rg_pair(p)
            if k >= 0:
                base, fx, ok = self.base_fx(self.x[p])
                w = self.weights(fx)
                v = ti.Vector.zero(self.real, 3)
                for i, j, q in ti.static(ti.ndrange(3, 3, 3)):
                    v += w[i][0] * w[j][1] * w[q][2] * self.node_v(p, base + ti.Vector([i, j, q]))
                s = self.pc_s[p]
                r = ti.cast(self.x[p], ti.f64) + self.pc_x[p] - self.rb_c[self.rc_bodies[s]]
                u = ti.cast(v, ti.f64) - self.pg_v(NS * s, r)
                n = self.pc_n[p]
                ut = (u - u.dot(n) * n) * (self.pg_ln[p] / self.rg_T[NT * k + 3])
                for ax in ti.static(range(3)):
                    self.rg_T[NT * k + ax] += ut[ax]

    @ti.kernel
    def rg_solve(self):
        for k in range(self.rg_npair):
            t = NT * k
            L = self.rg_T[t + 3]
            for ax in ti.static(range(3)):
                self.rg_T[t + 11 + ax] = 0.0
            us = ti.Vector([self.rg_T[t], self.rg_T[t + 1], self.rg_T[t + 2]])
            if L > 0.0 and us.norm() > 0.0:
                s = k // self.rc_ncol
                o = NS * s
                Ii = ti.Matrix.zero(ti.f64, 3, 3)
                for a, b in ti.static(ti.ndrange(3, 3)):
                    Ii[a, b] = self.pg_sl[o + 16 + 3 * a + b]
                rc = ti.Vector([self.rg_T[t + 4], self.rg_T[t + 5], self.rg_T[t + 6]]) / L
                arm = rc.cross(us.normalized())
                S = self.rg_T[t + 7] + 1.0 / self.rb_M[self.rc_bodies[s]] + arm.dot(Ii @ arm)
                J0 = ti.Vector([self.rg_T[t + 8], self.rg_T[t + 9], self.rg_T[t + 10]])
                J1 = J0 - us / S
                cap = self.rc_friction * self.rc_mus[k] * L
                if J1.norm() > cap:
                    J1 = J1 * (cap / J1.norm())
                for ax in ti.static(range(3)):
                    self.rg_T[t + 8 + ax] = J1[ax]
                    self.rg_T[t + 11 + ax] = J1[ax] - J0[ax]
            for ax in ti.static(range(3)):
                self.rg_T[t + ax] = 0.0

    @ti.kernel
    def rg_apply(self):
        for p in range(self.n_points[None]):
            k = self.rg_pair(p)
            if k >= 0:
                D = ti.Vector([self.rg_T[NT * k + 11], self.rg_T[NT * k + 12], self.rg_T[NT * k + 13]]) * (
                    self.pg_ln[p] / self.rg_T[NT * k + 3])
                base, fx, ok = self.base_fx(self.x[p])
                w = self.weights(fx)
                f = 1 - self.in_a[self.body[p]]
                for i, j, q in ti.static(ti.ndrange(3, 3, 3)):
                    self.pc_g[f, base + ti.Vector([i, j, q])] += ti.cast(w[i][0] * w[j][1] * w[q][2], ti.f64) * D
                if ti.static(self.pc_react_on != 0):
                    s = self.pc_s[p]
                    rb = self.rc_bodies[s]
                    xp = ti.cast(self.x[p], ti.f64) + self.pc_x[p]
                    L = (xp - self.rb_c[rb]).cross(-D)
                    for ax in ti.static(range(3)):
                        self.pg_sl[NS * s + ax] += -D[ax]
                        self.pg_sl[NS * s + 3 + ax] += L[ax]
                    Lo = xp.cross(-D)
                    self.rc_react[rb] += ti.Vector([-D[0], -D[1], -D[2], Lo[0], Lo[1], Lo[2]])

    def roll_friction(self) -> None:
        """After the normal passes (module notes)."""
        self.rg_clear()
        self.rg_sum()
        self.rg_share()
        self.rg_resp()
        self.pg_node()   # pg_tw cleared (pc_g is zero: nothing applied)
        for _ in range(self.rg_passes):
            self.rg_slip()
            self.rg_solve()
            self.rg_apply()
            self.pg_body(0)
            self.pg_node()
