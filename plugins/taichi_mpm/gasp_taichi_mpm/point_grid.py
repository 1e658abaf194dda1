"""Round 67: the point contact as a constraint of the grid velocities in Taichi (``gasp_core.mpm.rigid_sdf.GRID_PASSES``
> 0; ``docs/rigid.md`` "Round 67: the point contact as a constraint of the grid"), the steps of warp_mpm's
``point_grid.py`` (its module notes): ``pg_body`` (one thread a slot: ``V*``, the spin, the inverse inertia, the
sums cleared), ``pg_mark`` (a point each: the touching points, their normals and targets, their weights into ``pg_tw``),
``pg_pre`` (a point each: the row-sum bounds), then ``GRID_PASSES`` times ``pg_pass`` (a point each: gather, residual,
the impulse's step to ``pc_g`` and the opposite to the body), ``pg_body`` (the body's velocity), ``pg_node`` (a node
each: the nodes take the steps). Mixed into ``point_contact.PointContact``.
"""
import numpy as np
import taichi as ti

from .collider_pair import NA
from .roll_grid import RollGrid

#: The floats of a slot in ``pg_sl`` (warp_mpm's ``point_grid.NS`` layout).
NS = 32


@ti.data_oriented
class PointGrid(RollGrid):
    """The grid constraint's fields and kernels (``pg_on`` False: round 66's contact per point); round 70's option
    ``roll_contact`` (``pg_roll``: the spheres' exact patches in ``pg_mark``, the patch friction of ``roll_grid.py``)."""

    pg_on = False
    pg_roll = False
    pg_fmul = 1.0
    pg_sarm = 1
    pg_hascyl = False
    rg_turn = 1
    rg_sweeps = 4
    rg_dom = 1
    rg_bisect = 48

    def allocate_grid(self, points) -> None:
        from gasp_core.mpm import rigid_sdf
        import gasp_core.mpm.roll_contact as roll
        self.pg_roll = bool(points.get("roll", 0))   # round 70 (roll_grid.py)
        self.pg_passes = int(roll.NORMAL_PASSES) if self.pg_roll else int(rigid_sdf.GRID_PASSES)
        self.pg_on = self.pg_passes > 0
        if not self.pg_on:
            return
        n, ng, ns = self.x.shape[0], self.n_grid, int(self.rc_ns)
        self.pg_sl = ti.field(ti.f64, shape=NS * ns)
        self.pg_ln = ti.field(ti.f64, shape=n)
        self.pg_lt = ti.Vector.field(3, ti.f64, shape=n)
        self.pg_S = ti.Vector.field(2, ti.f64, shape=n)
        self.pg_tw = ti.field(ti.f64, shape=(2, ng, ng, ng))
        self.pg_patch = float(roll.PATCH if self.pg_roll else rigid_sdf.PATCH)
        self.pg_sph = ti.field(ti.f64, shape=ns)   # round 70: a sphere's exact radius (0: its lattice)
        self.pg_sph.from_numpy(np.asarray(points.get("sphere", np.zeros(ns)), np.float64))
        self.pg_sarm = int(roll.SURFACE_ARM)
        self.pg_cyl = ti.field(ti.f64, shape=(ns, 5))   # round 72: a cylinder's radius, half-length, axis (R 0: none)
        self.pg_cyl.from_numpy(np.asarray(points.get("cylinder", np.zeros((ns, 5))), np.float64).reshape(ns, 5))
        self.rg_sweeps = int(roll.CYL_SWEEPS)
        self.rg_turn = int(roll.CYL_TURN)
        self.rg_dom = int(roll.DOMAIN)   # round 83: the point read as its domain (roll_grid.rg_domain)
        self.rg_bisect = int(roll.DOMAIN_BISECT)
        self.pg_hascyl = bool(np.asarray(points.get("cylinder", np.zeros((ns, 5))))[:, 0].any())
        self.pg_pf = self.pg_roll and bool(roll.PATCH_FRICTION)
        self.pg_fmul = 0.0 if self.pg_pf else 1.0   # the normal passes frictionless under the patch friction
        if self.pg_pf:
            self.allocate_roll()
        comp = np.asarray(points["comp"], np.float64)   # the points' compliance (rigid_sdf.STIFFNESS)
        self.pg_c = ti.field(ti.f64, shape=len(comp))
        self.pg_c.from_numpy(comp)

    @ti.func
    def pg_v(self, o, r):
        return ti.Vector([self.pg_sl[o + 10], self.pg_sl[o + 11], self.pg_sl[o + 12]]) + ti.Vector(
            [self.pg_sl[o + 13], self.pg_sl[o + 14], self.pg_sl[o + 15]]).cross(r)

    @ti.kernel
    def pg_body(self, init: ti.i32):
        """One thread a slot (warp_mpm's ``pg_body``)."""
        for s in range(self.rc_ns):
            o = NS * s
            oa = NA * s
            rb = self.rc_bodies[s]
            M = self.rb_M[rb]
            if init != 0:
                R = self.rb_R[rb]
                Ii = (R @ self.rb_I0[rb] @ R.transpose() + 0.5 * self.rb_aff[None] * ti.cast(self.dx[None], ti.f64) ** 2 * M
                      * ti.Matrix.identity(ti.f64, 3)).inverse()
                nrm = ti.cast(0.0, ti.f64)
                for a in ti.static(range(3)):
                    row = ti.cast(0.0, ti.f64)
                    for b in ti.static(range(3)):
                        self.pg_sl[o + 16 + 3 * a + b] = Ii[a, b]
                        row += ti.abs(Ii[a, b])
                    nrm = ti.max(nrm, row)
                self.pg_sl[o + 25] = nrm
                for q in range(10):
                    self.pg_sl[o + q] = 0.0
            Ii = ti.Matrix.zero(ti.f64, 3, 3)
            for a, b in ti.static(ti.ndrange(3, 3)):
                Ii[a, b] = self.pg_sl[o + 16 + 3 * a + b]
            dw = Ii @ ti.Vector([self.pg_sl[o + 3], self.pg_sl[o + 4], self.pg_sl[o + 5]])
            for ax in ti.static(range(3)):
                self.pg_sl[o + 10 + ax] = self.rc_acc[oa + 4 + ax] + self.pg_sl[o + ax] / M
                self.pg_sl[o + 13 + ax] = self.rc_acc[oa + 62 + ax] + dw[ax]

    @ti.kernel
    def pg_mark(self):
        dt = ti.cast(self.dt[None], ti.f64)
        skin = self.pc_skin * ti.cast(self.dx[None], ti.f64)
        for p in range(self.n_points[None]):
            self.pc_s[p] = -1
            base, fx, ok = self.base_fx(self.x[p])
            if ok and self.rb_rigid[self.body[p]] == 0:
                xp = ti.cast(self.x[p], ti.f64)
                best, sb, nb = self.pc_nearest(xp, ti.cast(1.0e30, ti.f64), False)
                w = self.weights(fx)
                dlt = ti.Vector.zero(ti.f64, 3)
                f = 1 - self.in_a[self.body[p]]
                if sb >= 0 and self.pg_patch > 0.0 and best < skin + 2.0 * self.pg_patch * ti.cast(self.dx[None],
                                                                                                 ti.f64):
                    # the point as its patch of the soft body's surface (warp_mpm's point_grid.py)
                    has, t1, t2 = self.rg_frame(base, fx, w, f)
                    if has != 0:
                        rb = self.rc_bodies[sb]
                        R = self.rb_R[rb]
                        h = self.pg_patch * ti.cast(self.dx[None], ti.f64) * 0.5
                        for a, c in ti.ndrange(5, 5):
                            q = (ti.cast(a - 2, ti.f64) * t1 + ti.cast(c - 2, ti.f64) * t2) * h
                            d, g = self.pc_sdf(R.transpose() @ (xp + q - self.rb_c[rb]), sb)
                            if d < best and g.norm() > 0.0:
                                best = d
                                nb = (R @ g).normalized()
                                dlt = q
                if ti.static(self.pg_roll):   # round 70: a sphere's exact patch distance (roll_grid.py)
                    best, sb, nb, dlt = self.rg_sphere(xp, base, fx, w, f, skin, best, sb, nb, dlt)
                    if ti.static(self.pg_hascyl):   # round 72: the cylinders' (roll_grid.py)
                        best, sb, nb, dlt = self.rg_cylinder(xp, base, fx, w, f, skin, best, sb, nb, dlt)
                self.pc_x[p] = dlt
                if sb >= 0:
                    v = ti.Vector.zero(self.real, 3)
                    for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                        v += w[i][0] * w[j][1] * w[k][2] * self.node_v(p, base + ti.Vector([i, j, k]))
                    o = NS * sb
                    r = xp + dlt - self.rb_c[self.rc_bodies[sb]]
                    un = (ti.cast(v, ti.f64) - self.pg_v(o, r)).dot(nb)
                    gap = best - skin
                    if gap + dt * ti.min(un, 0.0) < 0.0:
                        self.pc_s[p] = sb
                        self.pc_n[p] = nb
                        bp = -gap / dt   # the gap closed within the substep (a compliant contact: its spring's)
                        if gap < 0.0 and self.pg_c[self.body[p]] == 0.0:
                            bp = -self.pc_bias * gap / dt   # the way out of a penetration
                        self.pc_b[p] = bp
                        self.pg_ln[p] = 0.0
                        self.pg_lt[p] = ti.Vector.zero(ti.f64, 3)
                        for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                            self.pg_tw[f, base + ti.Vector([i, j, k])] += ti.cast(w[i][0] * w[j][1] * w[k][2],
                                                                                  ti.f64)
                        self.pg_sl[o + 6] += 1.0
                        self.pg_sl[o + 7] += r.cross(nb).norm()
                        self.pg_sl[o + 8] += r.norm()

    @ti.kernel
    def pg_pre(self):
        for p in range(self.n_points[None]):
            s = self.pc_s[p]
            if s >= 0:
                base, fx, ok = self.base_fx(self.x[p])
                w = self.weights(fx)
                f = 1 - self.in_a[self.body[p]]
                g = ti.cast(0.0, ti.f64)
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    I = base + ti.Vector([i, j, k])
                    m = ti.cast(self.pc_m[f, I], ti.f64)
                    if m > 0.0:
                        g += ti.cast(w[i][0] * w[j][1] * w[k][2], ti.f64) * self.pg_tw[f, I] / m
                o = NS * s
                rb = self.rc_bodies[s]
                r = ti.cast(self.x[p], ti.f64) + self.pc_x[p] - self.rb_c[rb]
                lin = self.pg_sl[o + 6] / self.rb_M[rb]
                self.pg_S[p] = ti.Vector([g + lin + r.cross(self.pc_n[p]).norm() * self.pg_sl[o + 25] * self.pg_sl[o + 7],
                                          g + lin + r.norm() * self.pg_sl[o + 25] * self.pg_sl[o + 8]])

    @ti.kernel
    def pg_pass(self):
        dt = ti.cast(self.dt[None], ti.f64)
        for p in range(self.n_points[None]):
            s = self.pc_s[p]
            if s >= 0:
                base, fx, ok = self.base_fx(self.x[p])
                w = self.weights(fx)
                v = ti.Vector.zero(self.real, 3)
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    v += w[i][0] * w[j][1] * w[k][2] * self.node_v(p, base + ti.Vector([i, j, k]))
                o = NS * s
                rb = self.rc_bodies[s]
                xp = ti.cast(self.x[p], ti.f64) + self.pc_x[p]   # the contact point (round 67's patch)
                r = xp - self.rb_c[rb]
                n = self.pc_n[p]
                u = ti.cast(v, ti.f64) - self.pg_v(o, r)
                un = u.dot(n)
                c = self.pg_c[self.body[p]] / (dt * dt)   # 1 / (k dt^2), k the point's own stiffness (0: hard)
                l0 = self.pg_ln[p]
                l1 = ti.max(l0 - (un - self.pc_b[p] + c * l0) / (self.pg_S[p][0] + c), 0.0)
                t0 = self.pg_lt[p]
                t1 = t0 - (u - un * n) / self.pg_S[p][1]
                mu = self.rc_friction * self.pg_fmul * self.rc_mus[s * self.rc_ncol + self.rc_cols[self.body[p]]]
                tl = t1.norm()
                if ti.static(self.pc_cap != 0):
                    if tl > mu * l1 and tl > 0.0:
                        t1 = t1 * (mu * l1 / tl)
                self.pg_ln[p] = l1
                self.pg_lt[p] = t1
                D = (l1 - l0) * n + (t1 - t0)   # the point's impulse step (kg m/s)
                f = 1 - self.in_a[self.body[p]]
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    self.pc_g[f, base + ti.Vector([i, j, k])] += ti.cast(w[i][0] * w[j][1] * w[k][2], ti.f64) * D
                if ti.static(self.pc_react_on != 0):
                    L = r.cross(-D)
                    for ax in ti.static(range(3)):
                        self.pg_sl[o + ax] += -D[ax]
                        self.pg_sl[o + 3 + ax] += L[ax]
                    Lo = xp.cross(-D)
                    self.rc_react[rb] += ti.Vector([-D[0], -D[1], -D[2], Lo[0], Lo[1], Lo[2]])

    @ti.kernel
    def pg_node(self):
        lo, ext = self.touched_box()
        for idx in range(ext[0] * ext[1] * ext[2]):
            I = self.rc_node(idx, lo, ext)
            m_a = self.pc_m[0, I]
            m_b = self.pc_m[1, I]
            da = ti.Vector.zero(self.real, 3)
            db = ti.Vector.zero(self.real, 3)
            if m_a > 0.0:
                da = ti.cast(self.pc_g[0, I] / ti.cast(m_a, ti.f64), self.real)
            if m_b > 0.0:
                db = ti.cast(self.pc_g[1, I] / ti.cast(m_b, ti.f64), self.real)
            if ti.static(self.pc_soft != 0):
                self.grid_dv[I] += ti.Vector([da[0], da[1], da[2], db[0], db[1], db[2]])
            self.pc_g[0, I] = ti.Vector.zero(ti.f64, 3)
            self.pc_g[1, I] = ti.Vector.zero(ti.f64, 3)
            self.pg_tw[0, I] = 0.0
            self.pg_tw[1, I] = 0.0

    def grid_pass(self) -> None:
        """After the band's pass, before G2P (module notes)."""
        self.pg_body(1)
        self.pg_mark()
        self.pg_pre()
        for _ in range(self.pg_passes):
            self.pg_pass()
            self.pg_body(0)
            self.pg_node()
        if self.pg_pf:   # round 70: friction one impulse a patch (roll_grid.py)
            self.roll_friction()
