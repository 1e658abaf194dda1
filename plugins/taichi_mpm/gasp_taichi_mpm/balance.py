"""The contact's balance (``docs/contact.md``, issue 38), as Taichi kernels mixed into
:class:`gasp_taichi_mpm.solver.MPMSolver`; warp_mpm's ``balance.py`` spells the same steps: each body's net contact
force and torque made those of a smooth contact.

- :meth:`Balance.contact_moments` and :meth:`Balance.contact_shift` before each P2G: per body its mass centre ``c``,
  rigid velocity ``V``, spin ``omega`` (from ``m x x v`` and APIC's spin), normal impulse ``J`` and its centre.
  They are taken before the fused G2P and P2G kernel, on the positions and velocities the previous P2G used (one
  substep behind warp_mpm, which takes them on the same ones; ``c`` is moved on by ``V dt``);
- in P2G a point with a normal impulse marks its nodes with its body and adds its impulse and the impulse's moments
  to its body's (:meth:`Balance.mark_contact_nodes`: ``J`` and its centre are this substep's, as in warp_mpm);
- :meth:`Balance.balance_node` in the grid update, at each marked node after its friction: its friction impulse and
  moment, its mass and moments and its budget into ``fr_sums``; the node listed in ``fr_nodes``;
- :meth:`Balance.contact_fix` after the grid update: per body, the velocity change ``dv + alpha x (X - x_m)`` of its
  listed nodes that makes the friction's net force Coulomb's on the body's rigid motion at its centre of pressure
  and takes back the contact's torque about ``c`` up to ``J reach``, unless ``c`` lies more than ``reach`` beyond the pushed
  points' box.
"""
import numpy as np
import taichi as ti

from gasp_core.toolkit.contact import TORQUE_REACH

#: Slices of the points the moments run over (each summed serially on one thread, then added).
N_PARTS = 64


@ti.func
def inertia_of(m, first, xx, xy, xz, yy, yz, zz):
    """The inertia tensor about the mass centre from the mass, first and second moments (float64)."""
    c = first / m
    S = ti.Matrix([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]], ti.f64) / m - c.outer_product(c)
    return m * (S.trace() * ti.Matrix.identity(ti.f64, 3) - S)


class Balance:
    """The contact's balance (module docstring); reads the solver's fields and flags."""

    def allocate_balance(self, reach, mass) -> None:
        """Per body the sums, shift, reach (m) and mass (kg); the contact nodes' bodies and list.
        ``reach`` None or empty: no balance."""
        nb = 0 if reach is None else len(reach)
        self.n_spin = nb
        self.c_sums = ti.field(ti.f64, shape=(max(nb, 1), 19))
        self.c_jsums = ti.field(ti.f64, shape=(max(nb, 1), 7))   # this P2G's J, its moments in x, y, its box
        self.c_shift = ti.field(ti.f64, shape=(max(nb, 1), 21))   # c, V, omega, J, x_bar, y_bar, I^-1
        self.c_last = ti.field(ti.f64, shape=(max(nb, 1), 6))   # the last fix's change of V and omega
        self.c_reach = ti.field(ti.f64, shape=max(nb, 1))
        self.c_mass = ti.field(ti.f64, shape=max(nb, 1))
        ng = self.n_grid if nb else 1
        self.grid_fbody = ti.field(ti.i32, shape=(ng, ng, ng))
        self.grid_ff = ti.Vector.field(5, self.real, shape=(ng, ng, ng))   # a contact node's friction, mass, budget
        self.fr_sums = ti.field(ti.f64, shape=(max(nb, 1), 26))
        self.fr_nodes = ti.Vector.field(3, ti.i32, shape=1 + (min(ng ** 3, 8 * ng * ng * max(1, self.n_planes))
                                                              if nb else 0))
        if nb:
            self.c_reach.from_numpy(np.asarray(reach, np.float64))
            self.c_mass.from_numpy(np.asarray(mass, np.float64))
        self.grid_fbody.fill(-1)
        if nb:
            self.clear_boxes()

    @ti.kernel
    def contact_moments(self):
        """Per body into ``c_sums``: mass, first and second mass moments, momentum, angular momentum (columns
        ``gasp_core.toolkit.contact.SUMS``; the normal impulse's columns stay 0: P2G sums them into ``c_jsums``)."""
        n = self.n_points[None]
        D = ti.cast(0.25 * self.dx[None] * self.dx[None], ti.f64)
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
                m = ti.cast(self.p_mass[p], ti.f64)
                mv = m * ti.cast(self.v[p], ti.f64)
                C = ti.cast(self.C[p], ti.f64)
                L = x.cross(mv) + m * D * ti.Vector([C[2, 1] - C[1, 2], C[0, 2] - C[2, 0], C[1, 0] - C[0, 1]])
                acc += ti.Vector([m, m * x[0], m * x[1], m * x[2], m * x[0] * x[0], m * x[0] * x[1], m * x[0] * x[2],
                                  m * x[1] * x[1], m * x[1] * x[2], m * x[2] * x[2], 0.0, 0.0, 0.0,   # J: c_jsums
                                  mv[0], mv[1], mv[2], L[0], L[1], L[2]], ti.f64)
            if cur >= 0:
                for q in ti.static(range(19)):
                    ti.atomic_add(self.c_sums[cur, q], acc[q])

    @ti.kernel
    def contact_shift(self):
        """Per body into ``c_shift``: ``c`` (a substep on), ``V``, ``omega``, ``I^-1``; ``c_sums`` cleared."""
        for b in range(self.n_spin):
            M = self.c_sums[b, 0]
            c = ti.Vector.zero(ti.f64, 3)
            V = ti.Vector.zero(ti.f64, 3)
            omega = ti.Vector.zero(ti.f64, 3)
            if M > 0.0:
                first = ti.Vector([self.c_sums[b, 1], self.c_sums[b, 2], self.c_sums[b, 3]], ti.f64)
                c = first / M
                V = ti.Vector([self.c_sums[b, 13], self.c_sums[b, 14], self.c_sums[b, 15]], ti.f64) / M
                inertia = inertia_of(M, first, self.c_sums[b, 4], self.c_sums[b, 5], self.c_sums[b, 6],
                                     self.c_sums[b, 7], self.c_sums[b, 8], self.c_sums[b, 9])
                if inertia.determinant() > 0.0:
                    L = ti.Vector([self.c_sums[b, 16], self.c_sums[b, 17], self.c_sums[b, 18]], ti.f64)
                    inv = inertia.inverse()
                    omega = inv @ (L - M * c.cross(V))
                    for q in ti.static(range(9)):
                        self.c_shift[b, 12 + q] = inv[q // 3, q % 3]
                # the moments miss the last substep's grid update: its gravity and its contact (the last fix)
                V += ti.cast(self.dt[None] * self.gravity[None], ti.f64) \
                    + ti.Vector([self.c_last[b, 0], self.c_last[b, 1], self.c_last[b, 2]], ti.f64)
                omega += ti.Vector([self.c_last[b, 3], self.c_last[b, 4], self.c_last[b, 5]], ti.f64)
                c += ti.cast(self.dt[None], ti.f64) * V
            for q in ti.static(range(3)):
                self.c_shift[b, q] = c[q]
                self.c_shift[b, 3 + q] = V[q]
                self.c_shift[b, 6 + q] = omega[q]
            for q in ti.static(range(19)):
                self.c_sums[b, q] = 0.0

    @ti.func
    def clear_box(self, b):
        """Body b's box of pushed points, inverted."""
        self.c_jsums[b, 3] = 1.0e30
        self.c_jsums[b, 4] = -1.0e30
        self.c_jsums[b, 5] = 1.0e30
        self.c_jsums[b, 6] = -1.0e30

    @ti.kernel
    def clear_boxes(self):
        for b in range(self.n_spin):
            self.clear_box(b)

    @ti.func
    def mark_contact_nodes(self, p, base, jn):
        """A point the planes push marks its 27 nodes with its body (``grid_fbody``) and adds its impulse and the
        impulse's moments to ``c_jsums``."""
        if ti.static(self.n_planes > 0):
            if self.n_spin > 0 and jn > 0.0:
                j = ti.cast(jn, ti.f64)
                x = ti.cast(self.x[p], ti.f64)
                ti.atomic_add(self.c_jsums[self.body[p], 0], j)
                ti.atomic_add(self.c_jsums[self.body[p], 1], j * x[0])
                ti.atomic_add(self.c_jsums[self.body[p], 2], j * x[1])
                ti.atomic_min(self.c_jsums[self.body[p], 3], x[0])
                ti.atomic_max(self.c_jsums[self.body[p], 4], x[0])
                ti.atomic_min(self.c_jsums[self.body[p], 5], x[1])
                ti.atomic_max(self.c_jsums[self.body[p], 6], x[1])
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    self.grid_fbody[base + ti.Vector([i, j, k])] = self.body[p]

    @ti.func
    def balance_node(self, I, v_in, v_out, m, fb):
        """At a marked node after its friction: its friction impulse, mass and budget into ``grid_ff``; the node
        listed in ``fr_nodes`` (one atomic a node: :meth:`contact_fix` sums them serially, as contention on a body's
        sums from every thread cost about 5 ms a substep on the README donut)."""
        b = self.grid_fbody[I]
        if b >= 0:
            f = m * (v_out - v_in)
            self.grid_ff[I] = ti.Vector([f[0], f[1], f[2], m, fb], self.real)
            slot = ti.atomic_add(self.fr_nodes[0][0], 1) + 1
            if slot < self.fr_nodes.shape[0]:
                self.fr_nodes[slot] = I
            else:
                self.grid_fbody[I] = -1

    @ti.func
    def sum_node(self, I):
        """A listed node's friction impulse and moment, mass and moments and budget into its body's ``fr_sums``."""
        b = self.grid_fbody[I]
        g = ti.cast(self.grid_ff[I], ti.f64)
        X = ti.cast(self.lo[None] + self.dx[None] * ti.cast(I, self.real), ti.f64)
        f = ti.Vector([g[0], g[1], g[2]], ti.f64)
        tq = X.cross(f)
        mm = g[3]
        for q in ti.static(range(3)):
            self.fr_sums[b, q] += f[q]
            self.fr_sums[b, 4 + q] += mm * X[q]
            self.fr_sums[b, 13 + q] += tq[q]
        self.fr_sums[b, 3] += mm
        self.fr_sums[b, 7] += mm * X[0] * X[0]
        self.fr_sums[b, 8] += mm * X[0] * X[1]
        self.fr_sums[b, 9] += mm * X[0] * X[2]
        self.fr_sums[b, 10] += mm * X[1] * X[1]
        self.fr_sums[b, 11] += mm * X[1] * X[2]
        self.fr_sums[b, 12] += mm * X[2] * X[2]
        self.fr_sums[b, 16] += g[4]

    @ti.func
    def keep_braking(self, th, inv, omega):
        """The torque ``th`` to take back, less its part that brakes the body's horizontal spin ``omega``, up to
        stopping it (``inv``: the body's inverse inertia; warp_mpm's ``keep_braking``)."""
        out = th
        wh = ti.Vector([omega[0], omega[1], 0.0], ti.f64)
        lw = wh.norm()
        if lw > 0.0 and inv.determinant() > 0.0:
            w = wh / lw
            s = th.dot(w)
            Lw = (inv.inverse() @ omega).dot(w)
            if s < 0.0 and Lw > 0.0:
                out = th - ti.max(s, -Lw) * w
        return out

    @ti.func
    def body_fix(self, b):
        """Body b's ``dv``, ``alpha`` and ``x_m`` into ``fr_sums[b, 17:26]`` (warp_mpm's ``body_fix``)."""
        Mc = self.fr_sums[b, 3]
        mass = self.c_mass[b]
        for q in ti.static(range(6)):
            self.c_last[b, q] = 0.0
        if Mc > 0.0 and mass > 0.0:
            first = ti.Vector([self.fr_sums[b, 4], self.fr_sums[b, 5], self.fr_sums[b, 6]], ti.f64)
            xm = first / Mc
            c = ti.Vector([self.c_shift[b, 0], self.c_shift[b, 1], self.c_shift[b, 2]], ti.f64)
            J = self.c_jsums[b, 0]
            xb = ti.cast(0.0, ti.f64)
            yb = ti.cast(0.0, ti.f64)
            if J > 0.0:
                xb = self.c_jsums[b, 1] / J
                yb = self.c_jsums[b, 2] / J
            F = ti.Vector([self.fr_sums[b, 0], self.fr_sums[b, 1], self.fr_sums[b, 2]], ti.f64)
            xcp = ti.Vector([xb, yb, xm[2]], ti.f64)
            u = ti.Vector([self.c_shift[b, 3], self.c_shift[b, 4], self.c_shift[b, 5]], ti.f64) \
                + ti.cast(self.dt[None] * self.gravity[None], ti.f64) \
                + ti.Vector([self.c_shift[b, 6], self.c_shift[b, 7], self.c_shift[b, 8]], ti.f64).cross(xcp - c)
            ut = ti.Vector([u[0], u[1], 0.0], ti.f64)
            lt = ut.norm()
            Fexp = ti.Vector.zero(ti.f64, 3)
            if lt > 0.0:
                Fexp = -(ti.min(self.fr_sums[b, 16], mass * lt) / lt) * ut
            dF = Fexp - ti.Vector([F[0], F[1], 0.0], ti.f64)
            tn = J * ti.Vector([yb - c[1], -(xb - c[0]), 0.0], ti.f64)
            tf = ti.Vector([self.fr_sums[b, 13], self.fr_sums[b, 14], self.fr_sums[b, 15]], ti.f64) - c.cross(F)
            tq = tn + tf + (xm - c).cross(dF)
            th = ti.Vector([tq[0], tq[1], 0.0], ti.f64)
            lh = th.norm()
            if lh > J * self.c_reach[b] * TORQUE_REACH:
                th *= J * self.c_reach[b] * TORQUE_REACH / lh
            r = self.c_reach[b]
            if c[0] < self.c_jsums[b, 3] - r or c[0] > self.c_jsums[b, 4] + r or c[1] < self.c_jsums[b, 5] - r \
                    or c[1] > self.c_jsums[b, 6] + r:
                th = ti.Vector.zero(ti.f64, 3)   # the mass centre beyond the pushed points' box: it tips, keep it all
            inv = ti.Matrix([[self.c_shift[b, 12 + 3 * i + j] for j in ti.static(range(3))]
                             for i in ti.static(range(3))], ti.f64)
            th = self.keep_braking(th, inv, ti.Vector([self.c_shift[b, 6], self.c_shift[b, 7],
                                                       self.c_shift[b, 8]], ti.f64))
            inertia = inertia_of(Mc, first, self.fr_sums[b, 7], self.fr_sums[b, 8], self.fr_sums[b, 9],
                                 self.fr_sums[b, 10], self.fr_sums[b, 11], self.fr_sums[b, 12])
            alpha = ti.Vector.zero(ti.f64, 3)
            if inertia.determinant() > 1.0e-12 * inertia.trace() ** 3:
                alpha = -(inertia.inverse() @ th)
            dw = inv @ (tq - th)   # what this substep's contact does to the body's rigid motion, for the next
            for q in ti.static(range(3)):
                self.c_last[b, q] = Fexp[q] / mass
                self.c_last[b, 3 + q] = dw[q]
            for q in ti.static(range(3)):
                self.fr_sums[b, 17 + q] = dF[q] / Mc
                self.fr_sums[b, 20 + q] = alpha[q]
                self.fr_sums[b, 23 + q] = xm[q]

    @ti.kernel
    def contact_fix(self):
        """Each body's listed nodes summed, then moved by ``dv + alpha x (X - x_m)``; the sums and the list cleared."""
        ti.loop_config(serialize=True)
        for s in range(ti.min(self.fr_nodes[0][0], self.fr_nodes.shape[0] - 1)):
            self.sum_node(self.fr_nodes[s + 1])
        ti.loop_config(serialize=True)
        for b in range(self.n_spin):
            self.body_fix(b)
        ti.loop_config(serialize=True)
        for s in range(ti.min(self.fr_nodes[0][0], self.fr_nodes.shape[0] - 1)):
            I = self.fr_nodes[s + 1]
            b = self.grid_fbody[I]
            if self.fr_sums[b, 3] > 0.0:
                X = ti.cast(self.lo[None] + self.dx[None] * ti.cast(I, self.real), ti.f64)
                dv = ti.Vector([self.fr_sums[b, 17], self.fr_sums[b, 18], self.fr_sums[b, 19]], ti.f64) + ti.Vector(
                    [self.fr_sums[b, 20], self.fr_sums[b, 21], self.fr_sums[b, 22]], ti.f64).cross(
                    X - ti.Vector([self.fr_sums[b, 23], self.fr_sums[b, 24], self.fr_sums[b, 25]], ti.f64))
                self.grid_v[I] += ti.cast(dv, self.real)
            self.grid_fbody[I] = -1
        ti.loop_config(serialize=True)
        for b in range(self.n_spin):
            for q in ti.static(range(26)):
                self.fr_sums[b, q] = 0.0
            for q in ti.static(range(3)):
                self.c_jsums[b, q] = 0.0
            self.clear_box(b)
        self.fr_nodes[0][0] = 0
