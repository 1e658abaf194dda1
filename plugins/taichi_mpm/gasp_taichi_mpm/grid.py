"""The grid update (docs/mpm.md step 3) as a Taichi kernel, and the boundaries as node-index ranges; mixed into
:class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields and flags (``real``, ``atomic``, ...) it reads."""
import math

import numpy as np
import taichi as ti

from gasp_core.mpm.grid_tables import FT_TIME
from gasp_core.mpm.contact import ground_node_layer, wall_floor, wall_grid_cells
from gasp_core.mpm.materials import BRITTLE, P_LAM, P_MU, P_SF
from gasp_core.mpm.points import CUT_REACH, HELD_STRAINED, MIRROR_CELLS, cuts_held_faces

from .touch import GroundTouch

_TIE = 1e-9  # cells: tolerance for ties when boundary tests become node-index ranges


def node_ranges(setup, dx: float, contact: str = "particle"):
    """Boundaries as node-index tests (float64, ties within 1e-9 cells are exact ties).

    Returns
    -------
    walls : list of (friction, lo_first (3 ints), hi_first (3 ints))
        Wall nodes along axis d are ``I_d < lo_first[d]`` (normal +e_d) and ``I_d >= hi_first[d]`` (normal -e_d):
        within 3 cells of the faces, 1.5 with ``"particle"`` (``gasp_core.mpm.contact.wall_grid_cells``).
    grounds : list of (friction, k_max, height)
        Ground nodes are ``I_z <= k_max`` (``gasp_core.mpm.contact.ground_node_layer`` of ``contact``: the top
        layer with ``"grid"``, two cells lower with ``"particle"``, whose points meet the plane at ``height``, m).
    regions : list of (ilo (3 ints), ihi (3 ints)): fixed nodes are ``ilo <= I <= ihi`` on every axis.
    """
    lo = setup.domain_lo
    hi = setup.domain_hi
    walls, grounds, regions = [], [], []
    for b in setup.boundaries:
        if b.kind == "walls":
            # X_d < lo_d + w dx  <=>  I_d < w ;  X_d > hi_d - w dx  <=>  I_d > (hi_d - lo_d)/dx - w  (w = 3, 1.5 with
            # the particle contact: gasp_core.mpm.contact.wall_grid_cells)
            w = wall_grid_cells(contact)
            r = (hi - lo) / dx - w
            hi_first = tuple(int(math.floor(r[d] + _TIE)) + 1 for d in range(3))
            first = int(math.ceil(w - _TIE))   # no floor nodes where a ground is the floor (wall_floor)
            walls.append((float(b.friction), (first, first, first if wall_floor(setup, contact) else 0), hi_first))
        elif b.kind == "ground":
            grounds.append((float(b.friction), ground_node_layer(contact, b.height, lo[2], dx), float(b.height)))
        elif b.kind == "fixed_region":
            a = (np.asarray(b.lo, float) - lo) / dx
            c = (np.asarray(b.hi, float) - lo) / dx
            regions.append((tuple(int(math.ceil(a[d] - _TIE)) for d in range(3)),
                            tuple(int(math.floor(c[d] + _TIE)) for d in range(3)),
                            tuple(float(q) for q in b.lo), tuple(float(q) for q in b.hi)))
    return walls, grounds, regions


class GridUpdate(GroundTouch):
    """The grid update (:meth:`grid_update`) and the node extras it applies (:meth:`extras`)."""

    #: The brittle held rule (issue 66 round 32, docs/fracture.md "The held region"): a set box's brittle point's
    #: stress at its held damage, its gradient its mirror image's, the free node half a cell outside its face held
    #: with it; its points move with the grid, as any body's. False: the rule before (the catch of
    #: ``tests/test_tension_family.py``; warp_mpm's switch ``WarpMPMEngine.held_rule``).
    held_rule = True

    @ti.func
    def extras(self, I, v, m, gsurf, f):
        """Forces, impulses, then colliders at node ``I`` (docs/colliders.md; warp_mpm's order), at the node's position
        and the substep's time-table row; ``f``: the node's flowing-mass fraction (:meth:`Contact.rule`)."""
        dt = self.dt[None]
        X = self.lo[None] + self.dx[None] * ti.Vector([ti.cast(I[0], self.real), ti.cast(I[1], self.real),
                                                       ti.cast(I[2], self.real)])
        base = self.ex_step[None] * self.ex_width
        t = self.ex_tab[base + FT_TIME]
        v = self.apply_forces(X, v, m, gsurf, t, dt)
        v = self.apply_impulses(X, v, base)
        return self.apply_colliders(X, v, base, f)

    @ti.func
    def axis_friction(self, v, d: ti.template(), sign: ti.template(), mu_b):
        """:meth:`collide` with the axis normal ``sign * e_d`` (walls and grounds)."""
        n = ti.Vector.zero(self.real, 3)
        n[d] = sign
        return self.collide(v, n, mu_b)

    @ti.func
    def boundary_rules(self, I, v, f):
        """The walls' and grounds' grid rule at node ``I`` on ``v`` (:func:`node_ranges`; with the contact chosen per
        body by the node's flowing-mass fraction ``f`` where only the grid contact's rule reaches,
        :meth:`Contact.rule`). The grounds first: a ground on a wall's plane keeps its friction there."""
        for b in ti.static(range(self.n_grounds)):
            # I_z <= ground_kmax, or the touched layer above (touch.py); round 49: not where it shares the bound
            if self.ground_reach(b, I) and not self.shares(b, I):
                v = self.rule(v, self.axis_friction(v, 2, 1.0, self.ground_mu(b, I)), I[2] > self.ground_kfull[b], f)
            v = self.dashpot(b, I, v)   # round 48: the dashpot above the held layers (touch.py)
        for b in ti.static(range(self.n_walls)):
            mu_b = self.wall_fric[b]
            hi_first = self.wall_hi_first[b]
            for d in ti.static(range(3)):
                if I[d] < self.wall_lo_first[b][d]:
                    v = self.rule(v, self.axis_friction(v, d, 1.0, mu_b), I[d] >= self.wall_lo_full[b][d], f)
                if I[d] >= hi_first[d]:
                    v = self.rule(v, self.axis_friction(v, d, -1.0, mu_b), I[d] < self.wall_hi_full[b][d], f)
        return v

    @ti.func
    def touched_box(self):
        """The nodes P2G touched (the union of the chunks' boxes; the whole grid with atomic P2G)."""
        ng = self.n_grid
        lo = ti.Vector([0, 0, 0])
        hi = ti.Vector([ng - 1, ng - 1, ng - 1])
        if ti.static(not self.atomic):
            lo = ti.Vector([ng, ng, ng])
            hi = ti.Vector([-1, -1, -1])
            for t in ti.static(range(self.n_chunks)):
                lo = ti.min(lo, self.box[t, 0])
                hi = ti.max(hi, self.box[t, 1])
        return lo, ti.max(hi - lo + 1, 0)

    def grid_update(self):
        """The grid update (:meth:`grid_nodes`; the grounds' touched columns were marked after P2G, ``touch.py``), the
        balance's fix (``balance.py``), then the holds on what it left (:meth:`hold_nodes`; round 56, as warp_mpm)."""
        self.grid_nodes()
        self.touch_after()   # round 49 (touch.py)
        self.fix_contact()   # none without a balance
        self.hold_nodes()

    def hold_nodes(self):
        """The holds: broken faces (:meth:`mark_cut`), a brittle set box's faces, the ghosts (:meth:`mirror_held`)."""
        if self.n_regions or self.n_set_boxes:
            if self.cut:
                self.grid_cut.fill(0)
                self.mark_cut()
            if self.n_set_boxes and BRITTLE in self.kinds and self.held_rule:   # a brittle body's set box
                self.hold_set_faces()
            self.mirror_held()

    def allocate_cut(self) -> None:
        """``cut`` (a brittle body beside a ``fixed_region``) and ``grid_cut`` (i8, ``(2, n_grid, n_grid, n_grid)``;
        else one node): the nodes :meth:`mark_cut` marks."""
        ng = self.n_grid
        self.cut = self.any_fixed and cuts_held_faces(self.kinds, self.n_regions)
        self.grid_cut = ti.field(ti.i8, shape=(2, ng, ng, ng) if self.cut else (2, 1, 1, 1))

    @ti.kernel
    def mark_cut(self):
        """The fixed regions' broken faces (docs/fracture.md, "The held region";
        :func:`~gasp_core.mpm.points.cuts_held_faces`): the 27 nodes of the stencil of a strained held point broken
        through (``Jp >= 1``: its own stress, its mirror image's, passed the full softening's) in ``grid_cut[0]``, of a
        free point not broken through within :data:`~gasp_core.mpm.points.CUT_REACH` cells of a region in
        ``grid_cut[1]`` (both cleared first); :meth:`mirror_node` makes a region's node marked in the first a free-slip
        face where the face's last node (the node inside the box next to the first one past it, on the node's line along
        the face's normal) is not marked in the second: the crack's band beside the face is broken through across its
        width."""
        for p in range(self.n_points[None]):
            X = self.x[p]
            c = -1
            if self.kind[self.body[p]] == BRITTLE:
                if self.fixed[p] >= HELD_STRAINED and self.Jp[p] >= 1.0:
                    c = 0
                elif self.fixed[p] == 0 and self.Jp[p] < 1.0:
                    r = CUT_REACH * self.dx[None]
                    for b in ti.static(range(self.n_regions)):
                        if (X >= self.reg_box[b, 0] - r).all() and (X <= self.reg_box[b, 1] + r).all():
                            c = 1
            if c >= 0:
                base, fx, ok = self.base_fx(X)
                if ok:
                    for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                        self.grid_cut[c, base[0] + i, base[1] + j, base[2] + k] = 1

    @ti.func
    def mirror_node(self, I, blo, bhi, v_set, empty: ti.template(), cut):
        """The velocity of node ``I`` inside the held box ``[blo, bhi]`` (m) that holds its material at ``v_set``
        (docs/fracture.md, "The held region"): within :data:`~gasp_core.mpm.points.MIRROR_CELLS` cells of the
        box's nearest face, ``2 v_set - v(X')``, ``X'`` its mirror image across that face (``v`` linear along the
        face's normal between the two nodes around ``X'``; where one of them is ``I`` itself, solved for it), so the
        grid field meets ``v_set`` on the face and a uniform strain crosses it; deeper, ``v_set``. ``empty``: a
        mirror node without mass (no material past the face) leaves ``v_set`` (the set boxes; a fixed region's is 0
        anyway). An image past the grid's edge is read at the edge. ``cut`` (a fixed region's node that
        :meth:`mark_cut` marked, with the face's last node on its line read by no intact free point: the material
        beside the face is broken through, so the face is free of traction): the velocity of the first node past the
        face along its normal, less its normal part into the box (a free-slip face the material cannot enter)."""
        dx = self.dx[None]
        X = self.lo[None] + dx * ti.Vector([ti.cast(I[0], self.real), ti.cast(I[1], self.real),
                                            ti.cast(I[2], self.real)])
        s = ti.cast(1e30, self.real)
        ax, side = 0, 1
        for d in ti.static(range(3)):
            if X[d] - blo[d] < s:
                s, ax, side = X[d] - blo[d], d, -1
            if bhi[d] - X[d] < s:
                s, ax, side = bhi[d] - X[d], d, 1
        v = v_set
        if s < MIRROR_CELLS * dx:
            q = (X[ax] + 2.0 * ti.cast(side, self.real) * s - self.lo[None][ax]) / dx
            a = ti.min(ti.max(ti.cast(ti.floor(q), ti.i32), 0), self.n_grid - 2)
            t = q - ti.cast(a, self.real)
            Ia, Ib = I, I
            Ia[ax] = a
            Ib[ax] = a + 1
            va = self.image_share(v_set, Ia, I, empty)   # each image node by its share of I's material
            vb = self.image_share(v_set, Ib, I, empty)
            if a == I[ax]:       # the lower node is I itself (an upper face under dx/2 away)
                v = (2.0 * v_set - t * vb) / (2.0 - t)
            elif a + 1 == I[ax]:   # the upper node is I itself (a lower face)
                v = (2.0 * v_set - (1.0 - t) * va) / (1.0 + t)
            else:
                v = 2.0 * v_set - (1.0 - t) * va - t * vb
            if ti.static(empty):
                if self.grid_m[Ia] <= 0.0 or self.grid_m[Ib] <= 0.0:
                    v = v_set
            if cut != 0:
                Io = I
                Io[ax] = ti.min(ti.max(I[ax] + side * (ti.cast(ti.floor(s / dx + 1e-6), ti.i32) + 1), 0),
                                self.n_grid - 1)
                Iface = Io
                Iface[ax] = ti.min(ti.max(Io[ax] - side, 0), self.n_grid - 1)
                if ti.static(self.cut):   # and no free point short of broken through reads the face's last node
                    if self.grid_cut[1, Iface[0], Iface[1], Iface[2]] == 0:
                        v = self.grid_v[Io]
                        if (v[ax] - v_set[ax]) * ti.cast(side, self.real) < 0.0:
                            v[ax] = v_set[ax]
        return v

    @ti.func
    def held_axis(self, p):
        """The normal axis of the held box's face point ``p`` takes its image gradient across (:meth:`image_gradient`):
        a held point near its region's face (``fixed = HELD_STRAINED + a``), or near a set box's face acting now; -1."""
        a = -1
        if ti.static(self.any_fixed):
            if self.fixed[p] >= HELD_STRAINED:
                a = ti.cast(self.fixed[p], ti.i32) - HELD_STRAINED
        if ti.static(self.n_set_boxes > 0):
            if self.fixed[p] == 0:
                a = self.set_box_axis(self.x[p])
        return a

    @ti.func
    def image_C(self, p, a, C):
        """The velocity gradient point ``p`` near a held box's face (normal axis ``a`` from :meth:`held_axis`) takes:
        the grid's gradient gathered at its mirror image ``X'`` across that face, as the ghost field's (``grad v(X')
        D``, :meth:`image_gradient`), so its ``F`` follows the image's strain for any field, not the ghost nodes'
        reflection of a field linear along the normal (``C`` where no box holds it, or where a node of the image's
        stencil has no mass)."""
        X, best, qs, vs = self.x[p], ti.cast(1e30, self.real), -1, ti.Vector.zero(self.real, 3)   # qs: the set box
        f = X[a]
        if ti.static(self.any_fixed):
            if self.fixed[p] >= HELD_STRAINED:
                for b in ti.static(range(self.n_regions)):
                    lo_, hi_ = self.reg_box[b, 0], self.reg_box[b, 1]
                    if (X >= lo_).all() and (X <= hi_).all():
                        if X[a] - lo_[a] < best:
                            best, f = X[a] - lo_[a], lo_[a]
                        if hi_[a] - X[a] < best:
                            best, f = hi_[a] - X[a], hi_[a]
        if ti.static(self.n_set_boxes > 0):
            if self.fixed[p] == 0:
                q = self.set_box_at(X)
                if q >= 0:
                    c, b = self.impulse_corners(q)
                    vs = self.set_velocity(q, self.impulse_weight(q))
                    if X[a] - c[a] < best:
                        best, f, qs = X[a] - c[a], c[a], q
                    if b[a] - X[a] < best:
                        best, f, qs = b[a] - X[a], b[a], q
        out = C
        if best < 1e29:
            Xi = X
            Xi[a] = 2.0 * f - X[a]
            base, fx, ok = self.base_fx(Xi)
            if ok:
                w = self.weights(fx)
                v = ti.Vector.zero(self.real, 3)
                B = ti.Matrix.zero(self.real, 3, 3)
                full = True   # the image's stencil all in material (else the ghosts' C: no image to follow)
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    gv = w[i][0] * w[j][1] * w[k][2] * self.image_node_v(p, base + ti.Vector([i, j, k]), a, f, qs, vs)
                    v += gv
                    B += gv.outer_product(ti.Vector([float(i), float(j), float(k)], self.real))
                    full = full and self.grid_m[base + ti.Vector([i, j, k])] > 0.0
                if full:
                    out = self.image_gradient((4.0 * self.inv_dx[None]) * (B - v.outer_product(fx)), a)
        return self.along_flip(p, a, C, out)   # a set box's constrain = "along": the image's rows along its pull only

    @ti.func
    def image_gradient(self, C, a):
        """``C D``, ``D`` the diagonal matrix that negates every column but ``a`` (``a`` -1: ``C``): for a point
        near a held box's face (normal axis ``a``, :data:`~gasp_core.mpm.points.HELD_STRAINED`) the ghost field's
        gradient ``C`` as the gradient at its mirror image (P2G advances its ``F`` by it), and its stress ``tau D``
        (the force that update pairs with)."""
        out = C
        for j in ti.static(range(3)):
            if j != a and a >= 0:
                for i in ti.static(range(3)):
                    out[i, j] = -C[i, j]
        return out

    @ti.func
    def held_stress(self, p, tau, a, d_held):
        """The stress point ``p`` scatters under the held boxes' rule (``a`` from :meth:`held_axis`): ``tau D`` near a
        face; a brittle point in a held box keeps its damage ``d_held`` (its stress is its mirror image's: the
        material a box holds does not break); under ``held_rule`` a set box's point scatters the stress of ``d_held``
        (not softened on the way; a fixed region's held points keep their strain's: with both there a T rod hung by
        its head diverged, ``tests/test_brittle.py``)."""
        out = self.along_flip(p, a, tau, self.image_gradient(tau, a))
        if a >= 0:
            kind = self.kind[self.body[p]]
            if ti.static(not self.multi_kind):
                kind = ti.static(next(iter(self.kinds)))
            if kind == BRITTLE and self.Jp[p] < 1.0:   # broken through (its image's crack): stays so
                self.Jp[p] = d_held
                if ti.static(self.held_rule):   # a set box's point (held_rule): its stress at its held damage
                    if self.fixed[p] == 0:
                        prm = self.mat[self.body[p]]
                        U, sig, V = self.svd(self.F[p])
                        tau0, _d = self.brittle_tau(U, ti.log(ti.max(sig, 1e-4)), prm[P_MU], prm[P_LAM], prm[P_SF],
                                                    prm[P_SF], d_held)
                        out = self.along_flip(p, a, tau0, self.image_gradient(tau0, a))
        return out

    @ti.kernel
    def mirror_held(self):
        """The ghost nodes of the held boxes (:meth:`mirror_node`): each box impulse of ``mode = "set"`` while it acts
        (held at its velocity), then each ``fixed_region`` (held at 0), over the touched nodes. A ghost node reads
        only nodes outside its own box."""
        lo, ext = self.touched_box()
        count = ext[0] * ext[1] * ext[2]
        for idx in range(count):
            I = lo + ti.Vector([idx // (ext[1] * ext[2]), (idx // ext[2]) % ext[1], idx % ext[2]])
            if ti.static(self.n_set_boxes > 0):
                self.mirror_set_boxes(I)
            cut = 0
            if ti.static(self.cut):   # the held points beside broken through (mark_cut)
                cut = ti.cast(self.grid_cut[0, I[0], I[1], I[2]], ti.i32)
            for b in ti.static(range(self.n_regions)):
                if (I >= self.reg_lo[b]).all() and (I <= self.reg_hi[b]).all():
                    self.grid_v[I] = self.mirror_node(I, self.reg_box[b, 0], self.reg_box[b, 1],
                                                      ti.Vector.zero(self.real, 3), False, cut)

    @ti.kernel
    def grid_nodes(self):
        """Sum the copies over the touched box, clear them, velocity + gravity + boundaries -> grid_v."""
        ng = self.n_grid
        lo, ext = self.touched_box()
        if ti.static(not self.atomic):
            for i in range(ng):   # the chunks whose box reaches node plane I_x = i: first and last
                first, last = self.n_chunks, -1
                for t in ti.static(range(self.n_chunks)):
                    if self.box[t, 0][0] <= i and i <= self.box[t, 1][0]:
                        first = ti.min(first, t)
                        last = t
                self.plane_chunks[i] = ti.Vector([first, last])
        count = ext[0] * ext[1] * ext[2]
        for idx in range(count):
            I = lo + ti.Vector([idx // (ext[1] * ext[2]), (idx // ext[2]) % ext[1], idx % ext[2]])
            self.keep_row(I)   # the contact's balance: a marked node's key to its row (balance.py)
            acc = ti.Vector.zero(self.real, self.acc_width)
            gsurf = ti.Vector.zero(self.real, 3)
            if ti.static(self.atomic):
                acc = self.grid_mv[0, I]
                self.grid_mv[0, I] = ti.Vector.zero(self.real, self.acc_width)
                if ti.static(self.has_wind):
                    gsurf = self.grid_g[0, I]
                    self.grid_g[0, I] = ti.Vector.zero(self.real, 3)
            else:
                # copy t is zero outside its chunk's box: read and clear, in chunk order, only the copies that hold I
                span = self.plane_chunks[I[0]]
                for t in range(span[0], span[1] + 1):
                    if (I >= self.box[t, 0]).all() and (I <= self.box[t, 1]).all():
                        acc += self.grid_mv[t, I]
                        self.grid_mv[t, I] = ti.Vector.zero(self.real, self.acc_width)
                        if ti.static(self.has_wind):
                            gsurf += self.grid_g[t, I]
                            self.grid_g[t, I] = ti.Vector.zero(self.real, 3)
            v = ti.Vector.zero(self.real, 3)
            f = ti.cast(0.0, self.real)   # the flowing-mass fraction (the contact chosen per body; contact.py)
            if ti.static(self.mixed):
                f = self.grid_mf[I] / ti.max(acc[3], 1e-30)
                self.grid_mf[I] = 0.0
            fr = f   # the friction's fraction: rounds 81-82, A's mass fraction signed by its side (field_ground.py)
            if ti.static(self.rigid_a):
                fr = self.grid_mf[I] / ti.max(acc[3], 1e-30)
                self.grid_mf[I] = 0.0
            if acc[3] > 0.0:
                v = ti.Vector([acc[0], acc[1], acc[2]]) / acc[3] + self.dt[None] * self.gravity[None]
                if ti.static(self.has_extras):
                    v = self.extras(I, v, acc[3], gsurf, f)
                self.touch_keep(I, v, acc[3])   # round 49 (touch.py)
                v = self.boundary_rules(I, v, f)
                if ti.static(self.pc):   # the particle contact's friction and balance (its budget: the last channel)
                    v = self.pc_friction(I, v, acc[3], acc[self.acc_width - 1], fr)   # fields.py
                for b in ti.static(range(self.n_regions)):
                    if (I >= self.reg_lo[b]).all() and (I <= self.reg_hi[b]).all():
                        v = ti.Vector.zero(self.real, 3)
            self.grid_v[I] = v
            if ti.static(self.flip > 0):
                v0 = ti.Vector.zero(self.real, 3)
                if acc[3] > 0.0:
                    v0 = ti.Vector([acc[4], acc[5], acc[6]]) / acc[3]
                self.grid_v0[I] = v0
            if ti.static(self.keep_mass):
                self.grid_m[I] = acc[3]
