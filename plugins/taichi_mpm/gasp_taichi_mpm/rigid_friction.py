"""A rigid body's friction with its supports as one body (issue 53's twist, issue 67's Coulomb by force balance),
Taichi funcs mixed into :class:`gasp_taichi_mpm.rigid.Rigid`; the NumPy reference is
:mod:`gasp_core.mpm.rigid_friction`, warp_mpm's ``rigid.py`` spells the same steps.
"""
import taichi as ti

from gasp_core.mpm.rigid_friction import FLAT_FROM, FLAT_TO, TIP_SHARED
from gasp_core.mpm.rigid_support import ROUND_DEEP


@ti.func
def flatness(s3, deep, h):
    """``gasp_core.mpm.rigid_friction.contact_flatness`` (the same steps): ``s3`` three times the patch's spread
    along the slip (m^2), ``deep`` its deepest point (m), ``h`` the mass centre's height over it (m)."""
    out = ti.cast(1.0, ti.f64)
    if deep > 0.0 and h > 0.0:
        out = ti.min(ti.max((s3 / (deep * h) - FLAT_FROM) / (FLAT_TO - FLAT_FROM), 0.0), 1.0)
    return out


class RigidFriction:
    """:meth:`twist_brake` and :meth:`slide_brake`, called by ``Rigid.rigid_update`` per body; :meth:`rigid_pair`,
    the contact of two rigid bodies, after it (``Rigid.rigid_step``), with round 65's support tables
    (:meth:`set_support`, :meth:`body_row`, :meth:`flat_at`)."""

    def set_support(self, data, hollow=None) -> None:
        """The bodies' support tables (``gasp_core.mpm.rigid_pairs.support_data``: directions, supports, curvature
        tensors, bands, rows per body ``nd``, round 90's round bodies) as fields ``sup_*``; None: no table for any
        body (every band 0: every contact a face's), zero fields allocated once and nothing uploaded (round 66,
        docs/reliability.md: the empty tables' eight ``from_numpy`` calls, each a Taichi kernel turned into IR, cost
        about 0.4 s of every engine built; with every band 0 no table row is read: ``body_row`` loops ``sup_nd`` = 0 times, ``flat_at`` reads
        ``sup_delta`` alone and returns 1, and ``roll_point`` runs only where the flatness is under 1). ``hollow``:
        round 92's outer points (``gasp_core.mpm.hollow.hollow_data``) as ``hol_*``; None: none. Round 93: ``sup_curved``,
        per row 1.0 where the body reads curved (``gasp_core.mpm.rigid_support.curved_rows``)."""
        import numpy as np
        from gasp_core.mpm.rigid_support import curved_rows
        self.set_hollow(hollow)
        if data is None:
            if not getattr(self, "sup_empty", False):
                nb = max(int(self.n_bodies), 1)
                self.sup_nd, self.sup_empty, self.sup_cone = 0, True, 2.0
                self.sup_dirs = ti.Vector.field(3, ti.f64, shape=nb)
                self.sup_h = ti.field(ti.f64, shape=nb)
                self.sup_curv = ti.Matrix.field(3, 3, ti.f64, shape=nb)
                self.sup_delta = ti.field(ti.f64, shape=nb)
                self.sup_round = ti.field(ti.f64, shape=nb)
                self.sup_curved = ti.field(ti.f64, shape=nb)
            return
        dirs, h, curv, delta, self.sup_nd, rnd, self.sup_cone = data
        self.sup_empty = False
        self.sup_dirs = ti.Vector.field(3, ti.f64, shape=len(h))
        self.sup_h = ti.field(ti.f64, shape=len(h))
        self.sup_curv = ti.Matrix.field(3, 3, ti.f64, shape=len(h))
        self.sup_delta = ti.field(ti.f64, shape=len(delta))
        self.sup_round = ti.field(ti.f64, shape=len(rnd))
        self.sup_curved = ti.field(ti.f64, shape=len(h))
        for f, a in ((self.sup_dirs, dirs), (self.sup_h, h), (self.sup_curv, curv), (self.sup_delta, delta),
                     (self.sup_round, rnd), (self.sup_curved, curved_rows(h, curv))):
            f.from_numpy(np.asarray(a, np.float64))

    @ti.func
    def body_row(self, b, R, d):
        """The row of body ``b``'s table direction nearest to the world direction ``d`` at rotation ``R``
        (``gasp_core.mpm.rigid_support._row``)."""
        dl = R.transpose() @ d
        best = 0
        top = ti.cast(-2.0, ti.f64)
        for i in range(self.sup_nd):
            c = self.sup_dirs[b * self.sup_nd + i].dot(dl)
            if c > top:
                top = c
                best = b * self.sup_nd + i
        return best

    @ti.func
    def round_normal(self, a, b, n):
        """Round 91 (``gasp_core.mpm.rigid_support.pair_normal``, warp_mpm's the same): two spheres (``sup_round`` 1)
        take their line of centres; a pair of one round body takes as its normal (from ``a`` into ``b``) the other
        body's table direction within the cone (``sup_cone``, its cosine) of the nodes' ``n`` that leaves the two
        supports farthest apart (the separating axis, ``rigid_support.round_normal``); ``n`` otherwise, with the
        switch off, or where no direction lies in the cone; round 92: too deep in the hull (a hollow), and round 93:
        where the row reads the body curved (``sup_curved``), the plane fit to its outer points (``hollow_normal``);
        round 94: with it, a cylinder's foot on the fit and its side flag (0 and 0 otherwise)."""
        out = n
        foot = ti.cast(0.0, ti.f64)
        side = ti.cast(0.0, ti.f64)
        if self.sup_cone <= 1.0 and self.sup_round[a] == 1.0 and self.sup_round[b] == 1.0:
            out = (self.rb_c[b] - self.rb_c[a]).normalized()
        elif self.sup_nd > 0 and (self.sup_round[a] > 0.0) != (self.sup_round[b] > 0.0):
            f, r, sg = a, b, ti.cast(1.0, ti.f64)
            if self.sup_round[a] > 0.0:
                f, r, sg = b, a, ti.cast(-1.0, ti.f64)
            fn = sg * n   # out of f towards the round body
            dc = sg * (self.rb_c[b] - self.rb_c[a])
            Rf, Rr = self.rb_R[f], self.rb_R[r]
            top = ti.cast(-1.0e30, ti.f64)
            hr = ti.cast(0.0, ti.f64)
            best = 0
            for i in range(self.sup_nd):
                e = Rf @ self.sup_dirs[f * self.sup_nd + i]
                if e.dot(fn) >= self.sup_cone:
                    h_r = self.sup_h[self.body_row(r, Rr, -e)]
                    gap = e.dot(dc) - self.sup_h[f * self.sup_nd + i] - h_r
                    if gap > top:
                        top = gap
                        hr = h_r
                        out = sg * e
                        best = f * self.sup_nd + i
            if top < -ROUND_DEEP * hr:   # deeper in the other body's hull than a contact can be: concave, the nodes'
                out = n
                if self.sup_cone <= 1.0 and top > -1.0e29:   # round 92: in a hollow, from f's outer points
                    fit, foot, side = self.hollow_normal(f, r, fn)
                    out = sg * fit
            elif top > -1.0e29 and self.sup_curved[best] > 0.0:   # round 93: a curved face, the fit from its row
                fit, foot, side = self.hollow_normal(f, r, sg * out)
                out = sg * fit
        return out, foot, side

    @ti.func
    def pair_gap(self, a, b, n):
        """Round 91 (``gasp_core.mpm.rigid_support.pair_gap``): two spheres, or a sphere and a body that is not round,
        the gap between the two supports along ``n`` (m, < 0 overlapping); else -1e30 (none known: every approach of
        touching nodes removed, as before)."""
        g = ti.cast(-1.0e30, ti.f64)
        ra, rb = self.sup_round[a], self.sup_round[b]
        one = (ra == 1.0 and rb == 0.0) or (ra == 0.0 and rb == 1.0)
        if self.sup_cone <= 1.0 and self.sup_nd > 0 and ((ra == 1.0 and rb == 1.0) or one):
            row_a, row_b = self.body_row(a, self.rb_R[a], n), self.body_row(b, self.rb_R[b], -n)
            curved = (ra == 0.0 and self.sup_curved[row_a] > 0.0) or (rb == 0.0 and self.sup_curved[row_b] > 0.0)
            if not curved:   # round 93: none known where the body that is not round reads curved at its row
                g = n.dot(self.rb_c[b] - self.rb_c[a]) - self.sup_h[row_a] - self.sup_h[row_b]
        return g

    @ti.func
    def allowed_approach(self, gap, un):
        """Round 91's speculative contact (``gasp_core.mpm.rigid_friction.allowed_approach``): the approach speed a
        pair may keep this substep, so that it closes the gap its centres had at the step's start: ``max(gap / dt +
        un, 0)``; 0 where no gap is known."""
        s = ti.cast(0.0, ti.f64)
        if gap > -1.0e29:
            s = ti.max(gap / ti.cast(self.dt[None], ti.f64) + un, 0.0)
        return s

    @ti.func
    def flat_at(self, b, row, R, t):
        """Body ``b``'s flatness at its table row ``row`` along the slip ``t`` (``gasp_core.mpm.rigid_support.
        body_flatness``): its surface's curvature there against its support (``rigid_support.flatness``)."""
        f = ti.cast(1.0, ti.f64)
        if self.sup_delta[b] > 0.0:
            tl = R.transpose() @ t
            kh = tl.dot(self.sup_curv[row] @ tl) * self.sup_h[row]
            if kh * FLAT_TO > 1.0:
                f = ti.min(ti.max((1.0 / kh - FLAT_FROM) / (FLAT_TO - FLAT_FROM), 0.0), 1.0)
        return f

    @ti.func
    def twist_brake(self, b, w, inertia):
        """Body b's spin ``w`` (rad/s) less Coulomb's torsional friction of this substep: its part about the
        contact's mean normal ``n`` brought towards 0 by at most ``rb_twist / (n . I n)`` (``inertia``, kg m^2),
        never reversed. The nodes' friction stops only the nodes under the body (a rigid donut kept a twist of 0.06
        rad/s, losing 4.5 % a frame); this is the friction on the body as one."""
        out = w
        jn = ti.cast(self.rb_jn[b], ti.f64)
        if self.rb_twist[b] > 0.0 and jn.norm() > 0.0:
            n = jn / jn.norm()
            wn = w.dot(n)
            In = n.dot(inertia @ n)
            if In > 0.0 and wn != 0.0:
                out = w - n * (wn / ti.abs(wn)) * ti.min(ti.abs(wn), self.rb_twist[b] / In)
        self.rb_twist[b] = 0.0
        return out

    @ti.func
    def slide_brake(self, b, V, w, inertia, M, c):
        """Body b's ``(V, w)`` after Coulomb's friction on the body as one, decided by force balance
        (``gasp_core.mpm.rigid_friction.coulomb_friction``, the same steps): at the budget-weighted contact point ``x_f``
        the tangential velocity ``u_t`` (to the contact's mean normal) of ``V + w x (x_f - c)`` relative to the
        supports' takes the impulse along ``-u_t`` that stops it when that is within the substep's budget ``sum mu j``
        (it sticks), else the budget (it slides at the kinetic rate); the impulse's tipping moment is held by the
        normal contact up to ``J a f`` (``a`` the patch's half-width along ``u_t``, ``f`` its :func:`flatness`, kept
        with the patch's centre in ``rb_flat`` and ``rb_xf`` for the next substep's damping, ``Rigid.rolling_vn``): a
        block slides as a particle, a ball or a cylinder rolls (issue 67). ``(V, w)`` already hold gravity's and the
        normal contact's impulses of the substep, so the impulse that stops ``u_t`` is the one the body needs to stay.
        Its only friction with the planes and colliders (:meth:`node_budget`; issue 67)."""
        Vo, wo = V, w
        fx = self.rb_fx[b]
        jx = self.rb_jx[b]
        jn = ti.cast(self.rb_jn[b], ti.f64)
        if fx[3] > 0.0 and jn.norm() > 0.0 and jx[0] > 0.0:
            n = jn / jn.norm()
            r = ti.Vector([fx[0], fx[1], fx[2]]) / fx[3] - c
            u = V + w.cross(r) - self.rb_fv[b] / fx[3]
            ut = u - u.dot(n) * n
            lt = ut.norm()
            if lt > 0.0:
                t = ut / lt
                rt = r.cross(t)
                rh = rt - rt.dot(n) * n   # the tipping part of the moment arm
                inv = inertia.inverse()
                k_a = 1.0 / M + rt.dot(inv @ rt)   # free to turn: 1 / the effective mass along t at x_f
                m = rt.dot(inv @ rh)
                k_b = ti.max(k_a - m, 1.0 / M)   # its tipping moment held by the normal contact
                J = jx[0]
                xm = ti.Vector([jx[1], jx[2], jx[3]]) / J
                S = ti.Matrix([[jx[4], jx[5], jx[6]], [jx[5], jx[7], jx[8]], [jx[6], jx[8], jx[9]]], ti.f64) / J \
                    - xm.outer_product(xm)
                s2 = ti.max(t.dot(S @ t), 0.0)
                # a face holds the moment, a rounded contact rolls (contact_flatness): the patch's radius of
                # curvature 3 s2 / depth against the lever from the mass centre
                f = flatness(3.0 * s2, self.rb_deep[b], ti.abs((xm - c).dot(n)))
                self.rb_flat[b] = f
                self.rb_xf[b] = xm
                a = ti.sqrt(3.0 * s2) * f
                lh = rh.norm()
                hold = J * a   # round 85 (TIP_SHARED): less the moment the normal impulses already hold
                if ti.static(TIP_SHARED):
                    if lh > 0.0:
                        hold = ti.max(hold - ti.max(J * (xm - c).cross(n).dot(rh) / lh, 0.0), 0.0)
                p = lt / k_b
                held = p
                if hold < p * lh:   # more than the contact holds: the rest turns the body
                    ph = hold / lh
                    p = (lt + ph * m) / k_a
                    held = ph
                p = ti.min(p, fx[3])
                held = ti.min(held, p)
                Vo = V - (p / M) * t
                wo = w + inv @ (held * rh - p * rt)
        self.rb_fx[b] = ti.Vector.zero(ti.f64, 4)
        self.rb_fv[b] = ti.Vector.zero(ti.f64, 3)
        self.rb_jx[b] = ti.Vector.zero(ti.f64, 10)
        self.rb_deep[b] = 0.0
        return Vo, wo

    @ti.func
    def roll_flat(self, a, b, row_a, row_b, RA, RB, n, ut, lt, dw):
        """``gasp_core.mpm.rigid_pairs._roll_flatness`` at the bodies' table rows towards each other: the pair's
        flatness along the slip ``ut`` (``lt`` its length) or, without slip, along their relative rolling ``dw x n``;
        1 with neither."""
        f = ti.cast(1.0, ti.f64)
        roll = (dw - dw.dot(n) * n).cross(n)
        lr = roll.norm()
        if lt > 0.0 or lr > 0.0:
            t = roll / ti.max(lr, 1.0e-300)
            if lt > 0.0:
                t = ut / lt
            f = ti.min(self.flat_at(a, row_a, RA, t), self.flat_at(b, row_b, RB, t))
        return f

    @ti.func
    def roll_point(self, a, b, row_a, row_b, n, x_c):
        """``x_c`` moved along ``n`` onto where the bodies' surfaces meet (``gasp_core.mpm.rigid_support.
        contact_plane``; ``row_a``, ``row_b`` their table rows towards each other). Round 90: onto a round body's
        own surface (``sup_round`` 1 a sphere, 2 a cylinder: its exact table), midway where both or neither are
        round."""
        wa = 0.5 + 0.5 * (ti.min(self.sup_round[a], 1.0) - ti.min(self.sup_round[b], 1.0))
        plane = (wa * (self.rb_c[a].dot(n) + self.sup_h[row_a])
                 + (1.0 - wa) * (self.rb_c[b].dot(n) - self.sup_h[row_b]))
        return x_c + (plane - x_c.dot(n)) * n

    @ti.kernel
    def rigid_pair(self):
        """The contact of two rigid bodies as one, by force balance (issue 67 item 4; ``gasp_core.mpm.rigid_friction.
        pair_contact``, warp_mpm's ``rigid_friction.build_rigid_pair``, the same steps), after ``rigid_update``: the
        touching nodes' sums ``pair_acc`` (``RigidPairs.pair_touch``) give the contact's centre and normal; the mass
        centres' approach along it is removed through the centres (round 94: at a cylinder's foot, ``foot.py``), then
        Coulomb's friction of that impulse at the centre (stick within ``mu P``, else slide at ``mu P``); the
        centres' advance of the substep follows the new velocities. ``pair_acc`` is cleared."""
        dt = ti.cast(self.dt[None], ti.f64)
        half = 0.5 * self.rb_aff[None] * ti.cast(self.dx[None], ti.f64) ** 2   # 0 since round 67 (APIC_SPIN)
        mu = ti.cast(self.field_mu, ti.f64)
        for _ in range(1):
            a = 1
            if self.in_a[0] != 0:
                a = 0
            b = 1 - a
            W = self.pair_acc[0]
            n = ti.Vector([self.pair_acc[4], self.pair_acc[5], self.pair_acc[6]])
            if W > 0.0 and n.norm() > 0.0:
                n, foot, side = self.round_normal(a, b, n / n.norm())   # round 91: one round body, from the supports
                x_c = ti.Vector([self.pair_acc[1], self.pair_acc[2], self.pair_acc[3]]) / W
                MA, MB = self.rb_M[a], self.rb_M[b]
                VA, VB, wA, wB = self.rb_V[a], self.rb_V[b], self.rb_w[a], self.rb_w[b]
                armA, armB = self.foot_arms(a, b, foot)   # round 94 (foot.py): at a cylinder's foot, with its moment
                eye0 = half * ti.Matrix.identity(ti.f64, 3)
                iA0 = (self.rb_R[a] @ self.rb_I0[a] @ self.rb_R[a].transpose() + MA * eye0).inverse()
                iB0 = (self.rb_R[b] @ self.rb_I0[b] @ self.rb_R[b].transpose() + MB * eye0).inverse()
                un = self.foot_approach(VA, wA, VB, wB, armA, armB, n)
                # round 91: with the gap known, only the approach that would close it this substep (speculative)
                un -= self.allowed_approach(self.pair_gap(a, b, n), un)
                P = ti.cast(0.0, ti.f64)
                if un > 0.0:   # the approach removed
                    P = un / self.foot_mass(MA, MB, iA0, iB0, armA, armB, n)
                VA -= (P / MA) * n
                VB += (P / MB) * n
                wA -= P * (iA0 @ armA.cross(n))
                wB += P * (iB0 @ armB.cross(n))
                x_c = self.foot_point(x_c, a, b, armA, armB)
                rA, rB = x_c - self.rb_c[a], x_c - self.rb_c[b]
                u = VA + wA.cross(rA) - VB - wB.cross(rB)
                ut = u - u.dot(n) * n
                lt = ut.norm()
                if P > 0.0 and mu > 0.0 and lt > 0.0:
                    t = ut / lt
                    RA, RB = self.rb_R[a], self.rb_R[b]
                    # round 65: a round body rolls (rigid_support.pair_flatness) on its surface (contact_plane)
                    row_a, row_b = self.body_row(a, RA, n), self.body_row(b, RB, -n)
                    f = ti.min(self.flat_at(a, row_a, RA, t), self.flat_at(b, row_b, RB, t))
                    if side == 1.0:   # round 94: a point at a cylinder's foot holds no tipping moment
                        f = 0.0
                    if f < 1.0:
                        x_c = self.roll_point(a, b, row_a, row_b, n, x_c)
                        rA, rB = x_c - self.rb_c[a], x_c - self.rb_c[b]
                        u = VA + wA.cross(rA) - VB - wB.cross(rB)
                        ut = u - u.dot(n) * n
                        lt = ut.norm()
                        t = ut / ti.max(lt, 1.0e-300)
                    nIA = n.dot(RA @ self.rb_I0[a] @ RA.transpose() @ n) + half * MA
                    nIB = n.dot(RB @ self.rb_I0[b] @ RB.transpose() @ n) + half * MB
                    sA, sB = rA.cross(t).dot(n), rB.cross(t).dot(n)   # the twist arms about n
                    k = 1.0 / MA + 1.0 / MB + sA * sA / nIA + sB * sB / nIB
                    gA, gB = ti.Vector.zero(ti.f64, 3), ti.Vector.zero(ti.f64, 3)
                    if f < 1.0:   # (1 - f) of the tipping moment turns each body through its full inverse inertia
                        tA, tB = rA.cross(t), rB.cross(t)
                        gA = (1.0 - f) * (iA0 @ (tA - sA * n))   # iA0, iB0: the normal's inverse inertias, above
                        gB = (1.0 - f) * (iB0 @ (tB - sB * n))
                        k = k + (gA.dot(tA) + gB.dot(tB))
                    p = ti.min(lt / k, mu * P)
                    VA -= (p / MA) * t
                    VB += (p / MB) * t
                    wA -= (p * sA / nIA) * n
                    wB += (p * sB / nIB) * n
                    if f < 1.0:
                        wA -= p * gA
                        wB += p * gB
                self.rb_c[a] += dt * (VA - self.rb_V[a])
                self.rb_c[b] += dt * (VB - self.rb_V[b])
                self.rb_V[a], self.rb_V[b], self.rb_w[a], self.rb_w[b] = VA, VB, wA, wB
            for q in ti.static(range(7)):
                self.pair_acc[q] = 0.0
