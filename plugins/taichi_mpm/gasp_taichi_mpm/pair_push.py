"""Round 62's push (``gasp_core.mpm.gap_push``, docs/contact.md "Round 62: letting an overlap out"), warp_mpm's
``gasp_warp_mpm.pair_push`` in Taichi: each soft body of a pair translated by its share of the mean overlap of its
points that lie past their touch level (the half-space profile inverted at the other field's gathered volume
fraction), along the normal out of the other body; no velocity changed. :meth:`push_gap` after the contact, before
``field_clear`` (the fields' volumes still on the grid). Parallel loops over the points (atomic sums per body).

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver` (through :class:`gasp_taichi_mpm.fields.Fields`), whose fields
(``x``, ``body``, ``in_a``, ``grid_vf``, ``gap_level``) it reads.
"""
import numpy as np
import taichi as ti

from gasp_core.mpm import gap_push as GP, gap_touch as G


@ti.data_oriented
class PairPush:
    """The push's parameters (:meth:`allocate_push`) and kernels (:meth:`push_gap`)."""

    def allocate_push(self, setup) -> None:
        """``gap_push_on`` (``gap_push.PUSH`` with the touch by geometry on), ``push_params``
        (``gap_push.push_params``) and ``push_acc`` (per body: the sum of ``d n``, cells, and the count)."""
        self.gap_push_on = bool(self.gap_touch_on and GP.PUSH and setup is not None)
        params = GP.push_params(setup) if self.gap_push_on else np.zeros(1)
        self.push_nb = (len(params) - G.TABLE_N) // 2 if self.gap_push_on else 1
        self.push_params = ti.field(self.real, shape=len(params))
        self.push_params.from_numpy(params.astype(np.float64 if self.real == ti.f64 else np.float32))
        self.push_acc = ti.Vector.field(4, self.real, shape=self.push_nb)
        self.push_cap = float(GP.CAP)

    @ti.func
    def table_distance(self, phi):
        """The distance (cells) at which the half-space profile (``push_params[:TABLE_N]``) reads ``phi``, odd about
        the face: ``gasp_core.mpm.gap_push.table_distance`` (a bisection)."""
        n = ti.static(G.TABLE_N)
        q = phi
        sign = 1.0
        if phi > self.push_params[0]:
            q = 1.0 - phi
            sign = -1.0
        s = ti.cast(0.0, self.real)
        if q <= self.push_params[n - 1]:
            s = (n - 1) * G.TABLE_STEP
        elif q < self.push_params[0]:
            lo, hi = 0, n - 1
            while hi - lo > 1:
                mid = (lo + hi) // 2
                if self.push_params[mid] > q:
                    lo = mid
                else:
                    hi = mid
            s = (lo + (self.push_params[lo] - q) / (self.push_params[lo] - self.push_params[hi])) * G.TABLE_STEP
        return sign * s

    @ti.kernel
    def push_overlap(self):
        """Each overlapping point's ``d n`` (cells) and 1 added to its body's ``push_acc``."""
        n = ti.static(G.TABLE_N)
        for b in range(self.push_nb):
            self.push_acc[b] = ti.Vector.zero(self.real, 4)
        for p in range(self.n_points[None]):
            b = self.body[p]
            base, fx, ok = self.base_fx(self.x[p])
            if ok and self.push_params[n + self.push_nb + b] > 0.0:
                w = self.weights(fx)
                a = self.in_a[b]
                phi = ti.cast(0.0, self.real)
                g = ti.Vector.zero(self.real, 3)
                d1 = [fx - 1.5, -2.0 * (fx - 1.0), fx - 0.5]
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    v = self.grid_vf[base + ti.Vector([i, j, k])] / self.dx[None] ** 3
                    vo = v[1] if a != 0 else v[0]
                    phi += w[i][0] * w[j][1] * w[k][2] * vo
                    g += vo * ti.Vector([d1[i][0] * w[j][1] * w[k][2], w[i][0] * d1[j][1] * w[k][2],
                                         w[i][0] * w[j][1] * d1[k][2]])
                reach = self.push_params[n + b]
                if ti.static(self.gap_curve):   # the level's curvature shift (pair_touch.curved_reach)
                    reach = self.curved_reach(base, fx, w, b)
                d = reach - self.table_distance(phi)
                gn = g.norm()
                if d > 0.0 and gn > 1e-6:
                    dn = (-d / gn) * g
                    self.push_acc[b] += ti.Vector([dn[0], dn[1], dn[2], 1.0])

    @ti.kernel
    def push_move(self):
        """Each point moved by its body's share of the mean ``d n``, at most ``gap_push.CAP`` cells."""
        n = ti.static(G.TABLE_N)
        for p in range(self.n_points[None]):
            b = self.body[p]
            acc = self.push_acc[b]
            if acc[3] > 0.0:
                t = (self.push_params[n + self.push_nb + b] / acc[3]) * ti.Vector([acc[0], acc[1], acc[2]])
                lt = t.norm()
                if lt > ti.static(self.push_cap):
                    t = (ti.static(self.push_cap) / lt) * t
                self.x[p] += self.dx[None] * t

    def push_gap(self) -> None:
        """Round 62: the overlap let out (module docstring); after the contact, before ``field_clear``."""
        self.push_overlap()
        self.push_move()
