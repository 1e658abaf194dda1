"""The contact's balance (``docs/contact.md``, issue 38), as Taichi kernels mixed into
:class:`gasp_taichi_mpm.solver.MPMSolver`; warp_mpm's ``balance.py`` spells the same steps: each body's net contact
force and torque made those of a smooth contact.

- ``contact_moments`` and ``contact_shift`` after each P2G: per body its mass centre ``c``,
  rigid velocity ``V``, spin ``omega`` (from ``m x x v`` and APIC's spin), normal impulse ``J`` and its centre.
  They are taken after the fused G2P and P2G kernel, on the positions and velocities that P2G used (P2G leaves them
  as they are), as warp_mpm takes them before its P2G; nothing reads them before the grid update's
  ``contact_fix``. (Taken before the fused kernel, one substep behind, with the last substep's gravity
  and fix added as a predictor, they missed what else moved the body in that substep, the two-field contact's push
  of another body: the light ball of ``gasp_core.testing.sand_ball`` turned 2.37 degrees on taichi_mpm against 1.51
  on warp_mpm, issue 53);
- in P2G a point with a normal impulse marks its nodes with its body and adds its impulse and the impulse's moments
  to its body's (:meth:`Balance.mark_contact_nodes`: ``J`` and its centre are this substep's, as in warp_mpm);
- :meth:`Balance.balance_node` in the grid update, at each marked node after its friction: its friction impulse and
  moment, its mass and moments and its budget into ``fr_sums``; the node listed in ``fr_nodes``;
- ``contact_fix`` in the grid update, before the held boxes' holds (round 56): per body, the velocity change
  ``dv + alpha x (X - x_m)`` of its listed nodes that makes the friction's net force Coulomb's on the body's rigid
  motion at its centre of pressure and takes back the contact's torque about ``c`` up to ``J reach``, unless ``c``
  lies more than ``reach`` beyond the pushed points' box. A body whose material flows (sand, snow, liquid) has no
  rigid motion: its mass here is 0 and ``body_fix`` leaves it alone (``gasp_core.mpm.contact.balance_mass``,
  docs/contact.md "Round 59: the balance on a flowing body").

On the GPU schedule (:mod:`gasp_taichi_mpm.schedule`) the same sums run with every loop parallel: the moments over
slices of ``m_slice`` points (:func:`gasp_taichi_mpm.schedule.primitives.slice_points`) summed by a fixed tree (:meth:`gasp_taichi_mpm.balance_gpu.BalanceGPU.contact_moments_gpu`), and the fix
with no list and no sort: the marked nodes listed in node order by flag, scan and scatter, their terms summed per
support over chunks of list entries by a fixed tree, then applied one thread a node
(:meth:`gasp_taichi_mpm.balance_gpu.BalanceGPU.contact_fix_gpu`). The support sums of P2G (:meth:`Balance.add_contact`) stay float64 atomics on both (in fixed point with
``deterministic``: :mod:`gasp_taichi_mpm.schedule.fixed`). The CPU schedule's kernels, ordered (``contact_moments``,
``contact_shift``, ``contact_fix`` and its sort), are in :mod:`gasp_taichi_mpm.schedule.ordered`.
"""
import numpy as np
import taichi as ti

from gasp_core.mpm.contact import JSUMS, REACH, TORQUE_REACH
from gasp_core.mpm.contact_mark import (MARK_OCTAVES_BELOW, MARK_Q_MAX, MARK_ROW_BITS, MARK_ROW_MASK, MARK_STEPS,
                                        check_mark_rows)

from .balance_bound import closing_bound
from .schedule.ordered import N_PARTS
from .take_back import PLANE_RULE, unresolved_fraction

#: ``c_jsums``' column of ``sum j x_q x_r`` (q <= r): ``gasp_core.mpm.contact.JSUMS`` "jxx" ... "jzz".
SECOND_COL = ((20, 21, 22), (21, 23, 24), (22, 24, 25))
#: Columns of a listed node's terms (:meth:`Balance.node_terms`): fr_sums[s, :17].
N_NODE_TERMS = 17


@ti.func
def mark_key(push, row):
    """A contact node's key for a point of the balance's ``row`` pushing it with ``push = w |j|`` (kg m/s, f64;
    ``gasp_core.mpm.contact_mark.mark_key``)."""
    q = 0
    if push > 0.0:
        lq = ti.floor((ti.log(push) / ti.log(ti.cast(2.0, ti.f64)) + MARK_OCTAVES_BELOW) * MARK_STEPS)
        q = ti.cast(ti.min(ti.max(lq, 0.0), MARK_Q_MAX), ti.i32)
    return (q << MARK_ROW_BITS) | row


@ti.func
def inertia_of(m, first, xx, xy, xz, yy, yz, zz):
    """The inertia tensor about the mass centre from the mass, first and second moments (float64)."""
    c = first / m
    S = ti.Matrix([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]], ti.f64) / m - c.outer_product(c)
    return m * (S.trace() * ti.Matrix.identity(ti.f64, 3) - S)


#: Columns of a support's ``fr_sums``: its nodes' terms (:data:`N_NODE_TERMS`), then ``dv``, ``alpha``, ``x_m``.
FR_COLUMNS = 26


class Balance:
    """The contact's balance (module docstring); reads the solver's fields and flags."""

    def allocate_balance(self, reach, mass) -> None:
        """Per body the sums, shift, reach (m) and mass (kg); per support (``n_sup`` a body: the grounds, each
        collider with the particle contact) the contact's and the friction's sums; the contact nodes' supports and
        list. ``reach`` None or empty: no balance."""
        nb = 0 if reach is None else len(reach)
        ns = nb * self.n_sup
        check_mark_rows(ns)
        self.n_spin = nb
        self.n_slots = ns
        self.c_part = ti.field(ti.f64, shape=(N_PARTS, max(nb, 1), 19))   # each slice's sums (contact_moments)
        self.c_jsums = ti.field(ti.f64, shape=(max(ns, 1), len(JSUMS)))   # this P2G's contact sums per support
        self.c_shift = ti.field(ti.f64, shape=(max(nb, 1), 21))   # c, V, omega, L about c, I^-1
        self.c_reach = ti.field(ti.f64, shape=max(nb, 1))
        self.c_mass = ti.field(ti.f64, shape=max(nb, 1))
        ng = self.n_grid if nb else 1
        self.grid_fbody = ti.field(ti.i32, shape=(ng, ng, ng))
        self.grid_ff = ti.Vector.field(5, self.real, shape=(ng, ng, ng))   # a contact node's friction, mass, budget
        self.fr_sums = ti.field(ti.f64, shape=(max(ns, 1), FR_COLUMNS))
        self.fr_nodes = ti.Vector.field(3, ti.i32, shape=1 + (min(ng ** 3, 8 * ng * ng * max(1, self.n_planes
                                                                                               + self.n_colc))
                                                              if nb else 0))
        if nb:
            self.c_reach.from_numpy(np.asarray(reach, np.float64))
            self.c_mass.from_numpy(np.asarray(mass, np.float64))
        self.grid_fbody.fill(-1)
        if nb and self.gpu:
            self.allocate_balance_gpu(nb, ns)   # balance_gpu.py
        if nb:
            self.clear_boxes()

    @ti.func
    def moment_terms(self, p, D):
        """Point p's mass, first and second mass moments, momentum and angular momentum (with APIC's spin ``D``
        ``= dx^2 / 4``): the 19 columns of ``gasp_core.mpm.contact.SUMS`` (the impulse's three 0)."""
        x = ti.cast(self.x[p], ti.f64)
        m = ti.cast(self.p_mass[p], ti.f64)
        mv = m * ti.cast(self.v[p], ti.f64)
        C = ti.cast(self.C[p], ti.f64)
        L = x.cross(mv) + m * D * ti.Vector([C[2, 1] - C[1, 2], C[0, 2] - C[2, 0], C[1, 0] - C[0, 1]])
        return ti.Vector([m, m * x[0], m * x[1], m * x[2], m * x[0] * x[0], m * x[0] * x[1],
                          m * x[0] * x[2], m * x[1] * x[1], m * x[1] * x[2], m * x[2] * x[2],
                          0.0, 0.0, 0.0,   # J: c_jsums
                          mv[0], mv[1], mv[2], L[0], L[1], L[2]], ti.f64)

    @ti.func
    def shift_body(self, b, sums):
        """Body b's ``c``, ``V``, ``omega``, angular momentum about ``c`` and ``I^-1`` into ``c_shift`` from its 19
        sums (warp_mpm's ``contact_shift``)."""
        M = sums[0]
        c = ti.Vector.zero(ti.f64, 3)
        V = ti.Vector.zero(ti.f64, 3)
        omega = ti.Vector.zero(ti.f64, 3)
        Lc = ti.Vector.zero(ti.f64, 3)
        if M > 0.0:
            first = ti.Vector([sums[1], sums[2], sums[3]], ti.f64)
            c = first / M
            V = ti.Vector([sums[13], sums[14], sums[15]], ti.f64) / M
            inertia = inertia_of(M, first, sums[4], sums[5], sums[6],
                                 sums[7], sums[8], sums[9])
            Lc = ti.Vector([sums[16], sums[17], sums[18]], ti.f64) - M * c.cross(V)
            if inertia.determinant() > 0.0:
                inv = inertia.inverse()
                omega = inv @ Lc
                for q in ti.static(range(9)):
                    self.c_shift[b, 12 + q] = inv[q // 3, q % 3]
        for q in ti.static(range(3)):
            self.c_shift[b, q] = c[q]
            self.c_shift[b, 3 + q] = V[q]
            self.c_shift[b, 6 + q] = omega[q]
            self.c_shift[b, 9 + q] = Lc[q]

    @ti.func
    def clear_box(self, s):
        """Support s's contact sums cleared, its box of pushed points inverted."""
        for q in ti.static(range(14)):
            self.c_jsums[s, q] = 0.0
        for q in ti.static(range(20, 27)):
            self.c_jsums[s, q] = 0.0
        for d in ti.static(range(3)):
            self.c_jsums[s, 14 + 2 * d] = 1.0e30
            self.c_jsums[s, 15 + 2 * d] = -1.0e30

    @ti.kernel
    def clear_boxes(self):
        for s in range(self.n_slots):
            self.clear_box(s)

    @ti.func
    def add_contact(self, p, xp, sup, jn, n, vc):
        """Point p's normal impulse ``jn`` along ``n`` from support ``sup`` (its velocity ``vc`` there) into the
        support's row of ``c_jsums`` (``gasp_core.mpm.contact.JSUMS``), with the balance."""
        if ti.static(self.n_spin > 0):
            s = self.body[p] * self.n_sup + sup
            j = ti.cast(jn, ti.f64)
            x = ti.cast(xp, ti.f64)
            jv = j * ti.cast(n, ti.f64)
            mn = x.cross(jv)
            v = j * ti.cast(vc, ti.f64)
            mp = ti.cast(self.p_mass[p], ti.f64)   # the pushed points' mass (round 59: closing_bound)
            if ti.static(self.fixed_point):   # deterministic: the sums in fixed point (schedule/fixed.py)
                self.add_support_fixed(s, 0, j)
                for q in ti.static(range(3)):
                    self.add_support_fixed(s, 1 + q, j * x[q])
                    self.add_support_fixed(s, 4 + q, jv[q])
                    self.add_support_fixed(s, 7 + q, mn[q])
                    self.add_support_fixed(s, 10 + q, v[q])
                self.add_support_fixed(s, 13, mp)
                for q in ti.static(range(3)):   # round 86: sum j x x^T, sum j^2 (gasp_core.mpm.take_back)
                    for r in ti.static(range(q, 3)):
                        self.add_support_fixed(s, SECOND_COL[q][r], j * x[q] * x[r])
                self.add_support_fixed(s, 26, j * j)
            else:
                ti.atomic_add(self.c_jsums[s, 0], j)
                for q in ti.static(range(3)):
                    ti.atomic_add(self.c_jsums[s, 1 + q], j * x[q])
                    ti.atomic_add(self.c_jsums[s, 4 + q], jv[q])
                    ti.atomic_add(self.c_jsums[s, 7 + q], mn[q])
                    ti.atomic_add(self.c_jsums[s, 10 + q], v[q])
                ti.atomic_add(self.c_jsums[s, 13], mp)
                for q in ti.static(range(3)):   # round 86: sum j x x^T, sum j^2 (gasp_core.mpm.take_back)
                    for r in ti.static(range(q, 3)):
                        ti.atomic_add(self.c_jsums[s, SECOND_COL[q][r]], j * x[q] * x[r])
                ti.atomic_add(self.c_jsums[s, 26], j * j)
            for q in ti.static(range(3)):
                ti.atomic_min(self.c_jsums[s, 14 + 2 * q], x[q])
                ti.atomic_max(self.c_jsums[s, 15 + 2 * q], x[q])

    @ti.func
    def mark_contact_nodes(self, base, w, jvec, sup):
        """A point a support pushes (impulse ``jvec``, weights ``w``) marks its 27 nodes with the key of that
        support's row (``grid_fbody``): a node keeps the row of the point that pushes it most, ``w_ip |j_p|``, the
        same on any point order, thread count or device (``gasp_core.mpm.contact_mark``; :meth:`keep_row`)."""
        if ti.static(self.n_planes > 0 or self.n_colc > 0):
            if self.n_spin > 0 and sup >= 0:
                jm = ti.cast(jvec.norm(), ti.f64)
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    key = mark_key(ti.cast(w[i][0] * w[j][1] * w[k][2], ti.f64) * jm, sup)
                    ti.atomic_max(self.grid_fbody[base + ti.Vector([i, j, k])], key)

    @ti.func
    def keep_row(self, I):
        """The grid update: a marked node's key becomes its row (``gasp_core.mpm.contact_mark``)."""
        if ti.static(self.n_planes > 0 or self.n_colc > 0):
            if self.n_spin > 0:
                k = self.grid_fbody[I]
                if k >= 0:
                    self.grid_fbody[I] = k & MARK_ROW_MASK

    @ti.func
    def balance_node(self, I, v_in, v_out, m, fb):
        """At a marked node after its friction: its friction impulse, mass and budget into ``grid_ff``; the node
        listed in ``fr_nodes`` (one atomic a node: :meth:`contact_fix` sums them serially, as contention on a body's
        sums from every thread cost about 5 ms a substep on the README donut)."""
        b = self.grid_fbody[I]
        if b >= 0:
            f = m * (v_out - v_in)
            self.grid_ff[I] = ti.Vector([f[0], f[1], f[2], m, fb], self.real)
            if ti.static(not self.gpu):   # the GPU schedule lists the marked nodes in contact_fix_gpu
                slot = ti.atomic_add(self.fr_nodes[0][0], 1) + 1
                if slot < self.fr_nodes.shape[0]:
                    self.fr_nodes[slot] = I
                else:
                    self.grid_fbody[I] = -1

    @ti.func
    def node_terms(self, I):
        """A listed node's friction impulse (0-2), mass (3), first (4-6) and second (7-12) mass moments, friction
        moment (13-15) and budget (16): the columns of its support's ``fr_sums``."""
        g = ti.cast(self.grid_ff[I], ti.f64)
        X = ti.cast(self.lo[None] + self.dx[None] * ti.cast(I, self.real), ti.f64)
        f = ti.Vector([g[0], g[1], g[2]], ti.f64)
        tq = X.cross(f)
        mm = g[3]
        return ti.Vector([f[0], f[1], f[2], mm, mm * X[0], mm * X[1], mm * X[2],
                          mm * X[0] * X[0], mm * X[0] * X[1], mm * X[0] * X[2], mm * X[1] * X[1], mm * X[1] * X[2],
                          mm * X[2] * X[2], tq[0], tq[1], tq[2], g[4]], ti.f64)

    @ti.func
    def sum_node(self, I):
        """A listed node's terms (:meth:`node_terms`) into its support's ``fr_sums``."""
        b = self.grid_fbody[I]
        t = self.node_terms(I)
        for q in ti.static(range(N_NODE_TERMS)):
            self.fr_sums[b, q] += t[q]

    @ti.func
    def support_frame(self, s):
        """Support s's mean contact normal (``sum j n`` normalised; +z without one), the impulses' centre and the
        support's mean velocity there (warp_mpm's ``support_frame``)."""
        J = self.c_jsums[s, 0]
        jn = ti.Vector([self.c_jsums[s, 4], self.c_jsums[s, 5], self.c_jsums[s, 6]], ti.f64)
        ln = jn.norm()
        nb = ti.Vector([0.0, 0.0, 1.0], ti.f64)
        if ln > 0.0:
            nb = jn / ln
        xb = ti.Vector.zero(ti.f64, 3)
        vb = ti.Vector.zero(ti.f64, 3)
        if J > 0.0:
            xb = ti.Vector([self.c_jsums[s, 1], self.c_jsums[s, 2], self.c_jsums[s, 3]], ti.f64) / J
            vb = ti.Vector([self.c_jsums[s, 10], self.c_jsums[s, 11], self.c_jsums[s, 12]], ti.f64) / J
        return nb, xb, vb

    @ti.func
    def beyond_box(self, s, c, nb, reach):
        """Whether the line through ``c`` along ``nb`` misses support s's box of pushed points grown by ``reach``
        (a slab test; warp_mpm's ``beyond_box``)."""
        tmin = ti.cast(-1.0e30, ti.f64)
        tmax = ti.cast(1.0e30, ti.f64)
        out = False
        for d in ti.static(range(3)):
            lo = self.c_jsums[s, 14 + 2 * d] - reach
            hi = self.c_jsums[s, 15 + 2 * d] + reach
            if ti.abs(nb[d]) < 1.0e-9:
                if c[d] < lo or c[d] > hi:
                    out = True
            else:
                t1 = (lo - c[d]) / nb[d]
                t2 = (hi - c[d]) / nb[d]
                tmin = ti.max(tmin, ti.min(t1, t2))
                tmax = ti.min(tmax, ti.max(t1, t2))
        return out or tmin > tmax

    @ti.func
    def keep_braking(self, th, L, omega, nb):
        """The torque ``th`` to take back, less its part that brakes the body's spin ``omega`` about an axis in the
        contact plane (normal ``nb``), up to stopping it (``L``: the body's angular momentum about its mass centre;
        warp_mpm's ``keep_braking``). (Until round 59 ``L`` was taken as ``(I^-1)^-1 omega``, which can overflow for
        a fragment of a few points, its inertia near singular; warp_mpm always took it from the sums.)"""
        out = th
        wh = omega - omega.dot(nb) * nb
        lw = wh.norm()
        if lw > 0.0:
            w = wh / lw
            s = th.dot(w)
            Lw = L.dot(w)
            if s < 0.0 and Lw > 0.0:
                out = th - ti.max(s, -Lw) * w
        return out

    @ti.func
    def body_fix(self, s):
        """Support s's ``dv``, ``alpha`` and ``x_m`` into ``fr_sums[s, 17:26]``, the fix held to the pair's closing
        motion (:func:`closing_bound`; warp_mpm's ``body_fix``)."""
        b = s // self.n_sup
        Mc = self.fr_sums[s, 3]
        mass = self.c_mass[b]
        if Mc > 0.0 and mass > 0.0:
            first = ti.Vector([self.fr_sums[s, 4], self.fr_sums[s, 5], self.fr_sums[s, 6]], ti.f64)
            xm = first / Mc
            c = ti.Vector([self.c_shift[b, 0], self.c_shift[b, 1], self.c_shift[b, 2]], ti.f64)
            J = self.c_jsums[s, 0]
            nb, xb, vb = self.support_frame(s)
            F = ti.Vector([self.fr_sums[s, 0], self.fr_sums[s, 1], self.fr_sums[s, 2]], ti.f64)
            xcp = xb + (xm - xb).dot(nb) * nb
            u = ti.Vector([self.c_shift[b, 3], self.c_shift[b, 4], self.c_shift[b, 5]], ti.f64) \
                + ti.cast(self.dt[None] * self.gravity[None], ti.f64) \
                + ti.Vector([self.c_shift[b, 6], self.c_shift[b, 7], self.c_shift[b, 8]], ti.f64).cross(xcp - c) - vb
            ut = u - u.dot(nb) * nb
            lt = ut.norm()
            Fexp = ti.Vector.zero(ti.f64, 3)
            if lt > 0.0:
                Fexp = -(ti.min(self.fr_sums[s, 16], mass * lt) / lt) * ut
            dF = Fexp - (F - F.dot(nb) * nb)
            tn = ti.Vector([self.c_jsums[s, 7], self.c_jsums[s, 8], self.c_jsums[s, 9]], ti.f64) \
                - c.cross(ti.Vector([self.c_jsums[s, 4], self.c_jsums[s, 5], self.c_jsums[s, 6]], ti.f64))
            tf = ti.Vector([self.fr_sums[s, 13], self.fr_sums[s, 14], self.fr_sums[s, 15]], ti.f64) - c.cross(F)
            tq = tn + tf + (xm - c).cross(dF)
            th = tq - tq.dot(nb) * nb   # the twist about the normal is kept
            lh = th.norm()
            clip = J * self.c_reach[b] * TORQUE_REACH
            if ti.static(PLANE_RULE):   # round 86: bounded by the patch's departure from a plane (take_back.py)
                clip *= unresolved_fraction(self.c_jsums, s, nb, self.c_reach[b] / REACH)
            if lh > clip:
                th *= clip / lh
            th = self.keep_braking(th, ti.Vector([self.c_shift[b, 9], self.c_shift[b, 10], self.c_shift[b, 11]],
                                                 ti.f64),
                                   ti.Vector([self.c_shift[b, 6], self.c_shift[b, 7], self.c_shift[b, 8]], ti.f64), nb)
            if self.beyond_box(s, c, nb, self.c_reach[b]):
                th = ti.Vector.zero(ti.f64, 3)   # the mass centre beyond the pushed points' box: it tips, keep it all
            inertia = inertia_of(Mc, first, self.fr_sums[s, 7], self.fr_sums[s, 8], self.fr_sums[s, 9],
                                 self.fr_sums[s, 10], self.fr_sums[s, 11], self.fr_sums[s, 12])
            alpha = ti.Vector.zero(ti.f64, 3)
            tr = inertia.trace()   # > 0: a single listed node (no inertia; its trace roundoff, maybe < 0) takes no torque
            if tr > 0.0 and inertia.determinant() > 1.0e-12 * tr ** 3:
                alpha = -(inertia.inverse() @ th)
            Mp = self.c_jsums[s, 13]   # the pushed points' mass
            dv_j = ti.cast(0.0, ti.f64)   # J's velocity change on the pushed points: a rigid body's all move as one
            if self.rb_rigid[b] != 0:
                dv_j = J / mass
            elif Mp > 0.0:
                dv_j = J / Mp
            omega = ti.Vector([self.c_shift[b, 6], self.c_shift[b, 7], self.c_shift[b, 8]], ti.f64)
            k = closing_bound(dF, alpha, inertia, Mc, u + omega.cross(xm - xcp), omega, dv_j)
            dF *= k
            alpha *= k
            for q in ti.static(range(3)):
                self.fr_sums[s, 17 + q] = dF[q] / Mc
                self.fr_sums[s, 20 + q] = alpha[q]
                self.fr_sums[s, 23 + q] = xm[q]

    @ti.func
    def apply_fix(self, I):
        """A listed node moved by its support's ``dv + alpha x (X - x_m)``, given to field B alone where the grid
        update kept the node's flowing-mass fraction in ``grid_mf`` (``gasp_core.mpm.fields.B_BALANCE``,
        :meth:`Fields.field_friction`); its mark (and that) cleared."""
        b = self.grid_fbody[I]
        if self.fr_sums[b, 3] > 0.0:
            X = ti.cast(self.lo[None] + self.dx[None] * ti.cast(I, self.real), ti.f64)
            dv = ti.Vector([self.fr_sums[b, 17], self.fr_sums[b, 18], self.fr_sums[b, 19]], ti.f64) + ti.Vector(
                [self.fr_sums[b, 20], self.fr_sums[b, 21], self.fr_sums[b, 22]], ti.f64).cross(
                X - ti.Vector([self.fr_sums[b, 23], self.fr_sums[b, 24], self.fr_sums[b, 25]], ti.f64))
            self.grid_v[I] += ti.cast(dv, self.real)
            if ti.static(self.b_friction and self.mixed and self.field_rule // 4 % 2 != 0):
                f = self.grid_mf[I]
                if f > 0.0 and f < 1.0:
                    self.field_friction(I, ti.cast(dv, self.real), f, 1)
        if ti.static(self.b_friction and self.mixed and self.field_rule // 4 % 2 != 0):
            self.grid_mf[I] = 0.0
        self.grid_fbody[I] = -1
