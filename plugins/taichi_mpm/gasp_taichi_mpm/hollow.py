"""Round 92 (issue 67 items 2 and 4; ``gasp_core.mpm.hollow``, ``docs/rigid.md`` "Round 92: a ball in a hollow"): the
normal of a round rigid body's contact in a concave part of another rigid body, from that body's outer points near
it, Taichi funcs mixed into :class:`gasp_taichi_mpm.rigid.Rigid` (``RigidFriction.round_normal`` calls
:meth:`Hollow.hollow_normal`); warp_mpm's ``rigid_support.hollow_normal`` spells the same steps.
"""
import numpy as np
import taichi as ti

from gasp_core.mpm.rigid_fit import FOOT_BAND, FOOT_SAMPLES
from gasp_core.mpm.rigid_support import HOLLOW_POWER_STEPS, HOLLOW_REACH, HOLLOW_WINDOW


class Hollow:
    """:meth:`set_hollow` (the outer points and their cells as fields ``hol_*``), :meth:`hollow_normal`."""

    def set_hollow(self, data) -> None:
        """``gasp_core.mpm.hollow.hollow_data``'s dict as fields: ``hol_X`` (the outer points, rest frames, sorted by
        cell), ``hol_cstart``, ``hol_corg``, ``hol_csize``, ``hol_cdims`` (the cells), ``hol_s`` (spacings),
        ``hol_radius``, ``hol_half``, ``hol_axis`` (the round bodies' shapes), ``hol_side`` (round 94: 1.0 for a
        cylinder whose side takes its foot as a point, 2.0 its foot alone). None: zero fields of one entry a body,
        allocated once and nothing uploaded (zero cells: no read; round 66's rule for the empty tables)."""
        nb = max(int(self.n_bodies), 1)
        if data is None and getattr(self, "hol_X", None) is not None:
            return
        size = (lambda key: nb + 1 if key == "cstart" else 4 * nb if key == "cdims" else nb) if data is None else \
            (lambda key: len(data[key]))
        for name, key, make in (("hol_X", "X", 3), ("hol_corg", "corg", 3), ("hol_axis", "axis", 3),
                                ("hol_csize", "csize", ti.f64), ("hol_s", "spacing", ti.f64),
                                ("hol_radius", "radius", ti.f64), ("hol_half", "half", ti.f64),
                                ("hol_side", "side", ti.f64),
                                ("hol_cstart", "cstart", ti.i32), ("hol_cdims", "cdims", ti.i32)):
            field = ti.Vector.field(3, ti.f64, shape=size(key)) if make == 3 else ti.field(make, shape=size(key))
            setattr(self, name, field)
            if data is not None:
                field.from_numpy(np.asarray(data[key], np.int32 if make == ti.i32 else np.float64))

    @ti.func
    def axis_gap(self, Y, e, h):
        """The distance of ``Y`` (from a round body's centre) to its axis's segment ``+-h e`` (a sphere: ``e`` 0)."""
        return (Y - ti.min(ti.max(Y.dot(e), -h), h) * e).norm()

    @ti.func
    def hollow_sums(self, f, q, e, h, reach, d_min, win):
        """One pass over body ``f``'s outer points in the cells within ``reach`` of the round body's segment ``q +-
        h e`` (``f``'s frame): with ``win`` 0 the least distance, else the plane fit's weighted sums ``(W, sum w Y,
        sum w Y Y^T)`` and round 94's along the axis (``sum w u^k``, k 1-4, ``sum w u^k Y``, k 1-2, ``u = Y . e /
        h``; ``h`` 0: none)."""
        ext = ti.abs(e) * h + reach
        o = q - self.hol_corg[f]
        c = self.hol_csize[f]
        nx, ny, nz = self.hol_cdims[4 * f], self.hol_cdims[4 * f + 1], self.hol_cdims[4 * f + 2]
        first = self.hol_cdims[4 * f + 3]
        lo = ti.max(ti.floor((o - ext) / c, ti.i32), 0)
        hi = ti.min(ti.floor((o + ext) / c, ti.i32), ti.Vector([nx - 1, ny - 1, nz - 1]))
        dm = d_min
        W = ti.cast(0.0, ti.f64)
        y = ti.Vector([0.0, 0.0, 0.0], ti.f64)
        S = ti.Matrix.zero(ti.f64, 3, 3)
        T = ti.Vector.zero(ti.f64, 4)
        Y1 = ti.Vector.zero(ti.f64, 3)
        Y2 = ti.Vector.zero(ti.f64, 3)
        for i in range(lo[0], hi[0] + 1):
            for j in range(lo[1], hi[1] + 1):
                for k in range(lo[2], hi[2] + 1):
                    g = first + (i * ny + j) * nz + k
                    for p in range(self.hol_cstart[g], self.hol_cstart[g + 1]):
                        Y = self.hol_X[p] - q
                        d = self.axis_gap(Y, e, h)
                        if d <= reach:
                            if win == 0.0:
                                dm = ti.min(dm, d)
                            else:
                                t = 1.0 - (d - d_min) / win
                                if t > 0.0:
                                    W += t * t
                                    y += (t * t) * Y
                                    S += (t * t) * Y.outer_product(Y)
                                    if h > 0.0:
                                        u = Y.dot(e) / h
                                        T += (t * t) * ti.Vector([u, u * u, u * u * u, u * u * u * u])
                                        Y1 += (t * t * u) * Y
                                        Y2 += (t * t * u * u) * Y
        return dm, W, y, S, T, Y1, Y2

    @ti.func
    def side_foot(self, W, Y0, T, Y1, Y2, m, me, h, band):
        """Round 94 (``gasp_core.mpm.rigid_fit.side_foot``): the parabola of the patch's heights ``Y . m`` in ``u =
        t / h`` from the sums, the side's gap read at ``FOOT_SAMPLES`` points along the segment, the foot (m along
        the axis) the mean of ``t`` weighted by ``max(band - (gap - least gap), 0)``; 0 where the fit is singular."""
        A = ti.Matrix([[1.0, T[0] / W, T[1] / W], [T[0] / W, T[1] / W, T[2] / W], [T[1] / W, T[2] / W, T[3] / W]],
                      ti.f64)
        foot = ti.cast(0.0, ti.f64)
        if A.determinant() > 1.0e-9:
            c = A.inverse() @ (ti.Vector([m.dot(Y0), m.dot(Y1), m.dot(Y2)], ti.f64) / W)
            least = ti.cast(1.0e30, ti.f64)
            for k in range(FOOT_SAMPLES):
                u = -1.0 + (k + 0.5) * (2.0 / FOOT_SAMPLES)
                least = ti.min(least, u * h * me - (c[1] * u + c[2] * u * u))
            P = ti.cast(0.0, ti.f64)
            Pu = ti.cast(0.0, ti.f64)
            for k in range(FOOT_SAMPLES):
                u = -1.0 + (k + 0.5) * (2.0 / FOOT_SAMPLES)
                p = ti.max(band - (u * h * me - (c[1] * u + c[2] * u * u) - least), 0.0)
                P += p
                Pu += p * u
            foot = h * Pu / P
        return foot

    @ti.func
    def hollow_normal(self, f, r, fn):
        """``gasp_core.mpm.rigid_support.hollow_normal``: the normal out of body ``f`` towards round body ``r``'s
        centre (a cylinder's axis), the least spread of ``f``'s outer points within ``d_min + HOLLOW_WINDOW s`` of
        it, of those within its radius and ``HOLLOW_REACH s`` (power steps of ``tr(C) I - C`` from the nodes' ``fn``,
        turned towards it); ``fn`` where there are none. Round 94 (``rigid_fit.hollow_contact``): with it a
        cylinder's foot (m along its axis from its centre) and ``hol_side`` where its side touches (else 0 and 0.0),
        its normal then across its axis."""
        Rf = self.rb_R[f]
        q = Rf.transpose() @ (self.rb_c[r] - self.rb_c[f])
        e = Rf.transpose() @ (self.rb_R[r] @ self.hol_axis[r])
        h = self.hol_half[r]
        reach = self.hol_radius[r] + HOLLOW_REACH * self.hol_s[f]
        d_min, _W, _y, _S, _T, _Y1, _Y2 = self.hollow_sums(f, q, e, h, reach, ti.cast(1.0e30, ti.f64),
                                                           ti.cast(0.0, ti.f64))
        out = fn
        foot = ti.cast(0.0, ti.f64)
        side = ti.cast(0.0, ti.f64)
        if d_min < 1.0e29:
            _d, W, Ys, S, T, Y1, Y2 = self.hollow_sums(f, q, e, h, reach, d_min, HOLLOW_WINDOW * self.hol_s[f])
            y = Ys / W
            C = S / W - y.outer_product(y)
            M = C.trace() * ti.Matrix.identity(ti.f64, 3) - C
            m = Rf.transpose() @ fn
            for _k in range(HOLLOW_POWER_STEPS):
                m = (M @ m).normalized()
            if m.dot(y) > 0.0:
                m = -m
            if self.hol_side[r] > 0.0 and ti.abs(y.dot(e)) < h:   # round 94: a cylinder's side
                m = (m - m.dot(e) * e).normalized()
                foot = self.side_foot(W, Ys, T, Y1, Y2, m, m.dot(e), h, FOOT_BAND * self.hol_s[f])
                side = self.hol_side[r]
            out = Rf @ m
        return out, foot, side
