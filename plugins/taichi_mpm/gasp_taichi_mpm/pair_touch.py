"""The flowing body's touch in the two-field contact (issue 67, round 37; ``gasp_core.mpm.fields.flow_touch``,
docs/contact.md "Round 37: the flowing body's touch"), warp_mpm's ``gasp_warp_mpm.pair_touch`` in Taichi.

In a ``"mixed"`` scene, after P2G and before :meth:`gasp_taichi_mpm.fields.Fields.field_contact`: :meth:`mark_flow`
(a parallel loop over the points, atomic max) marks the 27 stencil nodes of every point of field A (the flowing
bodies) where field B's gathered volume fraction reaches its body's level (``gasp_core.mpm.flow_reach.flow_levels``,
round 75: the point's surface, half its body's point spacing out, lies within ``FLOW_TOUCH_DELTA`` cells of B's
surface); ``field_contact`` takes those nodes as where the bodies touch, and at a
touching node on A's side of the surface (``m_A > m_B``) sets A against B's mass at that node and the node behind
it (:meth:`behind`) moving as one (Coulomb's rule, :meth:`coulomb`, on A's velocity less B's mean over the two),
adding that node's share of the reaction to ``grid_push``; after it
:meth:`apply_flow` adds that momentum to B's offset there and clears the marks and the pushes.

Round 60 (``gasp_core.mpm.gap_touch``, docs/contact.md "Round 60: a touch by geometry"): for two bodies on the
particle contact every material point of either field marks its stencil where the OTHER field's gathered
volume fraction reaches its body's level (its surface within ``SEPARATION`` of the other's), :meth:`mark_gap`.
Round 61 (``gasp_core.mpm.gap_touch.CURVATURE``): the level is the half-space table's at the body's reach plus the
smoothing's shift of the least principal curvature both fields' level surfaces share at the point
(:meth:`curved_level`).

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields (``x``, ``body``, ``in_a``, ``grid_vf``, ...)
it reads.
"""
import taichi as ti

from gasp_core.mpm import fields as core_fields, gap_touch as G
from gasp_core.mpm.flow_reach import flow_levels


@ti.data_oriented
class PairTouch:
    """The flowing body's contact nodes (:meth:`mark_flow`) and the reaction behind them (:meth:`apply_flow`)."""

    def allocate_pair_touch(self, flow: bool, gap=None, setup=None) -> None:
        """``flow_touch_on`` (``flow``: ``gasp_core.mpm.fields.flow_touch``, with two fields), ``grid_ft`` (i32 per
        node, the marks) and ``grid_push`` (B's momentum from the node in front, kg m/s); one entry each when off.
        ``gap_touch_on`` (round 60: ``gap``, the touch by geometry's level per body, ``gasp_core.mpm.gap_touch``,
        kept in ``gap_level``; None: off), whose marks take ``grid_ft`` too. ``flow_level`` (round 75): the flowing
        body's touch level per body (``gasp_core.mpm.flow_reach.flow_levels`` of ``setup``, the scene)."""
        self.flow_touch_on = bool(self.fields and flow)
        self.gap_touch_on = bool(self.fields and gap is not None)
        self.gap_curve = bool(self.gap_touch_on and G.CURVATURE)   # round 61: gap = the table, then the reaches
        ng = self.n_grid if self.flow_touch_on or self.gap_touch_on else 1
        self.grid_ft = ti.field(ti.i32, shape=(ng, ng, ng))
        ng = self.n_grid if self.flow_touch_on else 1
        self.grid_push = ti.Vector.field(3, self.real, shape=(ng, ng, ng))
        levels = list(gap) if self.gap_touch_on else []
        self.gap_level = ti.field(self.real, shape=max(4, len(levels)))
        for b, lv in enumerate(levels):
            self.gap_level[b] = float(lv)
        flow_lv = list(flow_levels(setup)) if self.flow_touch_on else []
        self.flow_level = ti.field(self.real, shape=max(4, len(flow_lv)))
        for b, lv in enumerate(flow_lv):
            self.flow_level[b] = float(lv)
        # field A's points without their affine momentum where they meet B (transfers.p2g_prep; PIC_AT_B)
        self.pic_on = bool(self.flow_touch_on and core_fields.PIC_AT_B)
        self.p_pic = ti.field(ti.i32, shape=self.x.shape[0] if self.pic_on else 1)

    @ti.kernel
    def mark_flow(self):
        """Mark the stencil nodes of field A's points where B's volume fraction reaches their body's ``flow_level``."""
        cell = self.dx[None] ** 3
        for p in range(self.n_points[None]):
            if self.in_a[self.body[p]] != 0:
                base, fx, ok = self.base_fx(self.x[p])
                if ti.static(self.pic_on):
                    self.p_pic[p] = 0
                if ok:
                    w = self.weights(fx)
                    phi = ti.cast(0.0, self.real)
                    for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                        phi += w[i][0] * w[j][1] * w[k][2] * self.grid_vf[base + ti.Vector([i, j, k])][1]
                    if phi >= self.flow_level[self.body[p]] * cell:   # its surface within FLOW_TOUCH_DELTA of B's
                        if ti.static(self.pic_on):   # its next P2G without its affine momentum (PIC_AT_B)
                            self.p_pic[p] = 1
                        for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                            ti.atomic_max(self.grid_ft[base + ti.Vector([i, j, k])], 1)

    @ti.kernel
    def mark_gap(self):
        """Round 60 (``gasp_core.mpm.gap_touch``): mark the stencil nodes of every material point where the OTHER
        field's gathered volume fraction reaches its body's ``gap_level`` (its surface on the other body's)."""
        cell = self.dx[None] ** 3
        for p in range(self.n_points[None]):
            base, fx, ok = self.base_fx(self.x[p])
            if ok:
                w = self.weights(fx)
                phi = ti.Vector.zero(self.real, 2)   # each field's gathered volume (grid_vf: A's, B's)
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    phi += w[i][0] * w[j][1] * w[k][2] * self.grid_vf[base + ti.Vector([i, j, k])]
                a = self.in_a[self.body[p]]
                other = phi[1] if a != 0 else phi[0]
                level = ti.cast(0.0, self.real)
                if ti.static(self.gap_curve):   # round 61: the level reads the curvature
                    level = self.curved_level(base, fx, w, self.body[p]) * cell
                else:
                    level = self.gap_level[self.body[p]] * cell
                if other >= level:
                    for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                        ti.atomic_max(self.grid_ft[base + ti.Vector([i, j, k])], 1)

    @ti.func
    def least_curvature(self, g, h):
        """The smaller principal curvature (1 / cells) of the level surface of a field with gradient ``g`` and Hessian
        ``h`` (index units): ``gasp_core.mpm.gap_touch.least_curvature`` (Goldman 2005); 0 where ``|g|`` <= 1e-6."""
        gn = g.norm()
        out = ti.cast(0.0, self.real)
        if gn > 1e-6:
            t = (g.dot(h @ g) - gn * gn * (h[0, 0] + h[1, 1] + h[2, 2])) / (gn * gn * gn)
            a00 = h[1, 1] * h[2, 2] - h[1, 2] * h[1, 2]
            a11 = h[0, 0] * h[2, 2] - h[0, 2] * h[0, 2]
            a22 = h[0, 0] * h[1, 1] - h[0, 1] * h[0, 1]
            a01 = h[0, 2] * h[1, 2] - h[0, 1] * h[2, 2]
            a02 = h[0, 1] * h[1, 2] - h[0, 2] * h[1, 1]
            a12 = h[0, 1] * h[0, 2] - h[0, 0] * h[1, 2]
            q = (a00 * g[0] * g[0] + a11 * g[1] * g[1] + a22 * g[2] * g[2]
                 + 2.0 * (a01 * g[0] * g[1] + a02 * g[0] * g[2] + a12 * g[1] * g[2]))
            kg = q / (gn * gn * gn * gn)
            out = 0.5 * (t - ti.sqrt(ti.max(t * t - 4.0 * kg, 0.0)))
        return out

    @ti.func
    def curved_reach(self, base, fx, w, b):
        """Round 61's reach of a point (cells; ``b`` its body): its body's reach (``gap_level[TABLE_N + b]``) plus
        ``SIGMA2`` times the least principal curvature both fields' level surfaces share there (clamped at 0)."""
        d1 = [fx - 1.5, -2.0 * (fx - 1.0), fx - 0.5]
        g = ti.Matrix.zero(self.real, 2, 3)      # each field's gradient (A's, B's), per cell of the index
        h = ti.Matrix.zero(self.real, 2, 6)      # each field's Hessian: xx, yy, zz, xy, xz, yz
        for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
            v = self.grid_vf[base + ti.Vector([i, j, k])] / self.dx[None] ** 3
            wx, wy, wz = w[i][0], w[j][1], w[k][2]
            dx, dy, dz = d1[i][0], d1[j][1], d1[k][2]
            ex, ey, ez = 1.0 - 3.0 * (i % 2), 1.0 - 3.0 * (j % 2), 1.0 - 3.0 * (k % 2)   # the weight's 2nd derivative
            for f in ti.static(range(2)):
                g[f, 0] += v[f] * dx * wy * wz
                g[f, 1] += v[f] * wx * dy * wz
                g[f, 2] += v[f] * wx * wy * dz
                h[f, 0] += v[f] * ex * wy * wz
                h[f, 1] += v[f] * wx * ey * wz
                h[f, 2] += v[f] * wx * wy * ez
                h[f, 3] += v[f] * dx * dy * wz
                h[f, 4] += v[f] * dx * wy * dz
                h[f, 5] += v[f] * wx * dy * dz
        kap = ti.cast(1e30, self.real)
        for f in ti.static(range(2)):
            hf = ti.Matrix([[h[f, 0], h[f, 3], h[f, 4]], [h[f, 3], h[f, 1], h[f, 5]], [h[f, 4], h[f, 5], h[f, 2]]])
            kap = ti.min(kap, self.least_curvature(ti.Vector([g[f, 0], g[f, 1], g[f, 2]]), hf))
        n = ti.static(G.TABLE_N)
        return self.gap_level[n + b] + G.SIGMA2 * ti.max(kap, 0.0)

    @ti.func
    def curved_level(self, base, fx, w, b):
        """Round 61's level of a point (``gasp_core.mpm.gap_touch.curved_level``; ``b`` its body): the
        half-space table (``gap_level[:TABLE_N]``) at :meth:`curved_reach`."""
        n = ti.static(G.TABLE_N)
        u = ti.min(ti.max(self.curved_reach(base, fx, w, b) / G.TABLE_STEP, 0.0), n - 1.001)
        t = ti.cast(ti.floor(u), ti.i32)
        return self.gap_level[t] + (u - t) * (self.gap_level[t + 1] - self.gap_level[t])

    @ti.func
    def coulomb(self, u, nh, mu):
        """The part ``q`` of the relative velocity ``u`` (m/s) that Coulomb's contact along the unit normal ``nh``
        removes: none where it does not approach (``u . nh <= 0``), else the approach and the slip, less what slides
        past ``mu (u . nh)``."""
        un = u.dot(nh)
        q = ti.Vector.zero(self.real, 3)
        if un > 0.0:
            ut = u - un * nh
            lt = ut.norm()
            q = un * nh + ut
            if lt > mu * un:
                q = un * nh + (mu * un / lt) * ut
        return q

    @ti.func
    def behind(self, I, nh):
        """The node next to ``I`` along the grid axis nearest the unit normal ``nh``, into B."""
        a = 0
        if ti.abs(nh[1]) > ti.abs(nh[a]):
            a = 1
        if ti.abs(nh[2]) > ti.abs(nh[a]):
            a = 2
        step = ti.Vector([0, 0, 0])
        step[a] = 1 if nh[a] >= 0.0 else -1
        return I + step

    @ti.kernel
    def apply_flow(self):
        """B's offset at each node plus ``grid_push / m_B``; the marks and pushes cleared (over the nodes P2G
        touched)."""
        lo, ext = self.touched_box()
        for idx in range(ext[0] * ext[1] * ext[2]):
            I = lo + ti.Vector([idx // (ext[1] * ext[2]), (idx // ext[2]) % ext[1], idx % ext[2]])
            push = self.grid_push[I]
            m_b = self.mass_b(I)
            if m_b > 0.0 and push.norm() > 0.0:
                d = self.grid_dv[I]
                dv = push / m_b
                self.grid_dv[I] = ti.Vector([d[0], d[1], d[2], d[3] + dv[0], d[4] + dv[1], d[5] + dv[2]])
            self.grid_push[I] = ti.Vector.zero(self.real, 3)
            self.grid_ft[I] = 0
