"""The two-field grid contact (``gasp_core.mpm.fields``, ``docs/contact.md`` "Sand that slides on what it
touches", issue 53 items 3 and 5) in Taichi, the steps of warp_mpm's ``fields.py``: field A's bodies (``in_a``: a
mixed scene's flowing bodies, or body 1 of two soft bodies) scatter their momentum and mass to ``grid_sv`` and each
field's volume to ``grid_vf`` in P2G (:meth:`Fields.scatter_field`);
:meth:`Fields.contact_fields`, after P2G and before the grid update, turns them and the whole grid's into each field's
velocity offset ``grid_dv`` (A's in its first three channels, B's in the last three) and clears them; G2P reads a
node's velocity through :meth:`Fields.node_v`, the grid velocity plus the point's field's offset.

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields and flags (``real``, ``body``, ``box``, ...) it
reads.
"""
import taichi as ti

from gasp_core.mpm import fields as core_fields
from gasp_core.mpm.face_share import face_share
from gasp_core.mpm.fields import MIN_FRACTION, MIN_GRADIENT

from .field_flip import FieldFlip
from .field_ground import FieldGround
from .pair_push import PairPush
from .pair_touch import PairTouch


@ti.data_oriented
class Fields(PairTouch, PairPush, FieldFlip, FieldGround):
    """The two-field contact's fields and kernels (none without it: ``self.fields`` False)."""

    def set_in_a(self, in_a) -> None:
        """Round 61 (``gasp_core.mpm.colouring.recolour``): each body's field (``in_a``, per body, 1 in field A),
        written between frames."""
        for b, a in enumerate(in_a):
            self.in_a[b] = int(a)

    def allocate_fields(self, in_a, mu: float, touch: float, pair: bool = False, flow: bool = False,
                        node_mu=None, a_mu=None, gap=None, setup=None) -> None:
        """``in_a``: per body, True in field A (``gasp_core.mpm.fields.field_bodies``), or None: one field;
        ``mu`` the Coulomb coefficient (``field_friction``), ``touch`` the touch threshold (``touch_fraction``),
        ``pair`` ``fields.pair_mode`` (1 two rigid bodies: the touching nodes only sum into ``pair_acc``, sum m_red,
        sum m_red x, sum m_red n, for ``RigidFriction.rigid_pair``; 2 round 62's per pair), ``flow`` the flowing body's touch
        (``gasp_core.mpm.fields.flow_touch``, pair_touch.py), ``node_mu`` field B's bodies' several frictions
        (``gasp_core.mpm.fields.node_friction``: ``(own, mu_b, lo, hi)``, or None: the scalar ``mu``), ``a_mu`` field
        A's sands' several angles (``a_node_friction``: ``(mu_a, lo, hi, mu_b)``, or None: A's one), ``gap`` the touch
        by geometry's level per body (``gasp_core.mpm.gap_touch.gap_levels``, round 60; None: off), ``setup`` the
        scene (round 62's push, pair_push.py; None: off). Before the first substep."""
        self.fields = in_a is not None
        self.field_pair = bool(self.fields and pair)
        self.allocate_pairs(int(pair))   # pair_acc; round 62: rigid bodies among three or more (rigid_pairs.py)
        self.field_mu = float(mu)
        self.field_touch = float(touch)
        self.face = face_share(setup) if self.fields and setup is not None else 0.0   # round 96, read at compile
        self.in_a = ti.field(ti.i32, shape=max(4, len(in_a) if self.fields else 1))
        for b, a in enumerate(in_a if self.fields else []):
            self.in_a[b] = int(a)
        ng = self.n_grid if self.fields else 1
        self.grid_sv = ti.Vector.field(4, self.real, shape=(ng, ng, ng))
        self.grid_vf = ti.Vector.field(2, self.real, shape=(ng, ng, ng))
        self.grid_dv = ti.Vector.field(6, self.real, shape=(ng, ng, ng))
        # round 59 (docs/contact.md "Round 59: AFLIP's old velocity per field"): with AFLIP (flip > 0) field A's APIC
        # momentum and mass (grid_sv0) and each field's offset of the old velocity (grid_dv0, A's then B's)
        self.field_flip = bool(self.fields and self.flip > 0 and core_fields.FIELD_OLD_VELOCITY)
        nf = self.n_grid if self.field_flip else 1
        self.grid_sv0 = ti.Vector.field(4, self.real, shape=(nf, nf, nf))
        self.grid_dv0 = ti.Vector.field(6, self.real, shape=(nf, nf, nf))
        self.allocate_pair_touch(flow, gap, setup)
        self.allocate_push(setup)   # round 62: an overlap let out (pair_push.py)
        # B's bodies' several frictions (round 42): B's points scatter w m mu_b to grid_fmu, the pair's per node
        self.node_mu_on = node_mu is not None
        own, mu_b, lo, hi = node_mu if self.node_mu_on else (0.0, [], 0.0, 0.0)
        self.node_mu = (float(own), float(lo), float(hi))   # read when the kernels compile
        # A's sands' several angles (round 43): A's points scatter w m tan(phi) to grid_amu (a_node_friction)
        self.a_mu_on = a_mu is not None
        mu_a, a_lo, a_hi, a_mub = a_mu if self.a_mu_on else ([], 0.0, 0.0, 0.0)
        self.a_mu = (float(a_lo), float(a_hi), float(a_mub))   # read when the kernels compile
        self.body_mu = ti.field(self.real, shape=max(4, len(mu_b), len(mu_a)))   # B's friction, A's tan(phi)
        for b, mu in enumerate(mu_b):
            self.body_mu[b] = float(mu)
        for b, t in enumerate(mu_a):
            if in_a[b]:
                self.body_mu[b] = float(t)
        nm = ng if self.node_mu_on else 1
        self.grid_fmu = ti.field(self.real, shape=(nm, nm, nm))
        # round 44: B's unnamed bodies beside named ones with A per node (b_unnamed_mix): their w m to grid_umu
        self.b_un_on = self.node_mu_on and any(float(mu) == core_fields.UNNAMED for mu in mu_b)
        nu = ng if self.b_un_on else 1
        self.grid_umu = ti.field(self.real, shape=(nu, nu, nu))
        na = ng if self.a_mu_on else 1
        self.grid_amu = ti.field(self.real, shape=(na, na, na))
        # round 41 (gasp_core.mpm.fields): B's mass mirrored in a ground's layers for the normal; the particle
        # contact's friction to field B alone (read when the kernels compile)
        self.ground_mirror = bool(core_fields.GROUND_MIRROR)
        self.b_friction = bool(self.fields and core_fields.B_FRICTION)
        # round 81: the friction to the soft field beside a rigid one; round 82 per node (rigid_node_rule): P2G
        # scatters the rigid bodies' mass (mf_body) to grid_mf, field_contact writes A's back signed
        from gasp_core.mpm.rigid import rigid_mask
        from gasp_core.mpm.rigid_a import rigid_node_rule
        self.rigid_rule = rigid_node_rule(setup) if self.fields and not self.mixed and setup is not None else 0
        self.rigid_a = self.rigid_rule != 0
        if self.rigid_a:
            self.grid_mf = ti.field(self.real, shape=(ng, ng, ng))
            rigid = rigid_mask(setup.materials)
            self.mf_body = ti.field(ti.i32, shape=max(4, len(rigid)))
            for b, r in enumerate(rigid):
                self.mf_body[b] = int(r)
        self.b_fric_on = bool((self.b_friction and self.mixed) or self.rigid_a)   # friction_base, field_friction
        # round 42: a ground's top layer free in untouched columns, the friction on B's own velocity (touch.py)
        self.field_rule = core_fields.field_rule() if self.fields and self.mixed else 0

    @ti.func
    def scatter_field(self, p, base, w, mv0, A, m, S, fx, jvec):
        """P2G of point p into its field: a field-A body's momentum and mass to ``grid_sv`` and its volume to
        ``grid_vf[.][0]``, another body's volume to ``grid_vf[.][1]`` (nothing without the two-field contact); with
        AFLIP a field-A body's APIC momentum (less the stress part ``S`` and the contact impulse ``jvec``) and mass
        to ``grid_sv0``."""
        if ti.static(self.fields):
            fl = self.in_a[self.body[p]]
            vol = self.p_vol[p]
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                weight = w[i][0] * w[j][1] * w[k][2]
                node = base + ti.Vector([i, j, k])
                add_vf = ti.Vector([weight * vol, 0.0]) if fl != 0 else ti.Vector([0.0, weight * vol])
                if ti.static(self.atomic):
                    ti.atomic_add(self.grid_vf[node], add_vf)
                else:   # coloured or serial P2G: no two threads share a node (transfers.py)
                    self.grid_vf[node] = self.grid_vf[node] + add_vf
                if ti.static(self.node_mu_on):   # B's friction, mass-weighted (node_friction)
                    if fl == 0:
                        if ti.static(self.b_un_on):   # round 44: an unnamed body's mass to grid_umu
                            self.scatter_b_mu(node, weight * m, self.body_mu[self.body[p]])
                        else:
                            add_mu = weight * m * self.body_mu[self.body[p]]
                            if ti.static(self.atomic):
                                ti.atomic_add(self.grid_fmu[node], add_mu)
                            else:
                                self.grid_fmu[node] = self.grid_fmu[node] + add_mu
                if ti.static(self.a_mu_on):   # A's sands' angles, mass-weighted (a_node_friction)
                    if fl != 0:
                        add_t = weight * m * self.body_mu[self.body[p]]
                        if ti.static(self.atomic):
                            ti.atomic_add(self.grid_amu[node], add_t)
                        else:
                            self.grid_amu[node] = self.grid_amu[node] + add_t
                if ti.static(self.rigid_a):   # rounds 81-82: the rigid bodies' mass for the grid update's friction
                    if self.mf_body[self.body[p]] != 0:   # an atomic add: the same bits as a plain one serially
                        ti.atomic_add(self.grid_mf[node], weight * m)
                if fl != 0:
                    mv = mv0 + A @ ti.Vector([float(i), float(j), float(k)])
                    add_sv = weight * ti.Vector([mv[0], mv[1], mv[2], m])
                    if ti.static(self.atomic):
                        ti.atomic_add(self.grid_sv[node], add_sv)
                    else:
                        self.grid_sv[node] = self.grid_sv[node] + add_sv
                    if ti.static(self.field_flip):   # A's APIC momentum (transfers.node_val's, without stress, j_n)
                        mv0_ = mv - S @ (ti.Vector([float(i), float(j), float(k)]) - fx) - jvec
                        add_sv0 = weight * ti.Vector([mv0_[0], mv0_[1], mv0_[2], m])
                        if ti.static(self.atomic):
                            ti.atomic_add(self.grid_sv0[node], add_sv0)
                        else:
                            self.grid_sv0[node] = self.grid_sv0[node] + add_sv0

    @ti.func
    def scatter_b_mu(self, node, wm, mu_p):
        """A point of B's ``w m`` (``wm``, kg) at ``node`` where B's unnamed bodies have a channel (round 44,
        ``gasp_core.mpm.fields.b_unnamed_mix``): ``wm mu_p`` to ``grid_fmu``, or ``wm`` to ``grid_umu`` for an
        unnamed body (``mu_p`` ``UNNAMED``, negative)."""
        if mu_p >= 0.0:
            if ti.static(self.atomic):
                ti.atomic_add(self.grid_fmu[node], wm * mu_p)
            else:
                self.grid_fmu[node] = self.grid_fmu[node] + wm * mu_p
        else:
            if ti.static(self.atomic):
                ti.atomic_add(self.grid_umu[node], wm)
            else:
                self.grid_umu[node] = self.grid_umu[node] + wm

    @ti.func
    def node_pair(self, I, mu, m_a, m_b):
        """The A-B pair's Coulomb coefficient at node I: ``mu`` (the scalar) unless a field brings several (round 42:
        B's mass-weighted ``mu_B`` with the sand's one ``tan(phi)``; round 43: A's mass-weighted ``tan_A`` with B's
        ``mu_B`` per node, or its one, or ``tan_A`` where B names none; round 44: B's unnamed bodies in ``mu_B`` at
        ``tan_A``), ``combine_friction`` of the two."""
        mu_n = mu
        if ti.static(self.a_mu_on):
            t_a = ti.min(ti.max(self.grid_amu[I] / m_a, ti.static(self.a_mu[0])), ti.static(self.a_mu[1]))
            mu_bn = t_a
            if ti.static(self.b_un_on):   # round 44: B's unnamed bodies at A's own, tan_A
                s_b = self.grid_fmu[I] + t_a * self.grid_umu[I]
                mu_bn = ti.min(ti.max(s_b / m_b, ti.static(self.node_mu[1])), ti.static(self.node_mu[2]))
            elif ti.static(self.node_mu_on):
                mu_bn = ti.min(ti.max(self.grid_fmu[I] / m_b, ti.static(self.node_mu[1])), ti.static(self.node_mu[2]))
            elif ti.static(self.a_mu[2] >= 0.0):
                mu_bn = ti.cast(ti.static(self.a_mu[2]), self.real)
            mu_n = ti.min(ti.sqrt(t_a * mu_bn), 10.0)
        elif ti.static(self.node_mu_on):
            mu_bn = ti.min(ti.max(self.grid_fmu[I] / m_b, ti.static(self.node_mu[1])), ti.static(self.node_mu[2]))
            mu_n = ti.min(ti.sqrt(ti.static(self.node_mu[0]) * mu_bn), 10.0)
        return mu_n

    @ti.func
    def own_part(self, p, d):
        """Point p's field's half of a node's offsets ``d`` (6: field A's, then B's)."""
        r = ti.Vector([d[3], d[4], d[5]])
        if self.in_a[self.body[p]] != 0:
            r = ti.Vector([d[0], d[1], d[2]])
        return r

    @ti.func
    def node_v(self, p, node):
        """The velocity point p reads at ``node`` in G2P: the grid's, plus its field's offset."""
        v = self.grid_v[node]
        if ti.static(self.fields):
            v += self.own_part(p, self.grid_dv[node])
        if ti.static(self.cells_on):   # Grady's cells (cells.py)
            v += self.cell_v(p, node)
        return v

    @ti.func
    def mass_b(self, I):
        """``m_B`` at node I: the whole grid's mass less field A's."""
        return self.grid_mv[0, I][3] - self.grid_sv[I][3]

    @ti.func
    def mass_b_seen(self, I):
        """``m_B`` at node I as the normal sees it (``gasp_core.mpm.fields.ground_mirror``): at or below a ground's
        top node layer, plus B's mass at its mirror image in that layer."""
        out = self.mass_b(I)
        if ti.static(self.ground_mirror):
            for b in ti.static(range(self.n_grounds)):
                top = self.ground_kmax[b]
                if I[2] <= top and 2 * top - I[2] < self.n_grid:
                    out += self.mass_b(ti.Vector([I[0], I[1], 2 * top - I[2]]))
        return out

    @ti.func
    def grad_a(self, I):
        """``grad m_A`` at the inner node ``I``: central differences of ``grid_sv``'s masses (kg)."""
        ex, ey, ez = ti.Vector([1, 0, 0]), ti.Vector([0, 1, 0]), ti.Vector([0, 0, 1])
        return ti.Vector([self.grid_sv[I + ex][3] - self.grid_sv[I - ex][3],
                          self.grid_sv[I + ey][3] - self.grid_sv[I - ey][3],
                          self.grid_sv[I + ez][3] - self.grid_sv[I - ez][3]])

    @ti.func
    def faced(self, I, grad_b, m_b):
        """Round 96 (``gasp_core.mpm.face_share``): :meth:`faced_by` at the two-field contact's share ``self.face``."""
        return self.faced_by(I, grad_b, m_b, self.face)

    @ti.func
    def faced_by(self, I, grad_b, m_b, share: ti.template()):
        """Round 96 (``gasp_core.mpm.face_share``): whether B's mass falls towards A at the inner node ``I``,
        ``-grad_b . grad m_A > share m_b |grad m_A|`` (both central differences of the node masses, ``m_b`` B's mass
        there); True where ``share`` is 0 (the rule off, as before round 96)."""
        out = True
        if ti.static(share > 0.0):
            ga = self.grad_a(I)
            out = -grad_b.dot(ga) > ti.cast(share, self.real) * m_b * ga.norm()
        return out

    @ti.func
    def a_face(self, I, m):
        """Round 96: where B shows no normal, whether the rule is on and A shows a face there (``|grad m_A| >
        MIN_GRADIENT m``): the fields then keep their offsets instead of moving as one."""
        out = False
        if ti.static(self.face > 0.0):
            ga = self.grad_a(I)
            out = ga.norm() > MIN_GRADIENT * m
        return out

    @ti.kernel
    def field_contact(self):
        """Each shared node's offsets (``gasp_core.mpm.fields``): the Coulomb contact of the two fields, over the
        nodes P2G touched (G2P reads no other: its points are where they scattered from)."""
        ng = self.n_grid
        mu = ti.cast(self.field_mu, self.real)
        cell = self.dx[None] ** 3
        lo, ext = self.touched_box()
        for idx in range(ext[0] * ext[1] * ext[2]):
            I = lo + ti.Vector([idx // (ext[1] * ext[2]), (idx // ext[2]) % ext[1], idx % ext[2]])
            g = self.grid_mv[0, I]
            m = g[3]
            sv = self.grid_sv[I]
            m_a = sv[3]
            m_b = m - m_a
            if ti.static(self.rigid_a):   # round 82: A's mass signed by the side that takes the friction
                self.grid_mf[I] = self.rigid_side_mass(self.grid_mf[I], m, m_a)
            u2 = ti.Vector.zero(self.real, 3)
            u = ti.Vector.zero(self.real, 3)
            layer = 0
            mb_eff = ti.cast(0.0, self.real)
            held = self.held_node(I)   # a ground's node layers or the walls' (the grid rule's reach): the mean
            inner = (I > 0).all() and (I < ng - 1).all()
            if inner and held == 0 and m_a > MIN_FRACTION * m and m_b > MIN_FRACTION * m:
                vf = self.grid_vf[I]
                touch = vf[0] + vf[1] >= self.field_touch * cell
                if ti.static(self.flow_touch_on or self.gap_touch_on):   # the points mark (pair_touch.py)
                    touch = self.grid_ft[I] != 0
                v_b = ti.Vector([g[0] - sv[0], g[1] - sv[1], g[2] - sv[2]]) / m_b
                u = ti.Vector([sv[0], sv[1], sv[2]]) / m_a - v_b
                ex, ey, ez = ti.Vector([1, 0, 0]), ti.Vector([0, 1, 0]), ti.Vector([0, 0, 1])
                n = ti.Vector([self.mass_b_seen(I + ex) - self.mass_b_seen(I - ex),   # field B's surface normal
                               self.mass_b_seen(I + ey) - self.mass_b_seen(I - ey),
                               self.mass_b_seen(I + ez) - self.mass_b_seen(I - ez)])
                ln = n.norm()
                u2 = u
                mu_n = self.node_pair(I, mu, m_a, m_b)   # the pair's per node with several frictions (round 42, 43)
                if ln > MIN_GRADIENT * m:
                    nh = n / ln
                    un = u.dot(nh)
                    slot = 0   # round 62: the pair of rigid bodies here among three or more (asked once, round 63)
                    if ti.static(self.pair_many):
                        if touch:
                            slot = self.node_slot(I)
                    if ti.static(self.field_pair and not self.pair_many):   # two rigid bodies: where they touch
                        if touch:
                            self.pair_touch(I, m_a * m_b / m, nh, 0)
                    elif slot > 0:   # round 62: a pair of rigid bodies among three or more
                        self.pair_touch(I, m_a * m_b / m, nh, slot - 1)
                    elif un > 0.0 and touch and self.faced(I, n, m_b):   # approaching, where B shows A a face: Coulomb
                        ut = u - un * nh
                        lt = ut.norm()
                        q = un * nh + ut
                        if lt > mu_n * un:
                            q = un * nh + (mu_n * un / lt) * ut
                        u2 = u - q
                        if ti.static(self.flow_touch_on):
                            if m_b < m_a:   # A's side: B's node behind it takes the reaction with this one's B
                                J = self.behind(I, nh)
                                m_bj = self.mass_b(J)
                                if m_bj > m_b:   # Coulomb against B's velocity over both nodes
                                    mb_eff = m_b + m_bj
                                    gj = self.grid_mv[0, J]
                                    sj = self.grid_sv[J]
                                    v_bj = ti.Vector([gj[0] - sj[0], gj[1] - sj[1], gj[2] - sj[2]]) / m_bj
                                    v_a = ti.Vector([sv[0], sv[1], sv[2]]) / m_a
                                    q = self.coulomb(v_a - (m_b * v_b + m_bj * v_bj) / mb_eff, nh, mu_n)
                                    u2 = u - q
                                    ti.atomic_add(self.grid_push[J], (m_bj * m_a / (m_a + mb_eff)) * q)
                                    layer = 1
                else:
                    if not self.a_face(I, m):   # round 96: A's face in B's middle layer keeps the offsets
                        u2 = ti.Vector.zero(self.real, 3)   # no normal: the fields move as one
            da = (m_b / ti.max(m, 1e-30)) * u2
            db = -(m_a / ti.max(m, 1e-30)) * u2
            if layer != 0:   # A against B's mass at both nodes, moving as one (pair_touch.py)
                da = (m_b / m) * u - (mb_eff / (m_a + mb_eff)) * (u - u2)
                db = -(m_a / m) * u + (m_a / (m_a + mb_eff)) * (u - u2)
            self.grid_dv[I] = ti.Vector([da[0], da[1], da[2], db[0], db[1], db[2]])
            self.field_old(I, m, ng)   # round 59: AFLIP's old velocity per field

    @ti.kernel
    def field_clear(self):
        """``grid_sv`` and ``grid_vf`` back to zero for the next P2G, over the nodes P2G touched."""
        lo, ext = self.touched_box()
        for idx in range(ext[0] * ext[1] * ext[2]):
            I = lo + ti.Vector([idx // (ext[1] * ext[2]), (idx // ext[2]) % ext[1], idx % ext[2]])
            self.grid_sv[I] = ti.Vector.zero(self.real, 4)
            self.grid_vf[I] = ti.Vector.zero(self.real, 2)
            if ti.static(self.node_mu_on):
                self.grid_fmu[I] = 0.0
            if ti.static(self.a_mu_on):
                self.grid_amu[I] = 0.0
            if ti.static(self.b_un_on):
                self.grid_umu[I] = 0.0
            if ti.static(self.gap_touch_on):   # round 60: the touch by geometry's marks
                self.grid_ft[I] = 0

    def contact_fields(self) -> None:
        """After P2G (and the viscous step), before the grid update: the grounds' touched columns (``touch.py``), then
        the contact and the clear."""
        self.touch_update()
        if self.cells_on:   # Grady's cells (cells.py)
            self.cell_contact()
        if self.fields:
            if self.flow_touch_on:
                self.mark_flow()
            if self.gap_touch_on:   # round 60: the touch by geometry (pair_touch.py)
                self.mark_gap()
            self.field_contact()
            if self.rc_on:   # round 63: each field its own velocity, the collider's band (rigid_collider.py)
                self.collider_mark()
            if self.flow_touch_on:
                self.apply_flow()
            if self.gap_push_on:   # round 62 (pair_push.py): before the volumes are cleared
                self.push_gap()
            self.field_clear()
