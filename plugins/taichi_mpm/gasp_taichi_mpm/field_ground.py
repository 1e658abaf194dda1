"""The two-field contact's ground friction (``gasp_core.mpm.fields``): the nodes where the particle contact's
friction acts with the fields' offsets kept (``B_FRICTION`` in a ``"mixed"`` scene; rounds 81-82, beside a rigid
field, ``gasp_core.mpm.rigid_a.rigid_friction_side``), and which field takes it. Mixed into
:class:`gasp_taichi_mpm.fields.Fields`; warp_mpm's ``grid.build_field_friction``.
"""
import taichi as ti


@ti.data_oriented
class FieldGround:
    """The grounds' and walls' held nodes and the particle contact's friction between the two fields."""

    @ti.func
    def held_node(self, I):
        """1 where a ground's or the walls' grid rule reaches node I (both fields move with the mean there)."""
        held = 0
        for b in ti.static(range(self.n_grounds)):
            if self.field_reach(b, I):   # with the touched layer, the top layer freed (touch.py)
                held = 1
        for b in ti.static(range(self.n_walls)):
            if (I < self.wall_lo_first[b]).any() or (I >= self.wall_hi_first[b]).any():
                held = 1
        return held

    @ti.func
    def friction_base(self, I, v, m, f):
        """``(v_f, m_f, on)``: what the particle contact's friction acts on at node I (mean velocity ``v`` after the
        boundaries, mass ``m``, flowing-mass fraction ``f``). ``on`` 1 where the two fields keep their offsets
        (``B_FRICTION`` in a ``"mixed"`` scene, or round 81's ``RIGID_A_FRICTION`` with ``f`` a rigid field A's mass
        fraction; ``0 < f < 1``, not :meth:`held_node`); there, with ``field_rule`` bit
        2 (``gasp_core.mpm.fields.B_OWN_FRICTION``), field B's own velocity and mass ``(1 - f) m``; else ``(v, m)``
        (warp_mpm's ``grid.build_field_friction``)."""
        on = 0
        vf, mf = v, m
        if ti.static(self.b_fric_on):
            if f > 0.0 and f < 1.0 and self.held_node(I) == 0:
                on = 1
                if ti.static(self.field_rule // 2 % 2 != 0):
                    d = self.grid_dv[I]
                    vf, mf = v + ti.Vector([d[3], d[4], d[5]]), (1.0 - f) * m
        return vf, mf, on

    @ti.func
    def pc_friction(self, I, v_in, m, budget, f):
        """The particle contact's Coulomb friction at node I (mean velocity ``v_in`` after the boundaries, mass ``m``,
        the budget ``budget``; with walls or colliders relative to the supports, normal to them: ``grid_fnv``) on
        what :meth:`friction_base` names, then the contact's balance (balance.py; where the fields keep their offsets
        ``f`` kept in ``grid_mf`` for its fix, ``gasp_core.mpm.fields.B_BALANCE``) and :meth:`field_friction`; returns
        the node's new mean velocity."""
        fa = ti.abs(f)   # round 82: f < 0, A's mass fraction where field B is rigid at the node (rigid_side_mass)
        vf, mf, on = self.friction_base(I, v_in, m, fa)
        v = vf
        if ti.static(self.nfric):
            g = self.grid_fnv[I]
            self.grid_fnv[I] = ti.Vector.zero(self.real, 6)
            v = self.surface_friction(vf, mf, budget, ti.Vector([g[0], g[1], g[2]]), ti.Vector([g[3], g[4], g[5]]))
        else:
            v = self.node_friction(vf, mf, budget)
        if mf < m:   # on B's own velocity: the mean takes B's share of the change
            v = v_in + (mf / m) * (v - vf)
        if self.n_spin > 0:
            self.balance_node(I, v_in, v, m, budget)
            if ti.static(self.b_friction and self.mixed and self.field_rule // 4 % 2 != 0):
                if on != 0 and self.grid_fbody[I] >= 0:   # B_BALANCE: f kept for the balance's fix (apply_fix)
                    self.grid_mf[I] = fa
        if f < 0.0:   # round 82: to field A alone
            on *= 2
        self.field_friction(I, v - v_in, fa, on)
        return v

    @ti.func
    def field_friction(self, I, dv, f, on):
        """The particle contact's friction ``dv`` (m/s, its change of node I's mean velocity; B's points' budget) given
        to field B alone where ``on`` (:meth:`friction_base`; ``gasp_core.mpm.fields.B_FRICTION``): A's offset
        less ``dv``, B's plus ``dv f / (1 - f)``, ``f`` the node's flowing-mass fraction (A's share); ``on`` 2 (round
        82: a rigid field B, ``gasp_core.mpm.rigid_a.rigid_friction_side``) to field A alone, B's offset less ``dv``,
        A's plus ``dv (1 - f) / f``."""
        if ti.static(self.b_fric_on):
            if on == 1:
                d = self.grid_dv[I]
                db = (f / (1.0 - f)) * dv
                self.grid_dv[I] = ti.Vector([d[0] - dv[0], d[1] - dv[1], d[2] - dv[2], d[3] + db[0], d[4] + db[1],
                                             d[5] + db[2]])
            elif on == 2:
                d = self.grid_dv[I]
                da = ((1.0 - f) / f) * dv
                self.grid_dv[I] = ti.Vector([d[0] + da[0], d[1] + da[1], d[2] + da[2], d[3] - dv[0], d[4] - dv[1],
                                             d[5] - dv[2]])

    @ti.func
    def rigid_side_mass(self, r, m, m_a):
        """Round 82 (``gasp_core.mpm.rigid_a.rigid_node_rule``): ``r`` node I's rigid mass (P2G), ``m`` its mass, ``m_a``
        field A's: ``m_a`` where A holds all the rigid mass and B none (rule bit 1, the friction to B alone), ``-m_a``
        where B holds all and A none (bit 2, to A alone), else 0 (both fields take it); warp_mpm's
        ``field_nodes.rigid_side_mass``."""
        out = ti.cast(0.0, self.real)
        m_b = m - m_a
        tol = 1e-5 * m
        if r > 0.0 and m_a > 0.0 and m_b > 0.0:
            if ti.static(self.rigid_rule % 2 != 0):
                if ti.abs(r - m) <= tol or ti.abs(r - m_a) <= tol:
                    out = m_a
            if ti.static(self.rigid_rule // 2 % 2 != 0):
                if out == 0.0 and ti.abs(r - m_b) <= tol:
                    out = -m_a
        return out
