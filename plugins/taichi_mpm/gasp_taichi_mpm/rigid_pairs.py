"""Rigid bodies among three or more (round 62; the NumPy reference and the design are
:mod:`gasp_core.mpm.rigid_pairs`, warp_mpm's ``rigid_pairs.py`` spells the same steps), Taichi funcs mixed into
:class:`gasp_taichi_mpm.rigid.Rigid`: :meth:`RigidPairs.node_slot`, the pair of rigid bodies a node between the two
fields serves (``Fields.field_contact`` sums the touching nodes per pair), and :meth:`RigidPairs.rigid_pairs`, the
touching pairs solved together by projected Gauss-Seidel once a substep after the rigid update.
"""
import numpy as np
import taichi as ti

from .foot import Foot
from .hollow import Hollow


class RigidPairs(Hollow, Foot):
    """The pairs' arrays (:meth:`allocate_pairs`, :meth:`set_pairs`), :meth:`node_slot` and :meth:`rigid_pairs`;
    round 92's :class:`gasp_taichi_mpm.hollow.Hollow` beneath."""

    def allocate_pairs(self, pair: int) -> None:
        """``pair`` (``gasp_core.mpm.rigid_pairs.pair_mode``): ``pair_many`` for 2 (rigid bodies among three or more),
        ``pair_acc`` (7 per slot: sum m_red, sum m_red x, sum m_red n; one slot unless ``pair_many``), the solve's
        ``pair_lam`` (4 per slot: P and J), ``pair_order``, ``pair_mu`` per slot, each body's box ``pair_box``
        (lower, upper), ``pair_V0`` and round 63's list of the touching slots (``pair_slots``, their count ``pair_n``,
        ``pair_seen`` 1 per slot listed); the sweeps (``rigid_pairs.SWEEPS``) read now."""
        from gasp_core.mpm.rigid_pairs import ISLANDS, NODE_PAD, SWEEPS
        self.pair_many = bool(self.fields and pair == 2)
        nb = max(int(self.n_bodies), 1)
        ns = nb * nb if self.pair_many else 1
        self.pair_acc = ti.field(ti.f64, shape=7 * ns)
        self.pair_lam = ti.field(ti.f64, shape=4 * ns)
        self.pair_mu = ti.field(ti.f64, shape=ns)
        self.pair_order = ti.field(ti.i32, shape=ns)
        self.pair_box = ti.Vector.field(3, ti.f64, shape=2 * nb)
        self.pair_V0 = ti.Vector.field(3, ti.f64, shape=nb)
        self.pair_slots = ti.field(ti.i32, shape=ns)   # round 63: the touching slots, listed by the node kernel
        self.pair_n = ti.field(ti.i32, shape=())
        self.pair_seen = ti.field(ti.i32, shape=ns)
        self.pair_sweeps = int(SWEEPS)
        self.pair_islands = bool(ISLANDS)   # round 81: the GPU schedule's islands (rigid_pairs_gpu)
        self.pair_pad = float(NODE_PAD)
        self.pair_rows = ti.field(ti.i32, shape=2 * ns)   # round 65: each slot's two table rows
        # round 91: the approach each slot may keep (pair_normal); round 94: its cylinder's foot and side flag (3 per
        # slot)
        self.pair_allow = ti.field(ti.f64, shape=3 * ns)
        # round 81, the GPU schedule's islands (rigid_pairs_gpu): each listed pair's height, the bodies' union-find
        # roots, each root's island, each ordered pair's island, the islands' counts, starts and fill, their pairs
        self.pair_key = ti.field(ti.f64, shape=ns)
        self.pair_root = ti.field(ti.i32, shape=nb)
        self.pair_isl_of = ti.field(ti.i32, shape=nb)
        self.pair_isl = ti.field(ti.i32, shape=ns)
        self.pair_isl_count = ti.field(ti.i32, shape=nb + 1)
        self.pair_isl_start = ti.field(ti.i32, shape=nb + 1)
        self.pair_isl_fill = ti.field(ti.i32, shape=nb + 1)
        self.pair_isl_list = ti.field(ti.i32, shape=ns)
        self.pair_isl_n = ti.field(ti.i32, shape=())
        self.set_support(None)   # round 65's tables: none until set_pairs

    def set_pairs(self, boxes, mus, collider=None, support=None, setup=None) -> None:
        """Each rigid body's box (``rigid_pairs.body_boxes``, shape (n_bodies, 2, 3), m) and each slot's ``mu``
        (``pair_frictions``); nothing unless ``pair_many``. ``collider``: round 63's (rigid_collider.py); ``support``
        round 65's tables (``rigid_pairs.support_data``, ``RigidFriction.set_support``); ``setup`` gives round 92's
        outer points (``gasp_core.mpm.hollow.hollow_data``) where there are tables and a round body (else none
        uploaded)."""
        from gasp_core.mpm.hollow import hollow_data
        self.allocate_collider(collider)
        rnd = None if support is None or setup is None else np.asarray(support[5])
        self.set_support(support, None if rnd is None or not (rnd > 0.0).any() else hollow_data(setup, rnd))
        if self.pair_many:
            self.pair_box.from_numpy(np.asarray(boxes, np.float64).reshape(-1, 3))
            self.pair_mu.from_numpy(np.asarray(mus, np.float64))

    @ti.func
    def node_slot(self, I):
        """1 + ``a * nb + b`` for the rigid body ``a`` of field A and ``b`` of B whose boxes (in their frames) node
        ``I`` lies within ``NODE_PAD`` cells of, the nearest of each field; 0 where a field has none there (or
        without ``pair_many``): ``gasp_core.mpm.rigid_pairs.node_bodies``."""
        out = 0
        if ti.static(self.pair_many):
            nb = self.n_bodies
            x = ti.cast(self.lo[None] + self.dx[None] * ti.cast(I, self.real), ti.f64)
            pad = self.pair_pad * ti.cast(self.dx[None], ti.f64)
            best_a, best_b = -1, -1
            da, db = ti.cast(1.0e30, ti.f64), ti.cast(1.0e30, ti.f64)
            for k in range(nb):
                if self.rb_rigid[k] != 0:
                    q = self.rb_R[k].transpose() @ (x - self.rb_c[k])
                    d = ti.max(self.pair_box[2 * k] - q, q - self.pair_box[2 * k + 1]).max()
                    d = ti.max(d, 0.0)
                    if d <= pad:
                        if self.in_a[k] != 0:
                            if d < da:
                                da, best_a = d, k
                        elif d < db:
                            db, best_b = d, k
            if best_a >= 0 and best_b >= 0:
                out = 1 + best_a * nb + best_b
        return out

    @ti.func
    def pair_touch(self, I, m_red, nh, s):
        """A node where two rigid bodies touch (``Fields.field_contact`` calls it): its reduced mass ``m_red`` (kg),
        and that times its position and its unit normal ``nh`` (field B's), added to ``pair_acc``'s slot ``s``
        (warp_mpm's ``fields.field_contact``); with ``pair_many`` the slot listed the first time (round 63)."""
        wr = ti.cast(m_red, ti.f64)
        xn = ti.cast(self.lo[None] + self.dx[None] * ti.cast(I, self.real), ti.f64)
        ti.atomic_add(self.pair_acc[7 * s], wr)
        for ax in ti.static(range(3)):
            ti.atomic_add(self.pair_acc[7 * s + 1 + ax], wr * xn[ax])
            ti.atomic_add(self.pair_acc[7 * s + 4 + ax], wr * ti.cast(nh[ax], ti.f64))
        if ti.static(self.pair_many):   # round 63: the slot listed the first time it gets mass
            if ti.atomic_add(self.pair_seen[s], 1) == 0:
                self.pair_slots[ti.atomic_add(self.pair_n[None], 1)] = s

    @ti.kernel
    def rigid_pairs(self):
        """``gasp_core.mpm.rigid_pairs.solve_pairs`` in one thread after ``rigid_update`` (warp_mpm's
        ``rigid_pairs.build_rigid_pairs``, the same steps): the touching pairs (round 63: the ``pair_n`` slots the node
        kernel listed in ``pair_slots``) insertion-sorted by height along gravity, ties by slot, swept
        ``pair_sweeps`` times with accumulated impulses, then the centres' advance of the substep follows the new
        velocities. Their ``pair_acc`` and ``pair_seen`` are cleared, and ``pair_n``."""
        dt = ti.cast(self.dt[None], ti.f64)
        half = 0.5 * self.rb_aff[None] * ti.cast(self.dx[None], ti.f64) ** 2   # 0 since round 67 (APIC_SPIN)
        g = ti.cast(self.gravity[None], ti.f64)
        nb = self.n_bodies
        for _ in range(1):
            n_on = self.pair_n[None]
            for q in range(n_on):   # the touching pairs, bottom up
                s = self.pair_slots[q]
                nn = self.pair_normal(s)   # round 65: the bodies' table rows towards each other
                self.pair_rows[2 * s] = self.body_row(s // nb, self.rb_R[s // nb], nn)
                self.pair_rows[2 * s + 1] = self.body_row(s - (s // nb) * nb, self.rb_R[s - (s // nb) * nb], -nn)
                for c in ti.static(range(4)):
                    self.pair_lam[4 * s + c] = 0.0
                h = self.pair_height(s, g)
                j = q
                while j > 0 and (self.pair_height(self.pair_order[j - 1], g) > h or (
                        self.pair_height(self.pair_order[j - 1], g) == h and self.pair_order[j - 1] > s)):
                    self.pair_order[j] = self.pair_order[j - 1]
                    j -= 1
                self.pair_order[j] = s
            for b in range(nb):
                self.pair_V0[b] = self.rb_V[b]
            for _sweep in range(self.pair_sweeps):
                for q in range(n_on):
                    self.pair_update(self.pair_order[q], nb, half)
            for b in range(nb):
                self.rb_c[b] += dt * (self.rb_V[b] - self.pair_V0[b])
            for q in range(n_on):   # the touching slots back to zero for the next substep
                s = self.pair_slots[q]
                for c in ti.static(range(7)):
                    self.pair_acc[7 * s + c] = 0.0
                self.pair_seen[s] = 0
            self.pair_n[None] = 0

    @ti.kernel
    def rigid_pairs_gpu(self):
        """:meth:`rigid_pairs` on the GPU schedule (round 81): the same updates in the same order on each body, so
        the same bits, with the work that grows with the pile spread over threads. Each top-level loop is a task of
        its own, run in turn:

        1. one thread a listed slot: its table rows, its impulses cleared, its height (``pair_key``);
        2. one thread a body: ``pair_V0``, and the islands' tables reset;
        3. one thread a listed slot: its rank by (height, slot) among the listed ones, which is the insertion
           sort's place (the keys are distinct), so ``pair_order`` is the one-thread kernel's;
        4. one thread (integer work, O(n_on) but for the roots' walks): the islands, the bodies joined by the
           touching pairs (union-find, the smaller root kept), numbered by their first pair in ``pair_order``; each
           island's pairs listed in that order (``pair_isl_list`` from ``pair_isl_start``);
        5. one thread an island: ``pair_sweeps`` sweeps over its own pairs in order. No two islands share a body,
           and ``pair_update`` reads and writes only its pair's two bodies and slot, so each body sees the updates of
           the one-thread kernel in its order (Box2D's and Bullet's islands, there for sleeping);
        6. one thread a body: the centres' advance; 7. one thread a listed slot: its sums cleared; then ``pair_n``.

        A pile of separate stacks is as many islands as stacks; one heap where every body touches is one island,
        swept on one thread as before (``docs/performance.md`` "Round 81"). Long because its seven tasks must run in
        one kernel, in turn."""
        dt = ti.cast(self.dt[None], ti.f64)
        half = 0.5 * self.rb_aff[None] * ti.cast(self.dx[None], ti.f64) ** 2   # 0 since round 67 (APIC_SPIN)
        g = ti.cast(self.gravity[None], ti.f64)
        nb = self.n_bodies
        for q in range(self.pair_n[None]):   # 1. each listed slot
            s = self.pair_slots[q]
            nn = self.pair_normal(s)
            self.pair_rows[2 * s] = self.body_row(s // nb, self.rb_R[s // nb], nn)
            self.pair_rows[2 * s + 1] = self.body_row(s - (s // nb) * nb, self.rb_R[s - (s // nb) * nb], -nn)
            for c in ti.static(range(4)):
                self.pair_lam[4 * s + c] = 0.0
            self.pair_key[q] = self.pair_height(s, g)
        for b in range(nb):   # 2. each body
            self.pair_V0[b] = self.rb_V[b]
            self.pair_root[b] = b
            self.pair_isl_of[b] = -1
            self.pair_isl_count[b] = 0
            self.pair_isl_fill[b] = 0
        for q in range(self.pair_n[None]):   # 3. the order: each slot's rank by (height, slot)
            s, h = self.pair_slots[q], self.pair_key[q]
            r = 0
            for j in range(self.pair_n[None]):
                hj, sj = self.pair_key[j], self.pair_slots[j]
                if hj < h or (hj == h and sj < s):
                    r += 1
            self.pair_order[r] = s
        for _ in range(1):   # 4. the islands (integer work on one thread)
            n_on = self.pair_n[None]
            for q in range(n_on):
                s = self.pair_order[q]
                ra, rb = self.pair_find(s // nb), self.pair_find(s - (s // nb) * nb)
                if ra != rb:
                    self.pair_root[ti.max(ra, rb)] = ti.min(ra, rb)
            n_isl = 0
            for q in range(n_on):
                r = self.pair_find(self.pair_order[q] // nb)
                if self.pair_isl_of[r] < 0:
                    self.pair_isl_of[r] = n_isl
                    n_isl += 1
                i = self.pair_isl_of[r]
                self.pair_isl[q] = i
                self.pair_isl_count[i] += 1
            start = 0
            for i in range(n_isl):
                self.pair_isl_start[i] = start
                start += self.pair_isl_count[i]
            self.pair_isl_start[n_isl] = start
            for q in range(n_on):
                i = self.pair_isl[q]
                self.pair_isl_list[self.pair_isl_start[i] + self.pair_isl_fill[i]] = self.pair_order[q]
                self.pair_isl_fill[i] += 1
            self.pair_isl_n[None] = n_isl
        for i in range(self.pair_isl_n[None]):   # 5. each island, swept in order
            for _sweep in range(self.pair_sweeps):
                for k in range(self.pair_isl_start[i], self.pair_isl_start[i + 1]):
                    self.pair_update(self.pair_isl_list[k], nb, half)
        for b in range(nb):   # 6. the centres follow the new velocities
            self.rb_c[b] += dt * (self.rb_V[b] - self.pair_V0[b])
        for q in range(self.pair_n[None]):   # 7. the touching slots back to zero for the next substep
            s = self.pair_slots[q]
            for c in ti.static(range(7)):
                self.pair_acc[7 * s + c] = 0.0
            self.pair_seen[s] = 0
        self.pair_n[None] = 0

    @ti.func
    def pair_find(self, x):
        """The root of body ``x`` in ``pair_root`` (union-find, the path halved on the way)."""
        r = x
        while self.pair_root[r] != r:
            self.pair_root[r] = self.pair_root[self.pair_root[r]]
            r = self.pair_root[r]
        return r

    @ti.func
    def pair_normal(self, s):
        """Slot ``s``'s unit normal from its nodes' sum, round 91's from the shapes (``RigidFriction.round_normal``),
        written back to the sum for :meth:`pair_update`, and the approach the slot may keep this substep
        (``RigidFriction.allowed_approach``, ``pair_allow``: 0 where no gap is known)."""
        nb = self.n_bodies
        a, b = s // nb, s - (s // nb) * nb
        nn = ti.Vector([self.pair_acc[7 * s + 4], self.pair_acc[7 * s + 5], self.pair_acc[7 * s + 6]])
        nn, foot, side = self.round_normal(a, b, nn / ti.max(nn.norm(), 1.0e-300))
        armA, armB = self.foot_arms(a, b, foot)   # round 94: x_c onto a cylinder's foot
        W = self.pair_acc[7 * s]
        x_c = self.foot_point(ti.Vector([self.pair_acc[7 * s + 1], self.pair_acc[7 * s + 2],
                                         self.pair_acc[7 * s + 3]]) / W, a, b, armA, armB)
        for ax in ti.static(range(3)):
            self.pair_acc[7 * s + 4 + ax] = nn[ax]
            self.pair_acc[7 * s + 1 + ax] = x_c[ax] * W
        self.pair_allow[3 * s] = self.allowed_approach(self.pair_gap(a, b, nn),
                                                       (self.rb_V[a] - self.rb_V[b]).dot(nn))
        self.pair_allow[3 * s + 1] = foot
        self.pair_allow[3 * s + 2] = side
        return nn

    @ti.func
    def pair_height(self, s, g):
        """``-g . x_c`` of slot ``s`` (m^2/s^2: the order's key)."""
        return -g.dot(ti.Vector([self.pair_acc[7 * s + 1], self.pair_acc[7 * s + 2],
                                 self.pair_acc[7 * s + 3]])) / self.pair_acc[7 * s]

    @ti.func
    def pair_update(self, s, nb, half):
        """One pair's update within a sweep (``rigid_pairs._pair_update``): slot ``s``'s normal impulse kept >= 0,
        its friction impulse within ``mu`` times it (the disk); round 65: a round body rolls (``roll_flat``)."""
        a = s // nb
        b = s - a * nb
        n = ti.Vector([self.pair_acc[7 * s + 4], self.pair_acc[7 * s + 5], self.pair_acc[7 * s + 6]])
        if n.norm() > 0.0:
            n = n / n.norm()
            x_c = ti.Vector([self.pair_acc[7 * s + 1], self.pair_acc[7 * s + 2],
                             self.pair_acc[7 * s + 3]]) / self.pair_acc[7 * s]
            MA, MB = self.rb_M[a], self.rb_M[b]
            RA, RB = self.rb_R[a], self.rb_R[b]
            eye = ti.Matrix.identity(ti.f64, 3)
            iA = (RA @ self.rb_I0[a] @ RA.transpose() + half * MA * eye).inverse()
            iB = (RB @ self.rb_I0[b] @ RB.transpose() + half * MB * eye).inverse()
            # round 94 (foot.py): at a cylinder's foot (pair_allow[3 s + 1], pair_normal's; x_c moved onto it there)
            armA, armB = self.foot_arms(a, b, self.pair_allow[3 * s + 1])
            un = self.foot_approach(self.rb_V[a], self.rb_w[a], self.rb_V[b], self.rb_w[b], armA, armB, n)
            P = ti.max(self.pair_lam[4 * s] + (un - self.pair_allow[3 * s]) / self.foot_mass(MA, MB, iA, iB, armA, armB,
                                                                                            n), 0.0)   # round 91
            dP = P - self.pair_lam[4 * s]
            self.pair_lam[4 * s] = P
            self.rb_V[a] -= (dP / MA) * n
            self.rb_V[b] += (dP / MB) * n
            self.rb_w[a] -= dP * (iA @ armA.cross(n))
            self.rb_w[b] += dP * (iB @ armB.cross(n))
            rA, rB = x_c - self.rb_c[a], x_c - self.rb_c[b]
            u = self.rb_V[a] + self.rb_w[a].cross(rA) - self.rb_V[b] - self.rb_w[b].cross(rB)
            ut = u - u.dot(n) * n
            lt = ut.norm()
            row_a, row_b = self.pair_rows[2 * s], self.pair_rows[2 * s + 1]   # round 65: a round body rolls
            f = self.roll_flat(a, b, row_a, row_b, RA, RB, n, ut, lt, self.rb_w[a] - self.rb_w[b])
            if self.pair_allow[3 * s + 2] == 1.0:   # round 94: a point at a cylinder's foot holds no tipping moment
                f = 0.0
            if f < 1.0:
                x_c = self.roll_point(a, b, row_a, row_b, n, x_c)
                rA, rB = x_c - self.rb_c[a], x_c - self.rb_c[b]
                u = self.rb_V[a] + self.rb_w[a].cross(rA) - self.rb_V[b] - self.rb_w[b].cross(rB)
                ut = u - u.dot(n) * n
                lt = ut.norm()
            nIA = n.dot(RA @ self.rb_I0[a] @ RA.transpose() @ n) + half * MA
            nIB = n.dot(RB @ self.rb_I0[b] @ RB.transpose() @ n) + half * MB
            J0 = ti.Vector([self.pair_lam[4 * s + 1], self.pair_lam[4 * s + 2], self.pair_lam[4 * s + 3]])
            J = J0
            mu = self.pair_mu[s]
            if mu > 0.0 and lt > 0.0 and P > 0.0:
                t = ut / lt
                sA, sB = rA.cross(t).dot(n), rB.cross(t).dot(n)   # the twist arms about n
                k = 1.0 / MA + 1.0 / MB + sA * sA / nIA + sB * sB / nIB
                if f < 1.0:   # (1 - f) of the tipping moment turns each body: in the effective mass
                    tA, tB = rA.cross(t), rB.cross(t)
                    k = k + (1.0 - f) * (tA.dot(iA @ (tA - tA.dot(n) * n)) + tB.dot(iB @ (tB - tB.dot(n) * n)))
                J = J + (lt / k) * t
            lJ = J.norm()
            if lJ > mu * P:   # Coulomb's disk of the pair's normal impulse: stick within, else slide on it
                J = J * (ti.max(mu, 0.0) * P / lJ)
            dJ = J - J0
            for q in ti.static(range(3)):
                self.pair_lam[4 * s + 1 + q] = J[q]
            self.rb_V[a] -= dJ / MA
            self.rb_V[b] += dJ / MB
            self.rb_w[a] -= (rA.cross(dJ).dot(n) / nIA) * n
            self.rb_w[b] += (rB.cross(dJ).dot(n) / nIB) * n
            if f < 1.0:
                hA, hB = rA.cross(dJ), rB.cross(dJ)
                self.rb_w[a] -= (1.0 - f) * (iA @ (hA - hA.dot(n) * n))
                self.rb_w[b] += (1.0 - f) * (iB @ (hB - hB.dot(n) * n))
            if P > 0.0:   # the faces hold (f of) the relative tipping spin (rigid_pairs._pair_update)
                dw = self.rb_w[a] - self.rb_w[b]
                L = (iA + iB).inverse() @ (dw - dw.dot(n) * n)
                if f < 1.0:
                    L = f * L
                self.rb_w[a] -= iA @ L
                self.rb_w[b] += iB @ L
