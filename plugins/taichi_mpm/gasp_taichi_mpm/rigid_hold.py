"""The rigid bodies' hold on the flowing points (``gasp_core.mpm.rigid_hold``, docs/contact.md; warp_mpm's
``rigid_hold.py`` spells the same steps): after a point's G2P (:meth:`Colliders.hold_point`, after the colliders'
hold), a point of a body of the grid contact found inside a holding rigid body (its distance field at the body's
pose of that substep, read as a collider's, :meth:`Colliders.field_at`) is put back on its surface, its approach
relative to the body removed and its slip reduced by Coulomb's friction (:meth:`Colliders.collide`); its momentum
change is given back to the body through the sums of its next projection (``rb_hold``, :meth:`held`).

Within a frame the rigid bodies' G2P and projection run before the fused G2P + P2G kernel (``solver.substeps``), so
the pose is the substep's; with the hold the frame's last substep keeps that order too (:meth:`last_g2p`).

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields it reads.
"""
import numpy as np
import taichi as ti

from gasp_core.colliders.model import COL_META
from gasp_core.mpm.grid_tables import CM_FRICTION


class RigidHold:
    """The rigid bodies' hold: its fields (:meth:`allocate_rigid_hold`), one point's hold (:meth:`hold_rigid_point`)
    and the frame's last G2P (:meth:`last_g2p`)."""

    def allocate_rigid_hold(self, tables, pairs, flows) -> None:
        """``tables``: ``gasp_core.mpm.rigid_hold.rigid_hold_tables``' ``(row, sdf, grad, meta)``, or None: no
        hold (``self.hold_rigid`` False, the code before); ``pairs``: the coefficient per (A body, holding body) where
        A's sands bring several angles (``gasp_core.mpm.fields.hold_pairs``, round 43), or None: each holding body's
        row's; ``flows``: per body, whether it takes the grid contact. Before the first substep (the kernels read
        ``hold_rigid`` and ``rh_pairs_on`` when they compile)."""
        self.hold_rigid = tables is not None
        self.rh_pairs_on = self.hold_rigid and pairs is not None
        if not self.hold_rigid:
            return
        if self.rh_pairs_on:
            self.rh_pairs = ti.field(self.real, shape=np.asarray(pairs).size)
            self.rh_pairs.from_numpy(np.asarray(pairs, np.float32 if self.real == ti.f32 else np.float64).ravel())
        row, sdf, grad, meta = tables
        nb = len(row)
        self.rh_row, self.rh_flows = ti.field(ti.i32, shape=nb), ti.field(ti.i32, shape=nb)
        self.rh_row.from_numpy(np.asarray(row, np.int32))
        self.rh_flows.from_numpy(np.asarray(flows, np.int32))
        np_real = np.float32 if self.real == ti.f32 else np.float64
        for name, a in (("rh_sdf", sdf), ("rh_grad", grad), ("rh_meta", meta)):
            f = ti.field(self.real, shape=len(a))
            f.from_numpy(np.asarray(a, np_real))
            setattr(self, name, f)
        self.rb_hold = ti.Vector.field(6, ti.f64, shape=nb)

    @ti.func
    def held(self, b):
        """Body ``b``'s impulse and its moment about the origin from the hold since its last projection, cleared
        (zeros without the hold)."""
        out = ti.Vector.zero(ti.f64, 6)
        if ti.static(self.hold_rigid):
            out = self.rb_hold[b]
            self.rb_hold[b] = ti.Vector.zero(ti.f64, 6)
        if ti.static(self.rc_on):   # round 63: the rigid collider's reaction (rigid_collider.py)
            out += self.rc_react[b]
            self.rc_react[b] = ti.Vector.zero(ti.f64, 6)
        return out

    @ti.func
    def hold_rigid_point(self, p):
        """The holding rigid bodies' hold on point ``p`` (the module's steps; warp_mpm's ``rigid_hold``)."""
        if self.rh_flows[self.body[p]] != 0:
            xp = self.x[p]
            vp = self.v[p]
            for b in range(self.n_bodies):
                r = self.rh_row[b]
                if r >= 0:
                    R = ti.cast(self.rb_R[b], self.real)
                    T = ti.cast(self.rb_c[b], self.real)
                    phi, n = self.field_at(xp, R, T, self.rh_meta, self.rh_sdf, self.rh_grad, r * COL_META, 0.0)
                    if phi < 0.0:
                        vc = ti.cast(self.rb_V[b], self.real) + ti.cast(self.rb_w[b], self.real).cross(xp - T)
                        xp -= phi * n
                        mu = self.rh_meta[r * COL_META + CM_FRICTION]
                        if ti.static(self.rh_pairs_on):   # A's sands' several angles: the point's body's pair
                            mu = self.rh_pairs[self.body[p] * self.n_bodies + b]
                        vn = vc + self.collide(vp - vc, n, mu)
                        J = -ti.cast(self.p_mass[p], ti.f64) * ti.cast(vn - vp, ti.f64)
                        L = ti.cast(xp, ti.f64).cross(J)
                        self.rb_hold[b] += ti.Vector([J[0], J[1], J[2], L[0], L[1], L[2]])   # Newton's third law
                        vp = vn
            self.x[p] = xp
            self.v[p] = vp

    @ti.kernel
    def g2p_others(self):
        """G2P of the points of the bodies that are not rigid (the frame's last, with the hold)."""
        for p in range(self.n_points[None]):
            if self.asleep[self.body[p]] == 0:
                self.fused_g2p(p)

    def last_g2p(self, at) -> None:
        """The frame's last G2P, the passive points' (``at``: their launch, or None) and the rigid projection. With
        the hold in the order of the frame's other substeps (the passive points, the rigid bodies' G2P and projection,
        the others' G2P and hold: the hold reads the bodies' new pose); without it as before (G2P, the passive
        points', the projection)."""
        if self.hold_rigid:
            if at is not None:
                self.g2p_passive(at)
            self.g2p_rigid()
            self.rigid_step()
            self.g2p_others()
            return
        self.g2p()
        if at is not None:
            self.g2p_passive(at)
        if self.any_rigid:
            self.rigid_step()
