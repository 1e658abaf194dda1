"""The particle contact with the grounds (engine option ``contact = "particle"``, ``gasp_core.toolkit.contact``,
``docs/contact.md``), as Taichi functions; warp_mpm's ``contact.py`` spells the same steps.

- :meth:`Contact.plane_contact` in P2G: a point's normal impulse ``j_n = max(0, dt (k depth - c v_z))`` summed
  over the planes less than its skin below its centre (``depth = height + skin - z``), and its friction budget
  ``sum mu j_n``, which P2G adds to its nodes with its weights (``grid_mv``'s last channel);
- :meth:`Contact.node_friction` in the grid update: the node's tangential (x, y) velocity loses
  ``min(budget / m, |v_t|)``;
- :meth:`Contact.contact_moments` and :meth:`Contact.contact_shift` before P2G: the counter-spin of each body
  (``gasp_core.toolkit.contact.counter_spin``), from the impulses of the previous P2G (the moments are taken
  before the fused G2P and P2G kernel, on the positions the previous P2G used: one substep behind warp_mpm,
  which takes them on the same positions; over a contact the two take back the same torque);
- :meth:`Contact.hold_passive` after a passive point's update: the point put back in the box the boundaries keep
  it in (``gasp_core.toolkit.points.passive_bounds``, ``hold_passive``).

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields and flags (``real``, ``n_planes``, ...) it reads.
"""
import numpy as np
import taichi as ti

#: Slices of the points the counter-spin's sums run over (each slice summed serially on one thread, then added).
N_PARTS = 64


class Contact:
    """The particle contact's impulse per point (:meth:`plane_contact`) and friction per node (:meth:`node_friction`);
    the passive points' box (:meth:`hold_passive`)."""

    @ti.func
    def plane_contact(self, p):
        """``(j_n, budget)`` of point p (kg m/s) over the grounds' planes (``ground_h``, ``ground_fric``),
        ``p_contact[p] = (k, c, skin)``; zeros without the particle contact."""
        jn = ti.cast(0.0, self.real)
        budget = ti.cast(0.0, self.real)
        if ti.static(self.n_planes > 0):
            kcs = self.p_contact[p]
            for b in ti.static(range(self.n_planes)):
                depth = self.ground_h[b] + kcs[2] - self.x[p][2]
                if depth > 0.0:
                    jq = ti.max(self.dt[None] * (kcs[0] * depth - kcs[1] * self.v[p][2]), 0.0)
                    jn += jq
                    budget += self.ground_fric[b] * jq
        return jn, budget

    @ti.func
    def node_friction(self, v, m, fb):
        """Coulomb friction of the budget ``fb`` (kg m/s) on a node of mass ``m``: stops, never reverses, ``v_t``."""
        vt = ti.Vector([v[0], v[1], 0.0], self.real)
        lt = vt.norm()
        out = v
        if fb > 0.0 and lt > 0.0:
            out = v - (ti.min(fb / m, lt) / lt) * vt
        return out

    @ti.func
    def hold_passive(self, x, v):
        """``(x, v)`` of a passive point after its update, held in ``[hold_lo, hold_hi]``: on each axis a point below
        ``hold_lo[d]`` is put there with ``v[d] = max(v[d], 0)``, above ``hold_hi[d]`` likewise with ``min``
        (``gasp_core.toolkit.points.hold_passive``: a massless surface marker cannot be inside the ground or the walls)."""
        xo = x
        vo = v
        for d in ti.static(range(3)):
            if xo[d] < self.hold_lo[None][d]:
                xo[d] = self.hold_lo[None][d]
                vo[d] = ti.max(vo[d], 0.0)
            if xo[d] > self.hold_hi[None][d]:
                xo[d] = self.hold_hi[None][d]
                vo[d] = ti.min(vo[d], 0.0)
        return xo, vo

    # ------------------------------------------------------------------ the counter-spin
    def allocate_counter_spin(self, reach) -> None:
        """Per body, the sums, the reach (m) and the shift ``(d_omega, c)`` of the counter-spin (float64);
        ``reach`` None or empty: no counter-spin."""
        nb = 0 if reach is None else len(reach)
        self.n_spin = nb
        self.c_sums = ti.field(ti.f64, shape=(max(nb, 1), 19))
        self.c_shift = ti.field(ti.f64, shape=(max(nb, 1), 12))
        # the friction's balance: each contact node's body, per body its sums, the listed nodes (slot 0: count)
        ng = self.n_grid if nb else 1
        self.grid_fbody = ti.field(ti.i32, shape=(ng, ng, ng))
        self.grid_fbody.fill(-1)
        self.fr_sums = ti.field(ti.f64, shape=(max(nb, 1), 25))
        self.fr_nodes = ti.Vector.field(3, ti.i32, shape=1 + (min(ng ** 3, 8 * ng * ng * max(1, self.n_planes))
                                                              if nb else 0))
        self.c_reach = ti.field(ti.f64, shape=max(nb, 1))
        if nb:
            self.c_reach.from_numpy(np.asarray(reach, np.float64))

    @ti.kernel
    def contact_moments(self):
        """Each body's mass, first and second mass moments, and its points' normal impulses and their first
        moments in x, y into ``c_sums`` (columns ``gasp_core.toolkit.contact.SUMS``), then its momentum."""
        n = self.n_points[None]
        ti.loop_config(block_dim=1)
        for t in range(N_PARTS):
            acc = ti.Vector.zero(ti.f64, 19)
            cur = -1
            for p in range(t * n // N_PARTS, (t + 1) * n // N_PARTS):
                b = self.body[p]
                if b != cur:
                    if cur >= 0:
                        for q in ti.static(range(19)):
                            ti.atomic_add(self.c_sums[cur, q], acc[q])
                    acc = ti.Vector.zero(ti.f64, 19)
                    cur = b
                x = ti.cast(self.x[p], ti.f64)
                mv = ti.cast(self.p_mass[p] * self.v[p], ti.f64)
                m = ti.cast(self.p_mass[p], ti.f64)
                jn, _budget = self.plane_contact(p)
                j = ti.cast(jn, ti.f64)
                acc += ti.Vector([m, m * x[0], m * x[1], m * x[2], m * x[0] * x[0], m * x[0] * x[1], m * x[0] * x[2],
                                  m * x[1] * x[1], m * x[1] * x[2], m * x[2] * x[2], j, j * x[0], j * x[1],
                                  mv[0], mv[1], mv[2], x[1] * mv[2] - x[2] * mv[1], x[2] * mv[0] - x[0] * mv[2],
                                  x[0] * mv[1] - x[1] * mv[0]], ti.f64)
            if cur >= 0:
                for q in ti.static(range(19)):
                    ti.atomic_add(self.c_sums[cur, q], acc[q])

    @ti.kernel
    def contact_shift(self):
        """Each body's counter-spin ``d_omega`` (rad/s) and mass centre ``c`` (m) into ``c_shift``; ``c_sums`` cleared."""
        for b in range(self.n_spin):
            M = self.c_sums[b, 0]
            J = self.c_sums[b, 10]
            w = ti.Vector.zero(ti.f64, 3)
            c = ti.Vector.zero(ti.f64, 3)
            if M > 0.0:
                c = ti.Vector([self.c_sums[b, 1], self.c_sums[b, 2], self.c_sums[b, 3]], ti.f64) / M
            if M > 0.0 and J > 0.0:
                dX = c[0] - self.c_sums[b, 11] / J
                dY = c[1] - self.c_sums[b, 12] / J
                d = ti.sqrt(dX * dX + dY * dY)
                if d > self.c_reach[b]:
                    dX *= self.c_reach[b] / d
                    dY *= self.c_reach[b] / d
                S = ti.Matrix([[self.c_sums[b, 4], self.c_sums[b, 5], self.c_sums[b, 6]],
                               [self.c_sums[b, 5], self.c_sums[b, 7], self.c_sums[b, 8]],
                               [self.c_sums[b, 6], self.c_sums[b, 8], self.c_sums[b, 9]]], ti.f64) / M \
                    - c.outer_product(c)
                inertia = M * (S.trace() * ti.Matrix.identity(ti.f64, 3) - S)
                if inertia.determinant() > 0.0:
                    w = inertia.inverse() @ (J * ti.Vector([dY, -dX, 0.0], ti.f64))
            V = ti.Vector.zero(ti.f64, 3)
            omega = ti.Vector.zero(ti.f64, 3)
            if M > 0.0:   # the rigid motion (momentum / M, I^-1 angular momentum about c); c a substep on, as P2G uses it
                V = ti.Vector([self.c_sums[b, 13], self.c_sums[b, 14], self.c_sums[b, 15]], ti.f64) / M
                S = ti.Matrix([[self.c_sums[b, 4], self.c_sums[b, 5], self.c_sums[b, 6]],
                               [self.c_sums[b, 5], self.c_sums[b, 7], self.c_sums[b, 8]],
                               [self.c_sums[b, 6], self.c_sums[b, 8], self.c_sums[b, 9]]], ti.f64) / M \
                    - c.outer_product(c)
                inertia = M * (S.trace() * ti.Matrix.identity(ti.f64, 3) - S)
                if inertia.determinant() > 0.0:
                    L = ti.Vector([self.c_sums[b, 16], self.c_sums[b, 17], self.c_sums[b, 18]], ti.f64)
                    omega = inertia.inverse() @ (L - M * c.cross(V))
                c += ti.cast(self.dt[None], ti.f64) * V
            for q in ti.static(range(3)):
                self.c_shift[b, q] = w[q]
                self.c_shift[b, 3 + q] = c[q]
                self.c_shift[b, 6 + q] = V[q]
                self.c_shift[b, 9 + q] = omega[q]
            for q in ti.static(range(19)):
                self.c_sums[b, q] = 0.0

    @ti.func
    def counter_spin_momentum(self, p):
        """``m_p d_omega x (x_p - c)`` of point p's body (kg m/s; zero without the counter-spin)."""
        out = ti.Vector.zero(self.real, 3)
        if ti.static(self.n_planes > 0):
            b = self.body[p]
            dw = ti.Vector([self.c_shift[b, 0], self.c_shift[b, 1], self.c_shift[b, 2]])
            c = ti.Vector([self.c_shift[b, 3], self.c_shift[b, 4], self.c_shift[b, 5]])
            out = ti.cast(ti.cast(self.p_mass[p], ti.f64) * dw.cross(ti.cast(self.x[p], ti.f64) - c), self.real)
        return out

    @ti.func
    def mark_contact_nodes(self, p, base, budget):
        """With the counter-spin, the 27 nodes of a point with a friction budget take its body (``grid_fbody``)."""
        if ti.static(self.n_planes > 0):
            if self.n_spin > 0 and budget > 0.0:
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    self.grid_fbody[base + ti.Vector([i, j, k])] = self.body[p]

    @ti.func
    def balance_friction(self, I, v_in, v_out, m, fb):
        """At a node with friction: its friction impulse less its body's rigid motion's there, that excess's moment,
        the node's mass and its moments into ``fr_sums``; the node listed in ``fr_nodes`` (warp_mpm's
        ``build_friction_balance``, ``gasp_core.toolkit.contact.friction_balance``)."""
        b = self.grid_fbody[I]
        if fb > 0.0 and b >= 0:
            X = ti.cast(self.lo[None] + self.dx[None] * ti.cast(I, self.real), ti.f64)
            c = ti.Vector([self.c_shift[b, 3], self.c_shift[b, 4], self.c_shift[b, 5]])
            u = ti.Vector([self.c_shift[b, 6], self.c_shift[b, 7], self.c_shift[b, 8]]) \
                + ti.cast(self.dt[None] * self.gravity[None], ti.f64) \
                + ti.Vector([self.c_shift[b, 9], self.c_shift[b, 10], self.c_shift[b, 11]]).cross(X - c)
            ur = ti.cast(u, self.real)
            df = ti.cast(m * ((v_out - v_in) - (self.node_friction(ur, m, fb) - ur)), ti.f64)
            tq = X.cross(df)
            m64 = ti.cast(m, ti.f64)
            for q in ti.static(range(3)):
                ti.atomic_add(self.fr_sums[b, q], df[q])
                ti.atomic_add(self.fr_sums[b, 13 + q], tq[q])
                ti.atomic_add(self.fr_sums[b, 4 + q], m64 * X[q])
            ti.atomic_add(self.fr_sums[b, 3], m64)
            ti.atomic_add(self.fr_sums[b, 7], m64 * X[0] * X[0])
            ti.atomic_add(self.fr_sums[b, 8], m64 * X[0] * X[1])
            ti.atomic_add(self.fr_sums[b, 9], m64 * X[0] * X[2])
            ti.atomic_add(self.fr_sums[b, 10], m64 * X[1] * X[1])
            ti.atomic_add(self.fr_sums[b, 11], m64 * X[1] * X[2])
            ti.atomic_add(self.fr_sums[b, 12], m64 * X[2] * X[2])
            slot = ti.atomic_add(self.fr_nodes[0][0], 1) + 1
            if slot < self.fr_nodes.shape[0]:
                self.fr_nodes[slot] = I
        else:
            self.grid_fbody[I] = -1

    @ti.kernel
    def friction_fix(self):
        """Per body, the velocity change ``dv + alpha x (X - x_bar)`` of its listed nodes that takes back its friction
        excess's force and torque; the nodes moved, the sums and the list cleared."""
        ti.loop_config(serialize=True)
        for b in range(self.n_spin):
            Mc = self.fr_sums[b, 3]
            if Mc > 0.0:
                xb = ti.Vector([self.fr_sums[b, 4], self.fr_sums[b, 5], self.fr_sums[b, 6]]) / Mc
                F = ti.Vector([self.fr_sums[b, 0], self.fr_sums[b, 1], self.fr_sums[b, 2]])
                S = ti.Matrix([[self.fr_sums[b, 7], self.fr_sums[b, 8], self.fr_sums[b, 9]],
                               [self.fr_sums[b, 8], self.fr_sums[b, 10], self.fr_sums[b, 11]],
                               [self.fr_sums[b, 9], self.fr_sums[b, 11], self.fr_sums[b, 12]]], ti.f64) / Mc \
                    - xb.outer_product(xb)
                inertia = Mc * (S.trace() * ti.Matrix.identity(ti.f64, 3) - S)
                T = ti.Vector([self.fr_sums[b, 13], self.fr_sums[b, 14], self.fr_sums[b, 15]]) - xb.cross(F)
                alpha = ti.Vector.zero(ti.f64, 3)
                if inertia.determinant() > 1.0e-12 * inertia.trace() ** 3:
                    alpha = -(inertia.inverse() @ T)
                for q in ti.static(range(3)):
                    self.fr_sums[b, 16 + q] = -F[q] / Mc
                    self.fr_sums[b, 19 + q] = alpha[q]
                    self.fr_sums[b, 22 + q] = xb[q]
        ti.loop_config(serialize=True)
        for s in range(ti.min(self.fr_nodes[0][0], self.fr_nodes.shape[0] - 1)):
            I = self.fr_nodes[s + 1]
            b = self.grid_fbody[I]
            if b >= 0 and self.fr_sums[b, 3] > 0.0:
                X = ti.cast(self.lo[None] + self.dx[None] * ti.cast(I, self.real), ti.f64)
                dv = ti.Vector([self.fr_sums[b, 16], self.fr_sums[b, 17], self.fr_sums[b, 18]]) + ti.Vector(
                    [self.fr_sums[b, 19], self.fr_sums[b, 20], self.fr_sums[b, 21]]).cross(
                    X - ti.Vector([self.fr_sums[b, 22], self.fr_sums[b, 23], self.fr_sums[b, 24]]))
                self.grid_v[I] += ti.cast(dv, self.real)
            self.grid_fbody[I] = -1
        ti.loop_config(serialize=True)
        for b in range(self.n_spin):
            for q in ti.static(range(25)):
                self.fr_sums[b, q] = 0.0
        self.fr_nodes[0][0] = 0
