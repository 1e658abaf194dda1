"""Round 66: the rigid collider's contact of the soft points against a round rigid body's shape in Taichi
(``gasp_core.mpm.rigid_sdf``, switch ``POINT_CONTACT``; ``docs/rigid.md`` "Round 66: the point contact on a ball"),
the steps of warp_mpm's ``point_contact.py``: after the band's pass (``RigidCollider.collider_pass``), before G2P,
``pc_mark`` (a point each: its G2P velocity, its position after the substep, the least distance to a round slot's
body below ``SKIN`` cells, the approaching points into the slot's normal system), ``collider_solve(0)``, ``pc_layer``
(the tangential system), ``collider_solve(1)``, ``pc_fsum`` (each pair's N and T into ``pc_pacc``), ``pc_coulomb``
(one thread a pair), ``pc_apply`` (each point's change of momentum to its field's nodes by its weights, ``pc_g``; the
reaction to ``rc_react``), ``pc_node`` (the nodes' velocities take it). Mixed into ``rigid_collider.RigidCollider``.
"""
import numpy as np
import taichi as ti

from .collider_pair import NA, NP
from .point_grid import PointGrid


@ti.data_oriented
class PointContact(PointGrid):
    """The point contact's fields and kernels (``pc_on`` False: none)."""

    pc_on = False

    def allocate_points(self, points) -> None:
        """``points``: ``gasp_core.mpm.rigid_sdf.point_data`` (or None: off)."""
        from gasp_core.mpm import rigid_sdf
        self.pc_on = bool(points is not None and np.asarray(points["on"]).any())
        ns = int(self.rc_ns)
        self.rc_pt = ti.field(ti.i32, shape=ns)
        self.rc_pt.from_numpy(np.zeros(ns, np.int32) if points is None else np.asarray(points["on"], np.int32))
        if not self.pc_on:
            return
        self.pc_skin = float(rigid_sdf.SKIN)
        self.pc_bias = float(rigid_sdf.BIAS)
        self.pc_react_on = int(rigid_sdf.REACT_POINTS) * int(self.rc_react_on)
        self.pc_cap = int(rigid_sdf.FRICTION_CAP)
        self.pc_phi = ti.field(ti.f32, shape=len(points["phi"]))
        self.pc_phi.from_numpy(points["phi"])
        self.pc_grad = ti.Vector.field(3, ti.f32, shape=len(points["phi"]))
        self.pc_grad.from_numpy(points["grad"])
        self.pc_org = ti.Vector.field(3, ti.f64, shape=ns)
        self.pc_org.from_numpy(points["origin"])
        self.pc_h = ti.field(ti.f64, shape=ns)
        self.pc_h.from_numpy(points["h"])
        self.pc_dim = ti.field(ti.i32, shape=4 * ns)
        self.pc_dim.from_numpy(points["dims"])
        n = self.x.shape[0]
        self.pc_s = ti.field(ti.i32, shape=n)
        self.pc_n = ti.Vector.field(3, ti.f64, shape=n)
        self.pc_x = ti.Vector.field(3, ti.f64, shape=n)
        self.pc_v = ti.Vector.field(3, ti.f64, shape=n)
        self.pc_b = ti.field(ti.f64, shape=n)
        ng = self.n_grid
        self.pc_g = ti.Vector.field(3, ti.f64, shape=(2, ng, ng, ng))
        # each field's node mass as P2G gave it, kept by collider_mark (the grid update and the fields' clear clear
        # grid_mv and grid_sv before pc_node); SOFT_SIDE 0: a broken variant, the soft side's change dropped
        self.pc_m = ti.field(self.real, shape=(2, ng, ng, ng))
        self.pc_soft = int(rigid_sdf.SOFT_SIDE)
        self.pc_pacc = ti.field(ti.f64, shape=NP * ns * int(self.rc_ncol))
        self.allocate_grid(points)   # round 67: the contact as a constraint of the grid (point_grid.py)

    @ti.func
    def pc_sdf(self, q, s):
        """(phi, grad) of slot ``s``'s lattice at body-frame ``q``, trilinear; (1e30, 0) outside it."""
        f = (q - self.pc_org[s]) / self.pc_h[s]
        ny, nz, base = self.pc_dim[4 * s + 1], self.pc_dim[4 * s + 2], self.pc_dim[4 * s + 3]
        i0 = ti.cast(ti.floor(f), ti.i32)
        p = ti.cast(1.0e30, ti.f64)
        g = ti.Vector.zero(ti.f64, 3)
        if i0.min() >= 0 and i0[0] < self.pc_dim[4 * s] - 1 and i0[1] < ny - 1 and i0[2] < nz - 1:
            t = f - ti.cast(i0, ti.f64)
            tx = ti.Vector([1.0 - t[0], t[0]])
            ty = ti.Vector([1.0 - t[1], t[1]])
            tz = ti.Vector([1.0 - t[2], t[2]])
            p = 0.0
            for a, b, c in ti.static(ti.ndrange(2, 2, 2)):
                w = tx[a] * ty[b] * tz[c]
                at = base + ((i0[0] + a) * ny + (i0[1] + b)) * nz + (i0[2] + c)
                p += w * ti.cast(self.pc_phi[at], ti.f64)
                g += w * ti.cast(self.pc_grad[at], ti.f64)
        return p, g

    @ti.func
    def pc_nearest(self, xp, best0, ahead: ti.template()):
        """``(d, s, n)``: the slot whose round body (``rc_pt`` 1) is nearest the point ``xp`` (m, float64) by its
        lattice's distance (:meth:`pc_sdf`), under ``best0``: ``s`` -1 none, ``n`` the unit normal out of the body
        (world frame); ``ahead``: each body's centre moved over the substep by its velocity in ``rc_acc`` (round
        66's mark) or where it is (round 67's, ``point_grid.py``). warp_mpm's ``sdf_at.build_nearest``."""
        best = best0
        sb = -1
        nb = ti.Vector.zero(ti.f64, 3)
        for s in range(self.rc_ns):
            if self.rc_pt[s] != 0:
                rb = self.rc_bodies[s]
                R = self.rb_R[rb]
                c = self.rb_c[rb]
                if ti.static(ahead):
                    c = c + ti.cast(self.dt[None], ti.f64) * self.rc_vec(NA * s + 4)
                d, g = self.pc_sdf(R.transpose() @ (xp - c), s)
                if d < best and g.norm() > 0.0:
                    best = d
                    sb = s
                    nb = (R @ g).normalized()
        return best, sb, nb

    @ti.func
    def pc_body_v(self, at_v, at_w, r):
        return self.rc_vec(at_v) + self.rc_vec(at_w).cross(r)

    @ti.func
    def pc_arm(self, p, rb, o):
        dt = ti.cast(self.dt[None], ti.f64)
        return self.pc_x[p] - (self.rb_c[rb] + dt * self.rc_vec(o + 4))

    @ti.func
    def pc_system(self, o, P, r, b1):
        """Round 63's sums of ``A`` and ``b`` for one node or point (``collider_layer``'s layout; both call it)."""
        S = ti.Matrix([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]], ti.f64)
        self.rc_add33(o + 20, P)
        self.rc_add33(o + 29, -(P @ S))
        self.rc_add33(o + 38, S @ P)
        self.rc_add33(o + 47, -(S @ P @ S))
        b2 = r.cross(b1)
        for ax in ti.static(range(3)):
            self.rc_acc[o + 56 + ax] += b1[ax]
            self.rc_acc[o + 59 + ax] += b2[ax]

    @ti.kernel
    def pc_mark(self):
        dt = ti.cast(self.dt[None], ti.f64)
        skin = self.pc_skin * ti.cast(self.dx[None], ti.f64)
        for p in range(self.n_points[None]):
            self.pc_s[p] = -1
            base, fx, ok = self.base_fx(self.x[p])
            if ok and self.rb_rigid[self.body[p]] == 0:
                w = self.weights(fx)
                v = ti.Vector.zero(self.real, 3)
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    v += w[i][0] * w[j][1] * w[k][2] * self.node_v(p, base + ti.Vector([i, j, k]))
                vp = ti.cast(v, ti.f64)
                xp = ti.cast(self.x[p], ti.f64) + dt * vp
                self.pc_v[p] = vp
                self.pc_x[p] = xp
                best, sb, nb = self.pc_nearest(xp, skin, True)
                if sb >= 0:
                    o = NA * sb
                    r = self.pc_arm(p, self.rc_bodies[sb], o)
                    bp = self.pc_bias * (skin - best) / dt
                    un = (vp - self.pc_body_v(o + 4, o + 62, r)).dot(nb) - bp
                    self.pc_n[p] = nb
                    self.pc_b[p] = bp
                    self.pc_s[p] = -2 - sb
                    if un < 0.0:
                        self.pc_s[p] = sb
                        m = ti.cast(self.p_mass[p], ti.f64)
                        self.pc_system(o, m * nb.outer_product(nb), r, m * un * nb)

    @ti.kernel
    def pc_layer(self):
        for p in range(self.n_points[None]):
            s = self.pc_s[p]
            if s >= 0:
                o = NA * s
                r = self.pc_arm(p, self.rc_bodies[s], o)
                n = self.pc_n[p]
                u = self.pc_v[p] - self.pc_body_v(o + 65, o + 68, r)
                m = ti.cast(self.p_mass[p], ti.f64)
                self.pc_system(o, m * (ti.Matrix.identity(ti.f64, 3) - n.outer_product(n)), r,
                               m * (u - u.dot(n) * n))

    @ti.func
    def pc_change(self, p, s):
        o = NA * s
        r = self.pc_arm(p, self.rc_bodies[s], o)
        n = self.pc_n[p]
        u = self.pc_v[p] - self.pc_body_v(o + 65, o + 68, r)
        u2 = self.pc_v[p] - self.pc_body_v(o + 71, o + 74, r)
        return -(u.dot(n) - self.pc_b[p]) * n, -(u2 - u2.dot(n) * n), r

    @ti.kernel
    def pc_fsum(self):
        for p in range(self.n_points[None]):
            s = self.pc_s[p]
            if s >= 0:
                dvn, dvt, r = self.pc_change(p, s)
                q = NP * (s * self.rc_ncol + self.rc_cols[self.body[p]])
                m = ti.cast(self.p_mass[p], ti.f64)
                self.pc_pacc[q] += m * dvn.dot(self.pc_n[p])
                for ax in ti.static(range(3)):
                    self.pc_pacc[q + 1 + ax] += m * dvt[ax]

    @ti.kernel
    def pc_coulomb(self):
        for q in range(self.rc_ns * self.rc_ncol):
            o = NP * q
            mu = self.rc_mus[q] * self.rc_friction
            lt = ti.Vector([self.pc_pacc[o + 1], self.pc_pacc[o + 2], self.pc_pacc[o + 3]]).norm()
            cap = mu * ti.max(self.pc_pacc[o], 0.0)
            sc = ti.cast(1.0, ti.f64)
            if lt > cap:
                sc = cap / lt
            self.pc_pacc[o + 4] = sc
            for k in ti.static(range(4)):
                self.pc_pacc[o + 5 + k] = self.pc_pacc[o + k]
                self.pc_pacc[o + k] = 0.0

    @ti.kernel
    def pc_apply(self):
        for p in range(self.n_points[None]):
            s = self.pc_s[p]
            if s >= 0:
                rb = self.rc_bodies[s]
                dvn, dvt, r = self.pc_change(p, s)
                sc = self.pc_pacc[NP * (s * self.rc_ncol + self.rc_cols[self.body[p]]) + 4]
                if ti.static(self.pc_cap == 0):   # a broken variant: no Coulomb cap
                    sc = 1.0
                J = -ti.cast(self.p_mass[p], ti.f64) * (dvn + sc * dvt)
                base, fx, ok = self.base_fx(self.x[p])
                w = self.weights(fx)
                f = 1 - self.in_a[self.body[p]]
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    self.pc_g[f, base + ti.Vector([i, j, k])] += -ti.cast(w[i][0] * w[j][1] * w[k][2], ti.f64) * J
                if ti.static(self.pc_react_on != 0):
                    L = (self.rb_c[rb] + r).cross(J)
                    self.rc_react[rb] += ti.Vector([J[0], J[1], J[2], L[0], L[1], L[2]])

    @ti.kernel
    def pc_node(self):
        lo, ext = self.touched_box()
        for idx in range(ext[0] * ext[1] * ext[2]):
            I = self.rc_node(idx, lo, ext)
            m_a = self.pc_m[0, I]
            m_b = self.pc_m[1, I]
            ga = self.pc_g[0, I]
            gb = self.pc_g[1, I]
            da = ti.Vector.zero(self.real, 3)
            db = ti.Vector.zero(self.real, 3)
            if m_a > 0.0:
                da = ti.cast(ga / ti.cast(m_a, ti.f64), self.real)
            if m_b > 0.0:
                db = ti.cast(gb / ti.cast(m_b, ti.f64), self.real)
            if ti.static(self.pc_soft != 0):
                self.grid_dv[I] += ti.Vector([da[0], da[1], da[2], db[0], db[1], db[2]])
            self.pc_g[0, I] = ti.Vector.zero(ti.f64, 3)
            self.pc_g[1, I] = ti.Vector.zero(ti.f64, 3)

    def point_pass(self) -> None:
        """After the band's pass, before G2P (module notes); round 67's grid constraint where ``GRID_PASSES``."""
        if self.pg_on:
            self.grid_pass()
            return
        self.pc_mark()
        self.collider_solve(0)
        self.pc_layer()
        self.collider_solve(1)
        self.pc_fsum()
        self.pc_coulomb()
        self.pc_apply()
        self.pc_node()
