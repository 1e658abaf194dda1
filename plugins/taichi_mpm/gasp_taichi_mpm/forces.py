"""Forces and impulses (docs/colliders.md) on a grid node's velocity, and the fields of the colliders', forces'
and impulses' tables (:func:`gasp_core.mpm.grid_tables.grid_tables`), as Taichi code.

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields and flags (``real``, ``atomic``, ...) it reads.
"""
import numpy as np
import taichi as ti

from gasp_core.mpm.grid_tables import (COL_POSE, FALLOFF_INVERSE_SQUARE, FORCE_ROW, FORCE_WIND, FR_C, FR_DRAG,
                                           FR_FALLOFF, FR_KIND, FR_MODE_COUNT, FR_MODE_START, FR_RADIUS, FR_STRENGTH,
                                           FT_POSES, IM_A, IM_B, IM_DV, IM_MODE, IM_SHAPE, IMPULSE_ADD, IMPULSE_BOX,
                                           IMPULSE_ROW, IMPULSE_SET_ALONG, MD_A, MD_K, MD_OMEGA, MD_PHASE, MODE_ROW,
                                           SET_ON, count_along)
from gasp_core.mpm import grid_tables
from gasp_core.mpm.points import HELD_STRAIN_CELLS, SET_FACE_CELLS


def count_set_boxes(ex) -> int:
    """Box impulses of ``mode = "set"`` in the tables ``ex`` (None: none): their nodes are held (``mirror_held``)."""
    if ex is None or not ex.any:
        return 0
    rows = np.asarray(ex.impulses, float).reshape(-1, IMPULSE_ROW)[:ex.n_impulses]
    return int(np.sum((rows[:, IM_SHAPE] == IMPULSE_BOX) & (rows[:, IM_MODE] != IMPULSE_ADD)))


class Forces:
    """The tables' fields (:meth:`_setup_extras`), forces (:meth:`apply_forces`) and impulses (:meth:`apply_impulses`)."""

    def _setup_extras(self, ex, time_table, np_real, n_substeps) -> None:
        """Fields of :func:`gasp_core.mpm.grid_tables.grid_tables` (``ex``); none when ``ex`` is None or empty."""
        self.has_extras = ex is not None and ex.any
        self.n_along = count_along(ex)   # set boxes with constrain = "along": their projections are built (constrain)
        # wind: per node sum_p p_vol grad N_ip (m^2), the windward area its drag acts on (private copies as grid_mv)
        self.has_wind = bool(self.has_extras and ex.has_wind)
        ng = self.n_grid
        self.grid_g = ti.Vector.field(3, self.real, shape=(self.n_chunks, ng, ng, ng) if self.has_wind else (1, 1, 1, 1))
        if not self.has_extras:
            return
        self._ex_np = np_real
        self._time_table = time_table
        self.n_col, self.n_force, self.n_imp, self.ex_width = ex.n_colliders, ex.n_forces, ex.n_impulses, ex.width
        for name, arr in (("ex_sdf", ex.sdf), ("ex_grad", ex.sdf_grad), ("ex_meta", ex.col_meta),
                          ("ex_forces", ex.forces), ("ex_modes", ex.modes), ("ex_imps", ex.impulses)):
            f = ti.field(self.real, shape=len(arr))
            f.from_numpy(np.asarray(arr, np_real))
            setattr(self, name, f)
        self.ex_tab = ti.field(self.real, shape=n_substeps * self.ex_width)
        self.ex_step = ti.field(ti.i32, shape=())

    @ti.func
    def apply_forces(self, X, v, m, gsurf, t, dt):
        """Wind and point forces on velocity ``v`` of the node at ``X`` (time ``t``, substep ``dt``).

        Wind is quadratic drag on the windward surface, ``F = 1/2 rho_air C_d A |w| w``, ``w = u - v``,
        ``A = max(0, gsurf . w / |w|)`` (``gsurf = sum_p p_vol grad N_ip``, m^2; node mass ``m``, kg),
        applied implicitly in the drag rate ``k = F / (m |w|)``: ``v += w dt k / (1 + dt k)``."""
        for f in range(self.n_force):
            r = f * FORCE_ROW
            a = ti.Vector.zero(self.real, 3)
            if self.ex_forces[r + FR_KIND] == FORCE_WIND:
                u = ti.Vector([self.ex_forces[r + FR_C], self.ex_forces[r + FR_C + 1], self.ex_forces[r + FR_C + 2]])
                m0 = ti.cast(self.ex_forces[r + FR_MODE_START], ti.i32)
                for mm in range(m0, m0 + ti.cast(self.ex_forces[r + FR_MODE_COUNT], ti.i32)):
                    q = mm * MODE_ROW
                    k = ti.Vector([self.ex_modes[q + MD_K], self.ex_modes[q + MD_K + 1], self.ex_modes[q + MD_K + 2]])
                    A = ti.Vector([self.ex_modes[q + MD_A], self.ex_modes[q + MD_A + 1], self.ex_modes[q + MD_A + 2]])
                    u += A * ti.sin(k.dot(X) + self.ex_modes[q + MD_OMEGA] * t + self.ex_modes[q + MD_PHASE])
                wrel = u - v
                wn = wrel.norm()
                if wn > 0.0:
                    area = ti.max(0.0, gsurf.dot(wrel) / wn)
                    kdt = dt * self.ex_forces[r + FR_DRAG] * area * wn / m
                    v += (kdt / (1.0 + kdt)) * wrel
            else:
                d = ti.Vector([self.ex_forces[r + FR_C], self.ex_forces[r + FR_C + 1], self.ex_forces[r + FR_C + 2]]) - X
                rr = d.norm()
                strength = self.ex_forces[r + FR_STRENGTH]
                radius = self.ex_forces[r + FR_RADIUS]
                mag = strength * rr / radius
                if rr >= radius:
                    mag = strength
                    if self.ex_forces[r + FR_FALLOFF] == FALLOFF_INVERSE_SQUARE:
                        mag = strength * (radius / rr) * (radius / rr)
                if rr > 0.0:
                    a = d * (mag / rr)
            v += dt * a
        return v

    @ti.func
    def impulse_corners(self, q):
        """Impulse ``q``'s two vectors ``a, b``: a box's corners, a sphere's centre and (radius, 0, 0)."""
        r = q * IMPULSE_ROW
        return (ti.Vector([self.ex_imps[r + IM_A], self.ex_imps[r + IM_A + 1], self.ex_imps[r + IM_A + 2]]),
                ti.Vector([self.ex_imps[r + IM_B], self.ex_imps[r + IM_B + 1], self.ex_imps[r + IM_B + 2]]))

    @ti.func
    def impulse_weight(self, q):
        """Impulse ``q``'s weight in this substep's row of the time table (``grid_tables.impulse_weight``)."""
        return self.ex_tab[self.ex_step[None] * self.ex_width + FT_POSES + COL_POSE * self.n_col + q]

    @ti.func
    def set_velocity(self, q, w):
        """The velocity (m/s) a set impulse ``q`` of weight ``w > 0`` imposes: its ramp factor ``w - SET_ON`` times its
        ``velocity_change`` (``grid_tables.SET_ON``); warp_mpm's ``set_velocity``."""
        r = q * IMPULSE_ROW
        dv = ti.Vector([self.ex_imps[r + IM_DV], self.ex_imps[r + IM_DV + 1], self.ex_imps[r + IM_DV + 2]])
        return (w - SET_ON) * dv

    @ti.func
    def constrain(self, q, v_free, v_held):
        """The velocity (m/s) set impulse ``q`` leaves at a node whose velocity is ``v_free`` where its rule (the
        impulse, a ghost's mirror, a held face) gives ``v_held``: ``v_held`` (``constrain = "all"``); ``(I - a a^T)
        v_free + a a^T v_held``, ``a = dv / |dv|`` (``"along"``: the components across ``a`` left free;
        ``grid_tables.IMPULSE_SET_ALONG``). Scenes without an ``"along"`` box compile ``v_held`` alone."""
        out = v_held
        if ti.static(self.n_along > 0):
            r = q * IMPULSE_ROW
            if self.ex_imps[r + IM_MODE] == IMPULSE_SET_ALONG:
                a = ti.Vector([self.ex_imps[r + IM_DV], self.ex_imps[r + IM_DV + 1], self.ex_imps[r + IM_DV + 2]])
                a = a / a.norm()
                out = v_free + (v_held - v_free).dot(a) * a
        return out

    @ti.func
    def along_flip(self, p, a, M, M_flip):
        """A 3x3 ``M_flip`` (a gradient or a stress, the held rule's mirror of ``M``) of point ``p`` near a held face
        (``a >= 0``): for a set box's point (``fixed`` 0) whose box has ``constrain = "along"``, ``M + P (M_flip -
        M)``, ``P = a a^T``: its rows along the pull its mirror's, across it its own (:meth:`constrain` for the
        gradient's and the stress's rows); else ``M_flip``."""
        out = M_flip
        if ti.static(self.n_along > 0):
            if a >= 0 and self.fixed[p] == 0:
                q = self.set_box_at(self.x[p])
                if q >= 0:
                    r = q * IMPULSE_ROW
                    if self.ex_imps[r + IM_MODE] == IMPULSE_SET_ALONG:
                        d = ti.Vector([self.ex_imps[r + IM_DV], self.ex_imps[r + IM_DV + 1],
                                       self.ex_imps[r + IM_DV + 2]])
                        d = d / d.norm()
                        out = M + d.outer_product(d) @ (M_flip - M)
        return out

    @ti.func
    def mirror_set_boxes(self, I):
        """The ghost node ``I`` of the box impulse of ``mode = "set"`` acting in this substep that holds it
        (:meth:`set_box_at`; :meth:`gasp_taichi_mpm.grid.GridUpdate.mirror_node`, reflected about the imposed
        velocity)."""
        X = self.lo[None] + self.dx[None] * ti.Vector([ti.cast(I[0], self.real), ti.cast(I[1], self.real),
                                                       ti.cast(I[2], self.real)])
        q = self.set_box_at(X)
        if q >= 0:
            c, b = self.impulse_corners(q)
            self.grid_v[I] = self.constrain(q, self.grid_v[I], self.mirror_node(
                I, c, b, self.set_velocity(q, self.impulse_weight(q)), True, 0))

    @ti.func
    def image_share(self, v_set, J, I, empty: ti.template()):
        """The velocity (m/s) image node ``J`` lends ghost node ``I`` (:meth:`mirror_node`): ``v_set + s (v_J -
        v_set)``, ``s = min(1, m_J / m_I)`` the image's mass over the ghost's (1 where ``I`` has none), so a node of
        tiny mass (reached by one far point's stencil corner, whose stress term carries any speed) lends its speed in
        proportion to the material it holds, not at full weight (docs/fracture.md, round 37: the set box's bursts).
        ``gasp_core.mpm.grid_tables.MIRROR_BY_MASS`` off (a set box's, ``empty``) or ``FIXED_BY_MASS`` off (a fixed
        region's, ``v_set`` 0; round 40): ``v_J``."""
        v = self.grid_v[J]
        if ti.static(grid_tables.MIRROR_BY_MASS if empty else grid_tables.FIXED_BY_MASS):
            mi = self.grid_m[I]
            if mi > 0.0:
                v = v_set + ti.min(1.0, self.grid_m[J] / mi) * (v - v_set)
        return v

    @ti.func
    def image_node_v(self, p, J, a, f, q, vs):
        """The velocity (m/s) node ``J`` of the image stencil of a point ``p`` in set box ``q`` (-1: none; ``vs`` its
        velocity, :meth:`set_velocity`, found once a point by :meth:`image_C`) lends
        :meth:`gasp_taichi_mpm.grid.GridUpdate.image_C`, the face at ``f`` (m) along axis ``a``: by :meth:`image_share`
        against ``K``, the node nearest ``J``'s mirror image (the ghost that takes ``J``), so a node of tiny mass and
        large speed at the image's stencil does not set the point's gradient (docs/fracture.md "Round 40").
        ``grid_tables.IMAGE_BY_MASS`` off, or no set box: :meth:`node_v`."""
        v = self.node_v(p, J)
        if ti.static(grid_tables.IMAGE_BY_MASS):
            if q >= 0:
                K = J
                k = ti.round(2.0 * (f - self.lo[None][a]) * self.inv_dx[None] - ti.cast(J[a], self.real))
                K[a] = ti.min(ti.max(ti.cast(k, ti.i32), 0), self.n_grid - 1)
                mk = self.grid_m[K]
                if mk > 0.0:
                    v = vs + ti.min(1.0, self.grid_m[J] / mk) * (v - vs)
        return v

    @ti.func
    def set_box_at(self, X):
        """The index of a box impulse of ``mode = "set"`` acting now that holds ``X``, else -1."""
        base = self.ex_step[None] * self.ex_width
        hit = -1
        for q in range(self.n_imp):
            r = q * IMPULSE_ROW
            c, b = self.impulse_corners(q)
            w = self.ex_tab[base + FT_POSES + COL_POSE * self.n_col + q]
            if (self.ex_imps[r + IM_SHAPE] == IMPULSE_BOX and self.ex_imps[r + IM_MODE] != IMPULSE_ADD and w > 0.0
                    and (X >= c).all() and (X <= b).all()):
                hit = q
        return hit

    @ti.kernel
    def hold_set_faces(self):
        """The free node within :data:`~gasp_core.mpm.points.SET_FACE_CELLS` (half a cell) outside a set box's face
        (along its normal, inside its extent along the face): ``(v_set + s v_out) / (1 + s)``, ``s`` its distance to
        the face in cells, ``v_out`` the next node away from the box, so that with the ghost beyond it
        (:meth:`mirror_set_boxes`) the grid's linear velocity meets ``v_set`` on the face for any field, as where the
        box's own node is nearest the face. The warp_mpm plugin's ``hold_set_faces``."""
        lo, ext = self.touched_box()
        for idx in range(ext[0] * ext[1] * ext[2]):
            I = lo + ti.Vector([idx // (ext[1] * ext[2]), (idx // ext[2]) % ext[1], idx % ext[2]])
            X = self.lo[None] + self.dx[None] * ti.cast(I, self.real)
            base = self.ex_step[None] * self.ex_width
            for q in range(self.n_imp):
                r = q * IMPULSE_ROW
                c, b = self.impulse_corners(q)
                w = self.ex_tab[base + FT_POSES + COL_POSE * self.n_col + q]
                if (self.ex_imps[r + IM_SHAPE] == IMPULSE_BOX and self.ex_imps[r + IM_MODE] != IMPULSE_ADD
                        and w > 0.0 and self.grid_m[I] > 0.0):
                    dv = self.set_velocity(q, w)
                    for d in ti.static(range(3)):
                        lat = True
                        for e in ti.static(range(3)):
                            if e != d:
                                lat = lat and X[e] >= c[e] and X[e] <= b[e]
                        sl = (c[d] - X[d]) * self.inv_dx[None]
                        sh = (X[d] - b[d]) * self.inv_dx[None]
                        if lat and sl > 0.0 and sl < SET_FACE_CELLS and I[d] >= 1:
                            J = I
                            J[d] -= 1
                            if self.grid_m[J] > 0.0:
                                self.grid_v[I] = self.constrain(q, self.grid_v[I],
                                                                (dv + sl * self.grid_v[J]) / (1.0 + sl))
                        if lat and sh > 0.0 and sh < SET_FACE_CELLS and I[d] < self.n_grid - 1:
                            J = I
                            J[d] += 1
                            if self.grid_m[J] > 0.0:
                                self.grid_v[I] = self.constrain(q, self.grid_v[I],
                                                                (dv + sh * self.grid_v[J]) / (1.0 + sh))

    @ti.func
    def set_box_axis(self, X):
        """For a point at ``X`` in a set box acting now (:meth:`set_box_at`): the normal axis of the box's nearest face
        if within :data:`~gasp_core.mpm.points.HELD_STRAIN_CELLS` cells of it (the point takes its image
        gradient, as a held point near its region's face: :meth:`gasp_taichi_mpm.grid.GridUpdate.held_axis`), else
        -1."""
        a = -1
        q = self.set_box_at(X)
        if q >= 0:
            c, b = self.impulse_corners(q)
            s = ti.min(X - c, b - X)
            near = HELD_STRAIN_CELLS * self.dx[None]
            for d in ti.static(range(3)):
                if s[d] < near:
                    a, near = d, s[d]
        return a

    @ti.func
    def apply_impulses(self, X, v, base):
        """Impulses (box or sphere regions, weight from the time table row at ``base``) on ``v`` at ``X``: ``add``
        adds ``w dv``, ``set`` imposes :meth:`set_velocity` (its ramp factor times ``dv``)."""
        for q in range(self.n_imp):
            r = q * IMPULSE_ROW
            inside = False
            c, b = self.impulse_corners(q)
            if self.ex_imps[r + IM_SHAPE] == IMPULSE_BOX:
                inside = (X >= c).all() and (X <= b).all()
            else:
                inside = (X - c).norm() <= b[0]
            w = self.ex_tab[base + FT_POSES + COL_POSE * self.n_col + q]
            if inside and w > 0.0:
                dv = ti.Vector([self.ex_imps[r + IM_DV], self.ex_imps[r + IM_DV + 1], self.ex_imps[r + IM_DV + 2]])
                if self.ex_imps[r + IM_MODE] == IMPULSE_ADD:
                    v += w * dv
                else:
                    v = self.constrain(q, v, self.set_velocity(q, w))
        return v
