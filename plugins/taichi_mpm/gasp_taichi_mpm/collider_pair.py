"""Round 65: the rigid collider's Coulomb cap per contact pair (rigid body, soft body) in Taichi
(``gasp_core.mpm.rigid_collider`` module notes "The pair's friction", ``docs/rigid.md`` "Round 65: the pair's friction
in the collider"; warp_mpm's ``collider_pair.py`` spells the same).

Which soft body a band node's soft-field mass is of: ``rc_sb`` (i32, (2, n_grid, n_grid, n_grid): field A's, B's),
-1 over the touched box (``collider_mark``), then (``collider_psum``, a material point each) every soft point writes
its body at the nodes its stencil weights (``ti.atomic_max``, read first; round 61/62's colouring keeps a field's
bodies 3 cells apart, so a node's writers in a field are one body). A band node's pair: ``slot * rc_ncol +
rc_cols[rc_sb]``. ``rc_pacc`` (float64, ``NP`` = 9 a pair): 0 the normal impulse N, 1-3 the stuck tangential one T,
4 the scale, 5-8 the last substep's 0-3 (reading). :meth:`ColliderPair.collider_fsum` (a node each) sums them,
:meth:`ColliderPair.collider_coulomb` (one thread a pair) scales each pair's T to at most its ``mu`` times its N,
:meth:`ColliderPair.collider_apply` (a node each) applies them. Mixed into ``rigid_collider.RigidCollider``.
"""
import taichi as ti

#: The floats of a slot (a rigid body) in ``rc_acc`` (``rigid_collider.py``'s layout, warp_mpm's).
NA = 86
#: The floats of a pair (rigid body, soft body) in ``rc_pacc`` (the module notes' layout).
NP = 9


@ti.data_oriented
class ColliderPair:
    """The pairs' Coulomb cap (module notes)."""

    @ti.func
    def rc_pair(self, I, s, ra):
        """The pair (slot ``s``, the soft body's column) of band node I: its soft field's body (``rc_sb``; column 0
        where none is written: the two-body pair, or one column)."""
        f = 0   # the soft field: B where the rigid body is A
        if ra != 0:
            f = 1
        sb = self.rc_sb[f, I]
        c = 0
        if sb >= 0:
            c = self.rc_cols[sb]
        return s * self.rc_ncol + c

    @ti.func
    def rc_change(self, I, r, o, ra):
        """(dv_n, dv_t): the normal change against the first solve's body, the stuck tangential against the
        second's (the slot's sums from ``o``)."""
        n = ti.cast(self.rc_n[I], ti.f64)
        u = self.rc_relative(I, o + 65, o + 68, r, ra)
        ut2 = self.rc_relative(I, o + 71, o + 74, r, ra)
        return -u.dot(n) * n, -(ut2 - ut2.dot(n) * n)

    @ti.kernel
    def collider_fsum(self):
        """Each pair's normal impulse (0) and stuck tangential impulse (1-3)."""
        lo, ext = self.touched_box()
        for idx in range(ext[0] * ext[1] * ext[2]):
            I = self.rc_node(idx, lo, ext)
            if self.rc_m[I][2] > 1.5:
                s = self.rc_o[I]
                o = NA * s
                rb = self.rc_bodies[s]
                dvn, dvt = self.rc_change(I, self.rc_x(I) - self.rb_c[rb], o, self.in_a[rb])
                q = NP * self.rc_pair(I, s, self.in_a[rb])
                m_s = ti.cast(self.rc_m[I][1], ti.f64)
                self.rc_pacc[q] += m_s * dvn.dot(ti.cast(self.rc_n[I], ti.f64))
                for ax in ti.static(range(3)):
                    self.rc_pacc[q + 1 + ax] += m_s * dvt[ax]

    @ti.kernel
    def collider_coulomb(self):
        """Coulomb's on each pair: its stuck tangential impulse scaled to at most ``mu N`` (4); one thread a pair
        (its ``mu``)."""
        for q in range(self.rc_ns * self.rc_ncol):
            o = NP * q
            mu = self.rc_mus[q] * self.rc_friction
            lt = ti.Vector([self.rc_pacc[o + 1], self.rc_pacc[o + 2], self.rc_pacc[o + 3]]).norm()
            cap = mu * ti.max(self.rc_pacc[o], 0.0)
            sc = ti.cast(1.0, ti.f64)
            if lt > cap:
                sc = cap / lt
            self.rc_pacc[o + 4] = sc
            for k in ti.static(range(4)):
                self.rc_pacc[o + 5 + k] = self.rc_pacc[o + k]
                self.rc_pacc[o + k] = 0.0

    @ti.kernel
    def collider_apply(self):
        """At each approaching node the normal change and its pair's scaled tangential one; the reaction to the
        slot's body (``rc_react``)."""
        lo, ext = self.touched_box()
        for idx in range(ext[0] * ext[1] * ext[2]):
            I = self.rc_node(idx, lo, ext)
            if self.rc_m[I][2] > 1.5:
                s = self.rc_o[I]
                o = NA * s
                rb = self.rc_bodies[s]
                ra = self.in_a[rb]
                x = self.rc_x(I)
                dvn, dvt = self.rc_change(I, x - self.rb_c[rb], o, ra)
                dv = dvn + self.rc_pacc[NP * self.rc_pair(I, s, ra) + 4] * dvt
                dr = ti.cast(dv, self.real)
                if ra != 0:   # the soft field is B
                    self.grid_dv[I] += ti.Vector([0.0, 0.0, 0.0, dr[0], dr[1], dr[2]])
                else:
                    self.grid_dv[I] += ti.Vector([dr[0], dr[1], dr[2], 0.0, 0.0, 0.0])
                J = -ti.cast(self.rc_m[I][1], ti.f64) * dv
                if ti.static(self.rc_react_on != 0):   # Newton's third law: to the body's projection sums
                    L = x.cross(J)
                    self.rc_react[rb] += ti.Vector([J[0], J[1], J[2], L[0], L[1], L[2]])
                for ax in ti.static(range(3)):
                    self.rc_acc[o + 7 + ax] += J[ax]
                self.rc_acc[o + 10] += ti.cast(self.rc_m[I][1], ti.f64)
