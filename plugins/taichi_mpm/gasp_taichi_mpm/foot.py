"""Round 94 (issue 67 items 2 and 4; ``gasp_core.mpm.rigid_fit.side_foot``, ``docs/rigid.md`` "Round 94: a cylinder's
foot"): a rigid pair's normal impulse at a solid cylinder's foot, where its side bears on another rigid body's fitted
surface, with that point's moment about the cylinder's middle (a board on a log), Taichi funcs mixed into
:class:`gasp_taichi_mpm.rigid.Rigid` (``RigidFriction.rigid_pair``, ``RigidPairs.pair_update``); warp_mpm's
``foot.py`` spells the same steps.
"""
import taichi as ti


class Foot:
    """:meth:`foot_arms`, :meth:`foot_point`, :meth:`foot_approach`, :meth:`foot_mass`."""

    @ti.func
    def foot_arms(self, a, b, foot):
        """The arms (m, world) of the normal impulse from each body's centre: ``foot`` along the round body's axis
        (``RigidFriction.round_normal``'s), zero for the other body and wherever ``foot`` is 0."""
        armA, armB = ti.Vector.zero(ti.f64, 3), ti.Vector.zero(ti.f64, 3)
        if foot != 0.0:
            if self.sup_round[a] > 0.0:
                armA = foot * (self.rb_R[a] @ self.hol_axis[a])
            else:
                armB = foot * (self.rb_R[b] @ self.hol_axis[b])
        return armA, armB

    @ti.func
    def foot_point(self, x_c, a, b, armA, armB):
        """The contact point ``x_c`` moved along the round body's axis onto its foot; ``x_c`` without an arm."""
        out = x_c
        if armA.norm() > 0.0:
            e = armA.normalized()
            out = x_c + armA - (x_c - self.rb_c[a]).dot(e) * e
        elif armB.norm() > 0.0:
            e = armB.normalized()
            out = x_c + armB - (x_c - self.rb_c[b]).dot(e) * e
        return out

    @ti.func
    def foot_approach(self, VA, wA, VB, wB, armA, armB, n):
        """The approach along ``n`` (m/s) of A's point at the foot to B's (through the centres with zero arms)."""
        return (VA + wA.cross(armA) - VB - wB.cross(armB)).dot(n)

    @ti.func
    def foot_mass(self, MA, MB, iA, iB, armA, armB, n):
        """The inverse of the pair's effective mass along ``n`` at the foot (``1 / MA + 1 / MB`` with zero arms)."""
        gA, gB = armA.cross(n), armB.cross(n)
        return 1.0 / MA + 1.0 / MB + gA.dot(iA @ gA) + gB.dot(iB @ gB)
