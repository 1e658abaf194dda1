"""Round 63-64: the rigid body as a moving collider of the soft field (``gasp_core.mpm.rigid_collider``,
``docs/rigid.md`` "Round 63", "Round 64") in Taichi, the steps of warp_mpm's ``rigid_collider.py``.

:meth:`RigidCollider.collider_mark` (after the first pass ``Fields.field_contact``, before the fields' clear) finds
the slot each shared node serves (:meth:`RigidCollider.rc_owner`: the pair's body, or round 64's lookup over every
rigid body), gives the node its fields' own velocities and marks the band's nodes with field B's normal and the slot
(``rc_o``); :meth:`RigidCollider.collider_pass` (after the grid update, before G2P) sums each slot body's momentum
into ``V*`` (the pair: its field's nodes; round 64: its points' G2P, ``collider_psum``), solves each body with its
approaching layer (normal, then tangential stuck), takes Coulomb's on each contact pair (rigid body, soft body) as one
(round 65, ``collider_pair.py``: the soft body at a node from ``rc_sb``, cleared by ``collider_mark`` and written by
``collider_psum``'s soft points) and changes the soft field's offsets, the reaction to ``rc_react`` (read with the
hold's in the projection's sums, ``RigidHold.held``).
``rc_acc`` (float64, ``NA`` = 86 a slot): warp_mpm's layout. The one-thread-a-slot kernels (``collider_body``,
``collider_solve``) loop over the slots in parallel (the scene's rigid bodies), ``collider_coulomb`` over the pairs.

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields it reads.
"""
import numpy as np
import taichi as ti

from gasp_core.mpm import rigid_collider as core_collider
from gasp_core.mpm.face_share import b_band
from gasp_core.mpm.fields import MIN_FRACTION, MIN_GRADIENT

from .collider_pair import NA, NP, ColliderPair
from .point_contact import PointContact

#: Deliberately broken variants for the checks (as warp_mpm's): REACT 0 gives the body no reaction; FRICTION 0 a
#: frictionless collider.
REACT = 1
FRICTION = 1.0
IMPLICIT = 1   # 0: no solve, the body's reaction explicit (a broken variant: the block floats)


@ti.data_oriented
class RigidCollider(ColliderPair, PointContact):
    """The collider's fields and kernels (none without it: ``rc_on`` False)."""

    rc_on = False

    def allocate_collider(self, collider) -> None:
        """``collider``: ``gasp_core.mpm.rigid_collider.collider_data`` (a dict: the slots' bodies and ``mu``, the
        bodies' boxes, ``multi``) or None (off). Before the first substep (the kernels read ``rc_on`` when they
        compile)."""
        self.rc_on = bool(collider is not None and self.fields)
        if not self.rc_on:
            return
        from gasp_core.mpm.rigid_pairs import NODE_PAD
        ng, nb = self.n_grid, max(int(self.n_bodies), 1)
        bodies = np.asarray(collider["bodies"], np.int32)
        self.rc_ns, self.rc_multi = len(bodies), int(collider["multi"])
        self.rc_band = float(core_collider.BAND)
        self.rc_band_b, self.rc_face = b_band()   # round 96: a rigid field B's band and face test
        self.rc_pad = float(NODE_PAD)
        self.rc_react_on = int(REACT)
        self.rc_friction = float(FRICTION)
        self.rc_implicit = int(IMPLICIT)
        self.rc_bodies = ti.field(ti.i32, shape=len(bodies))
        self.rc_bodies.from_numpy(bodies)
        slot = np.full(nb, -1, np.int32)
        slot[bodies] = np.arange(len(bodies), dtype=np.int32)
        self.rc_slot = ti.field(ti.i32, shape=nb)
        self.rc_slot.from_numpy(slot)
        # round 65: the pairs' table (collider_pair.py), a column a soft body (one: the pair, or PAIR_MU off)
        mus = np.full((len(bodies), 1), self.field_mu) if collider["mus"] is None else collider["mus"]
        mus = np.asarray(mus, np.float64)
        self.rc_ncol = int(mus.shape[1])
        self.rc_mus = ti.field(ti.f64, shape=mus.size)
        self.rc_mus.from_numpy(mus.reshape(-1))
        self.rc_cols = ti.field(ti.i32, shape=nb)
        self.rc_cols.from_numpy(np.asarray(collider["cols"], np.int32)[:nb])
        self.rc_pacc = ti.field(ti.f64, shape=NP * mus.size)
        self.rc_sb = ti.field(ti.i32, shape=(2, ng, ng, ng))
        self.rc_sb.fill(-1)
        self.rc_box = ti.Vector.field(3, ti.f64, shape=2 * nb)
        self.rc_box.from_numpy(np.asarray(collider["boxes"], np.float64).reshape(-1, 3)[:2 * nb])
        self.rc_m = ti.Vector.field(3, self.real, shape=(ng, ng, ng))
        self.rc_n = ti.Vector.field(3, self.real, shape=(ng, ng, ng))
        self.rc_o = ti.field(ti.i32, shape=(ng, ng, ng))
        self.rc_acc = ti.field(ti.f64, shape=NA * len(bodies))
        self.rc_react = ti.Vector.field(6, ti.f64, shape=nb)
        self.allocate_points(collider.get("points"))   # round 66: the round bodies' point contact (rc_pt)

    @ti.func
    def rc_node(self, idx, lo, ext):
        return lo + ti.Vector([idx // (ext[1] * ext[2]), (idx // ext[2]) % ext[1], idx % ext[2]])

    @ti.func
    def rc_x(self, I):
        return ti.cast(self.lo[None] + self.dx[None] * ti.cast(I, self.real), ti.f64)

    @ti.func
    def rc_owner(self, x):
        """(slot, d): warp_mpm's ``owner``: the pair's body (slot 0), or (round 64) the nearest rigid body of each
        field within ``NODE_PAD`` cells, a slot where one field has one and the other none, -1 else; ``d`` (m) the
        node's distance to its box in its frame."""
        pad = self.rc_pad * ti.cast(self.dx[None], ti.f64)
        sa, sb = -1, -1
        da, db = ti.cast(1.0e30, ti.f64), ti.cast(1.0e30, ti.f64)
        for s in range(self.rc_ns):
            rb = self.rc_bodies[s]
            q = self.rb_R[rb].transpose() @ (x - self.rb_c[rb])
            d = ti.max(self.rc_box[2 * rb] - q, q - self.rc_box[2 * rb + 1]).max()
            if ti.static(self.rc_multi == 0) or d <= pad:
                if self.in_a[rb] != 0:
                    if d < da:
                        da, sa = d, s
                elif d < db:
                    db, sb = d, s
        best, dbest = sa, da
        if sb >= 0:
            best, dbest = sb, db
        if sa >= 0 and sb >= 0:
            best = -1
        return best, dbest

    @ti.kernel
    def collider_mark(self):
        """Each shared node off the grounds' and walls' layers that a slot's body owns (``rc_owner``): its fields' own
        velocities; a band node (within ``rc_band`` cells of the body's points' box, both masses, B's normal) marked
        1 with the rigid body's outward normal, its slot in ``rc_o``."""
        ng = self.n_grid
        lo, ext = self.touched_box()
        band = self.rc_band * ti.cast(self.dx[None], ti.f64)
        band_b = self.rc_band_b * ti.cast(self.dx[None], ti.f64)
        for idx in range(ext[0] * ext[1] * ext[2]):
            I = self.rc_node(idx, lo, ext)
            m = self.grid_mv[0, I][3]
            sv = self.grid_sv[I]
            m_a = sv[3]
            m_b = m - m_a
            ra = self.in_a[self.rc_bodies[0]]
            m_r = m_b
            if ra != 0:
                m_r = m_a
            if ti.static(self.rc_multi != 0):   # round 64: V* from the points (collider_psum)
                m_r = 0.0
            flag = ti.cast(0.0, self.real)
            nh = ti.Vector.zero(self.real, 3)
            own = -1
            inner = (I > 0).all() and (I < ng - 1).all()
            if inner and m_a > MIN_FRACTION * m and m_b > MIN_FRACTION * m and self.held_node(I) == 0:
                s, d = self.rc_owner(self.rc_x(I))
                if s >= 0:
                    own = s
                    ra = self.in_a[self.rc_bodies[s]]
                    m_r = m_b
                    if ra != 0:
                        m_r = m_a
                    g = self.grid_mv[0, I]
                    u = ti.Vector([sv[0], sv[1], sv[2]]) / m_a - ti.Vector([g[0] - sv[0], g[1] - sv[1],
                                                                             g[2] - sv[2]]) / m_b
                    da = (m_b / m) * u
                    db = -(m_a / m) * u
                    self.grid_dv[I] = ti.Vector([da[0], da[1], da[2], db[0], db[1], db[2]])
                    ex, ey, ez = ti.Vector([1, 0, 0]), ti.Vector([0, 1, 0]), ti.Vector([0, 0, 1])
                    n = ti.Vector([self.mass_b_seen(I + ex) - self.mass_b_seen(I - ex),   # field B's, into B
                                   self.mass_b_seen(I + ey) - self.mass_b_seen(I - ey),
                                   self.mass_b_seen(I + ez) - self.mass_b_seen(I - ez)])
                    ln = n.norm()
                    reach = band
                    faced = True
                    if ra == 0:   # round 96: a rigid field B's band reaches band_b, where its mass falls to the soft
                        reach = band_b
                        faced = self.faced_by(I, n, m_b, self.rc_face)
                    if d <= reach and self.rc_pt[s] == 0 and ln > MIN_GRADIENT * m and faced:   # round 66: not a round body's
                        flag = 1.0
                        nh = n / ln   # into B: out of the rigid body where it is A
                        if ra == 0:
                            nh = -nh
            self.rc_m[I] = ti.Vector([m_r, m - m_r, flag])
            if ti.static(self.pc_on):   # round 66: the fields' node masses for pc_node (point_contact.py)
                self.pc_m[0, I] = m_a
                self.pc_m[1, I] = m_b
            self.rc_n[I] = nh
            self.rc_o[I] = own
            self.rc_sb[0, I] = -1   # round 65: the nodes' soft bodies, written by collider_psum
            self.rc_sb[1, I] = -1

    @ti.func
    def rc_field_v(self, I, soft: ti.template(), ra):
        """A node's field velocity (float64): the soft field's (``soft`` 1) or the rigid one's (``ra``: the rigid
        body's field, 1 for A)."""
        d = self.grid_dv[I]
        v = self.grid_v[I] + ti.Vector([d[3], d[4], d[5]])   # field B's
        a = ra != 0
        if ti.static(soft != 0):
            a = ra == 0
        if a:   # field A's
            v = self.grid_v[I] + ti.Vector([d[0], d[1], d[2]])
        return ti.cast(v, ti.f64)

    @ti.kernel
    def collider_sum(self):
        """The pair's ``V*`` sums over the rigid field's nodes (slot 0)."""
        lo, ext = self.touched_box()
        ra = self.in_a[self.rc_bodies[0]]
        for idx in range(ext[0] * ext[1] * ext[2]):
            I = self.rc_node(idx, lo, ext)
            m_r = ti.cast(self.rc_m[I][0], ti.f64)
            if m_r > 0.0:
                p = m_r * self.rc_field_v(I, 0, ra)
                for ax in ti.static(range(3)):
                    self.rc_acc[ax] += p[ax]
                self.rc_acc[3] += m_r

    @ti.kernel
    def collider_psum(self):
        """Round 64: each slot body's ``V*`` sums from its points' G2P of its field (a field may hold several).
        Round 65: a soft point's body into ``rc_sb`` at the nodes it weights (``collider_pair.py``)."""
        for p in range(self.n_points[None]):
            s = self.rc_slot[self.body[p]]
            base, fx, ok = self.base_fx(self.x[p])
            if ok and s < 0:
                w = self.weights(fx)
                b = self.body[p]
                f = 1 - self.in_a[b]
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    J = base + ti.Vector([i, j, k])
                    if w[i][0] * w[j][1] * w[k][2] > 0.0 and self.rc_sb[f, J] != b:
                        ti.atomic_max(self.rc_sb[f, J], b)
            if s >= 0:
                if ok:
                    w = self.weights(fx)
                    v = ti.Vector.zero(self.real, 3)
                    for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                        v += w[i][0] * w[j][1] * w[k][2] * self.node_v(p, base + ti.Vector([i, j, k]))
                    m = ti.cast(self.p_mass[p], ti.f64)
                    for ax in ti.static(range(3)):
                        self.rc_acc[NA * s + ax] += m * ti.cast(v[ax], ti.f64)
                    self.rc_acc[NA * s + 3] += m

    @ti.kernel
    def collider_body(self):
        """``V*`` (4-6) from the sums and the spin of the state (62-64); one thread a slot."""
        for s in range(self.rc_ns):
            o = NA * s
            for q in ti.static(range(4)):
                self.rc_acc[o + 11 + q] = self.rc_acc[o + 7 + q]
                self.rc_acc[o + 7 + q] = 0.0
            if self.rc_acc[o + 3] > 0.0:
                for ax in ti.static(range(3)):
                    self.rc_acc[o + 4 + ax] = self.rc_acc[o + ax] / self.rc_acc[o + 3]
            for ax in ti.static(range(3)):
                self.rc_acc[o + 62 + ax] = self.rb_w[self.rc_bodies[s]][ax]
            for q in ti.static(range(4)):
                self.rc_acc[o + q] = 0.0

    @ti.func
    def rc_vec(self, at):
        return ti.Vector([self.rc_acc[at], self.rc_acc[at + 1], self.rc_acc[at + 2]])

    @ti.func
    def rc_relative(self, I, at_v, at_w, r, ra):
        """The soft field's velocity less the body's (``rc_acc[at_v:]``, spin ``rc_acc[at_w:]``) at node I."""
        return self.rc_field_v(I, 1, ra) - self.rc_vec(at_v) - self.rc_vec(at_w).cross(r)

    @ti.func
    def rc_add33(self, at, a):
        for p in ti.static(range(3)):
            for q in ti.static(range(3)):
                self.rc_acc[at + 3 * p + q] += a[p, q]

    @ti.kernel
    def collider_layer(self, mode: ti.i32):
        """mode 0: the approaching nodes (marked 2) and the normal system against V*; 1: their tangential system;
        each node into its slot's sums."""
        lo, ext = self.touched_box()
        for idx in range(ext[0] * ext[1] * ext[2]):
            I = self.rc_node(idx, lo, ext)
            f = self.rc_m[I][2]
            if f > 0.0:
                o = NA * self.rc_o[I]
                rb = self.rc_bodies[self.rc_o[I]]
                r = self.rc_x(I) - self.rb_c[rb]
                u = self.rc_relative(I, o + 4 + 61 * mode, o + 62 + 6 * mode, r, self.in_a[rb])
                n = ti.cast(self.rc_n[I], ti.f64)
                un = u.dot(n)
                m_s = ti.cast(self.rc_m[I][1], ti.f64)
                P = m_s * n.outer_product(n)
                b1 = m_s * un * n
                use = 0
                if mode == 0 and un < 0.0:
                    use = 1
                    self.rc_m[I][2] = 2.0
                if mode == 1 and f > 1.5:   # stuck along the surface (its normal held by the first solve)
                    P = m_s * ti.Matrix.identity(ti.f64, 3) - P
                    b1 = m_s * u - b1
                    use = 1
                if use != 0:
                    self.pc_system(o, P, r, b1)   # the sums of A and b (point_contact.py: shared with the points)

    @ti.func
    def rc_get33(self, at):
        return ti.Matrix([[self.rc_acc[at], self.rc_acc[at + 1], self.rc_acc[at + 2]],
                          [self.rc_acc[at + 3], self.rc_acc[at + 4], self.rc_acc[at + 5]],
                          [self.rc_acc[at + 6], self.rc_acc[at + 7], self.rc_acc[at + 8]]], dt=ti.f64)

    @ti.kernel
    def collider_solve(self, mode: ti.i32):
        """The body's (dV, dw) from ``A x = b`` (Schur's complement, the spin first): mode 0 from (V*, w) at 4, 62 to
        65, 68; mode 1 from there to 71, 74; one thread a slot."""
        for s in range(self.rc_ns):
            o = NA * s
            rb = self.rc_bodies[s]
            M = self.rb_M[rb]
            R = self.rb_R[rb]
            eye = ti.Matrix.identity(ti.f64, 3)
            A11 = M * eye + self.rc_get33(o + 20)
            A12 = self.rc_get33(o + 29)
            A21 = self.rc_get33(o + 38)
            A22 = R @ self.rb_I0[rb] @ R.transpose() + 0.5 * self.rb_aff[None] * ti.cast(self.dx[None], ti.f64) ** 2 * M * eye \
                + self.rc_get33(o + 47)
            b1 = self.rc_vec(o + 56)
            b2 = self.rc_vec(o + 59)
            V = self.rc_vec(o + 4 + 61 * mode)
            w = self.rc_vec(o + 62 + 6 * mode)
            if ti.static(self.rc_implicit != 0) and self.rc_acc[o + 20] + self.rc_acc[o + 24] \
                    + self.rc_acc[o + 28] > 0.0:
                inv11 = A11.inverse()
                dw = (A22 - A21 @ inv11 @ A12).inverse() @ (b2 - A21 @ (inv11 @ b1))
                V += inv11 @ (b1 - A12 @ dw)
                w += dw
            for ax in ti.static(range(3)):
                self.rc_acc[o + 65 + 6 * mode + ax] = V[ax]
                self.rc_acc[o + 68 + 6 * mode + ax] = w[ax]
            for q in range(42):
                self.rc_acc[o + 20 + q] = 0.0

    def grid_update(self):
        """``GridUpdate.grid_update``, then with the rule the collider's pass (before G2P; first among
        ``MPMSolver``'s bases, so this is the one the substeps call)."""
        super().grid_update()
        if self.rc_on:
            self.collider_pass()

    def collider_pass(self) -> None:
        """After the grid update, before G2P (module notes)."""
        if self.rc_multi:   # round 64: V* from each slot body's points
            self.collider_psum()
        else:
            self.collider_sum()
        self.collider_body()
        for mode in (0, 1):
            self.collider_layer(mode)
            self.collider_solve(mode)
        self.collider_fsum()
        self.collider_coulomb()
        self.collider_apply()
        if self.pc_on:   # round 66: the round bodies' contact by the soft points (point_contact.py)
            self.point_pass()
