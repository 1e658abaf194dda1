"""Colliders (docs/colliders.md): the Coulomb "separate" collider rule that every boundary applies, and the
signed-distance colliders on a grid node's velocity, as Taichi functions.

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields and flags (``real``, ``atomic``, ...) it reads.
"""
import numpy as np
import taichi as ti

from gasp_core.mpm.grid_tables import (CM_FRICTION, CM_H, CM_NX, CM_NY, CM_NZ, CM_OFFSET, CM_ORIGIN, COL_META,
                                           COL_POSE, FT_POSES, PO_R, PO_T, PO_V, PO_W)


class Colliders:
    """The collider rule (:meth:`collide`) and the signed-distance colliders (:meth:`apply_colliders`)."""

    @ti.func
    def collide(self, v, n, mu_b):
        """taichi_elements' separate collider with Coulomb friction, unit normal ``n`` (any direction)."""
        vn = v.dot(n)
        out = v
        if vn < 0.0:
            vt = v - vn * n
            lt = vt.norm()
            if lt > 1e-30:
                out = vt * ti.max(0.0, 1.0 + mu_b * vn / lt)
            else:
                out = ti.Vector.zero(self.real, 3)
        return out

    @ti.func
    def field_at(self, X, R, T, meta: ti.template(), sdf: ti.template(), grad: ti.template(), r, thr):
        """``(phi, n)``: the signed distance (m; ``1e30`` off its grid or where its gradient vanishes) and unit outward
        normal (world) at the world point ``X`` of the field whose ``COL_META`` row starts at ``r`` of ``meta``
        (samples in ``sdf``, gradients in ``grad``), its frame at the pose ``x = R X + T``, trilinear; the normal only
        where ``phi <= thr`` (zeros elsewhere: the callers act only there). A collider's (:meth:`collider_at`) and a
        rigid body's (``rigid_hold.py``; warp_mpm's ``field_at``)."""
        h = meta[r + CM_H]
        org = ti.Vector([meta[r + CM_ORIGIN], meta[r + CM_ORIGIN + 1], meta[r + CM_ORIGIN + 2]])
        nx = ti.cast(meta[r + CM_NX], ti.i32)
        ny = ti.cast(meta[r + CM_NY], ti.i32)
        nz = ti.cast(meta[r + CM_NZ], ti.i32)
        off = ti.cast(meta[r + CM_OFFSET], ti.i32)
        u = (R.transpose() @ (X - T) - org) / h
        phi = ti.cast(1.0e30, self.real)
        n = ti.Vector.zero(self.real, 3)
        if (u[0] >= 0.0 and u[1] >= 0.0 and u[2] >= 0.0 and u[0] <= nx - 1.0 and u[1] <= ny - 1.0
                and u[2] <= nz - 1.0):
            i0 = ti.min(ti.cast(ti.floor(u[0]), ti.i32), nx - 2)
            j0 = ti.min(ti.cast(ti.floor(u[1]), ti.i32), ny - 2)
            k0 = ti.min(ti.cast(ti.floor(u[2]), ti.i32), nz - 2)
            fx = u - ti.Vector([ti.cast(i0, self.real), ti.cast(j0, self.real), ti.cast(k0, self.real)])
            ph = ti.cast(0.0, self.real)
            for di, dj, dk in ti.static(ti.ndrange(2, 2, 2)):
                wgt = ((fx[0] if di else 1.0 - fx[0]) * (fx[1] if dj else 1.0 - fx[1])
                       * (fx[2] if dk else 1.0 - fx[2]))
                ph += wgt * sdf[off + ((i0 + di) * ny + (j0 + dj)) * nz + (k0 + dk)]
            phi = ph
            g = ti.Vector.zero(self.real, 3)
            if ph <= thr:   # the gradient only where the caller acts (the lookup's costly part)
                for di, dj, dk in ti.static(ti.ndrange(2, 2, 2)):
                    wgt = ((fx[0] if di else 1.0 - fx[0]) * (fx[1] if dj else 1.0 - fx[1])
                           * (fx[2] if dk else 1.0 - fx[2]))
                    idx = off + ((i0 + di) * ny + (j0 + dj)) * nz + (k0 + dk)
                    g += wgt * ti.Vector([grad[3 * idx], grad[3 * idx + 1], grad[3 * idx + 2]])
            gl = g.norm()
            if ph > thr:
                phi = ph
            elif gl <= 0.0:
                phi = ti.cast(1.0e30, self.real)
            else:
                n = R @ (g / gl)
        return phi, n

    @ti.func
    def collider_at(self, X, c, base, thr):
        """``(phi, n, v_c)``: collider ``c``'s signed distance and unit outward normal at the world point ``X``
        (:meth:`field_at`) and its velocity there, at the pose of the time-table row at ``base``; the normal and
        velocity only where ``phi <= thr`` (zeros elsewhere: the callers act only there). The grid rule and the
        particle contact both read it (warp_mpm's ``collider_at``)."""
        p0 = base + FT_POSES + COL_POSE * c
        pr = p0 + PO_R
        R = ti.Matrix([[self.ex_tab[pr + 0], self.ex_tab[pr + 1], self.ex_tab[pr + 2]],
                       [self.ex_tab[pr + 3], self.ex_tab[pr + 4], self.ex_tab[pr + 5]],
                       [self.ex_tab[pr + 6], self.ex_tab[pr + 7], self.ex_tab[pr + 8]]])
        T = ti.Vector([self.ex_tab[p0 + PO_T], self.ex_tab[p0 + PO_T + 1], self.ex_tab[p0 + PO_T + 2]])
        phi, n = self.field_at(X, R, T, self.ex_meta, self.ex_sdf, self.ex_grad, c * COL_META, thr)
        vc = ti.Vector.zero(self.real, 3)
        if phi <= thr:
            vl = ti.Vector([self.ex_tab[p0 + PO_V], self.ex_tab[p0 + PO_V + 1], self.ex_tab[p0 + PO_V + 2]])
            om = ti.Vector([self.ex_tab[p0 + PO_W], self.ex_tab[p0 + PO_W + 1], self.ex_tab[p0 + PO_W + 2]])
            vc = vl + om.cross(X - T)
        return phi, n, vc

    def allocate_hold(self, hold, box_hold=None) -> None:
        """``hold``: per body, True where its points take the colliders' hold (:meth:`hold_point`: the bodies of the
        grid contact in a scene with colliders), or None: no hold (``self.hold_cols`` False). ``box_hold``: per body,
        its code of the ground's and walls' hold (:meth:`hold_box`, ``gasp_core.mpm.box_hold.box_hold_codes``: the
        deformable bodies of the grid contact, and since round 97 of the particle contact), or None
        (``self.hold_boxed`` False). The rigid bodies' hold is allocated after (``rigid_hold.py``;
        none: ``self.hold_rigid`` False)."""
        self.hold_rigid = False
        self.hold_cols = hold is not None and bool(np.any(hold))
        self.holds = ti.field(ti.i32, shape=max(4, len(hold) if self.hold_cols else 1))
        for b, h in enumerate(hold if self.hold_cols else []):
            self.holds[b] = int(h)
        self.hold_boxed = box_hold is not None and bool(np.any(box_hold))
        self.box_holds = ti.field(ti.i32, shape=max(4, len(box_hold) if self.hold_boxed else 1))
        for b, h in enumerate(box_hold if self.hold_boxed else []):
            self.box_holds[b] = int(h)

    @ti.func
    def hold_point(self, p):
        """The holds on point ``p`` after its G2P: the colliders' (:meth:`hold_colliders`), then the rigid bodies'
        (``rigid_hold.py``); before them the ground's and walls' (:meth:`hold_box`); nothing where none applies (the
        code before)."""
        if ti.static(self.hold_boxed):
            self.hold_box(p)
        if ti.static(self.hold_cols):
            self.hold_colliders(p)
        if ti.static(self.hold_rigid):
            self.hold_rigid_point(p)

    @ti.func
    def hold_box(self, p):
        """The ground's and walls' position-level hold on point ``p`` of a deformable body after its G2P (round 97: the
        particle contact's too, but for a point that started behind a plane, its skin below 0)
        (warp_mpm's ``box_hold``; ``gasp_core.mpm.points.hold_passive``'s rule): outside ``[hold_lo, hold_hi]`` (the box of
        ``gasp_core.mpm.points.passive_bounds``: the ground's plane, the walls' last node layers) it is put on the
        face, its velocity into the face removed, and one put on the floor loses ``hold_mu`` (the floor's friction)
        times that removed speed from its horizontal speed, Coulomb's friction. The grid rule acts at the nodes, and a
        point between a stopped node layer and a moving one was carried up to 1.25 mm under the ground by a landing at
        50 m/s (issue 66). The floor's friction: the ground's plane lies up to a cell above its top node layer, and a
        point held on it reads that stopped layer with a weight as low as 1/8, so without its own friction a sand
        column held there slid out flat (``tests/test_runout.py``)."""
        h = self.box_holds[self.body[p]]   # gasp_core.mpm.box_hold: 1 every point, 2 unless it started behind a plane
        if h == 1 or (h == 2 and self.p_contact[p][2] >= 0.0):   # with the floor's friction, as a stranded point
            self.x[p], self.v[p] = self.hold_passive(self.x[p], self.v[p], True)

    @ti.func
    def hold_colliders(self, p):
        """The colliders' position-level hold on point ``p`` after its G2P (warp_mpm's ``collider_hold``,
        docs/colliders.md "The hold"): inside a collider (``phi < 0``) it is put back on the surface along
        the outward normal, its approach relative to the collider removed and its slip reduced by Coulomb's
        friction of it (:meth:`collide`). The grid rule alone, at the nodes a cell apart, let sand slip
        through a thin wall; a point held each substep gets no deeper than one substep's travel, so it leaves
        a thin wall on the side it entered."""
        if self.holds[self.body[p]] != 0:   # a body of the grid contact
            base = self.ex_step[None] * self.ex_width
            xp = self.x[p]
            vp = self.v[p]
            for c in range(self.n_col):
                phi, n, vc = self.collider_at(xp, c, base, 0.0)
                if phi < 0.0:
                    xp -= phi * n
                    vp = vc + self.collide(vp - vc, n, self.ex_meta[c * COL_META + CM_FRICTION])
            self.x[p] = xp
            self.v[p] = vp

    @ti.func
    def apply_colliders(self, X, v, base, f):
        """Colliders on ``v`` at ``X`` (:meth:`collider_at`); inside (``phi <= -col_deep``: 0 with
        ``contact = "grid"``, ``gasp_core.mpm.contact.collider_grid_depth`` with the particle contact, which
        meets the points at the surface), :meth:`collide` relative to the collider's velocity; with the contact
        chosen per body, by the node's flowing-mass fraction ``f`` where ``phi > -col_full`` (:meth:`rule`)."""
        for c in range(self.n_col):
            phi, n, vc = self.collider_at(X, c, base, -self.col_deep)
            if phi <= -self.col_deep:
                v = self.rule(v, vc + self.collide(v - vc, n, self.ex_meta[c * COL_META + CM_FRICTION]),
                              phi > -self.col_full, f)
        return v
