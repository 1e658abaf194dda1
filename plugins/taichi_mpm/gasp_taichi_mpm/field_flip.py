"""AFLIP's old velocity per field in the two-field contact (round 59; docs/contact.md "Round 59: AFLIP's old velocity
per field"; ``gasp_core.mpm.fields.FIELD_OLD_VELOCITY``): mixed into :class:`~gasp_taichi_mpm.fields.Fields`, whose
``grid_v0``, ``grid_dv0``, ``grid_sv0``, ``grid_mv``, ``in_a``, ``body``, ``field_flip`` and ``real`` it reads."""
import taichi as ti

from gasp_core.mpm.fields import MIN_FRACTION


@ti.data_oriented
class FieldFlip:
    @ti.func
    def node_v0(self, p, node):
        """AFLIP's old velocity point p reads at ``node`` in G2P: the grid's (``grid_v0``), plus its field's offset
        of it (``grid_dv0``, :meth:`field_old`; round 59)."""
        v = self.grid_v0[node]
        if ti.static(self.field_flip):
            v += self.own_part(p, self.grid_dv0[node])   # Fields.own_part
        return v

    @ti.func
    def field_old(self, I, m, ng):
        """Round 59 (docs/contact.md "Round 59: AFLIP's old velocity per field"): node I's offsets of AFLIP's old
        velocity, each field's own APIC velocity less the mean's (``m_B / m u0``, ``-m_A / m u0``, ``u0 = v0_A -
        v0_B``; ``grid_mv``'s channels 4-6 the whole grid's APIC momentum, ``grid_sv0`` A's), where both fields have
        more than ``MIN_FRACTION`` of the node's mass ``m``; clears ``grid_sv0``. Without it a point's AFLIP
        increment ``v_new - v_old`` took its field's offset against the mean's old velocity each substep: the offset
        fed back with the weight ``alpha``, which grows as the substep shrinks (``1 - n_ref / n_substeps``)."""
        if ti.static(self.field_flip):
            s0 = self.grid_sv0[I]
            m_a = s0[3]
            m_b = m - m_a
            d = ti.Vector.zero(self.real, 6)
            inner = (I > 0).all() and (I < ng - 1).all()
            if inner and m_a > MIN_FRACTION * m and m_b > MIN_FRACTION * m:
                g = self.grid_mv[0, I]
                pa = ti.Vector([s0[0], s0[1], s0[2]])
                u0 = pa / m_a - (ti.Vector([g[4], g[5], g[6]]) - pa) / m_b
                da = (m_b / m) * u0
                db = -(m_a / m) * u0
                d = ti.Vector([da[0], da[1], da[2], db[0], db[1], db[2]])
            self.grid_dv0[I] = d
            self.grid_sv0[I] = ti.Vector.zero(self.real, 4)
