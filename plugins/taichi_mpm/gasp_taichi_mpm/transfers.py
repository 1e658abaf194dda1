"""Transfers between points and grid (docs/mpm.md steps 2, 4 and 5): the stencil, P2G (fused with G2P within
a frame), G2P and the passive points' G2P, as Taichi functions and kernels.

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields and flags (``real``, ``atomic``, ...) it reads.
Sources: Hu et al. 2018 (MLS-MPM, APIC, quadratic B-splines), taichi's mpm128 (``F`` advanced in P2G).
"""
import taichi as ti

from gasp_core.mpm import grid_tables
from gasp_core.mpm.materials import BRITTLE, P_ETA

class Transfers:
    """The stencil of a point, P2G (atomic or into private grid copies; the schedules' own P2G passes are in
    :mod:`gasp_taichi_mpm.schedule.coloured` and :mod:`gasp_taichi_mpm.schedule.tiles`), G2P and the passive points' G2P."""

    #: With ``grid_tables.PASSIVE_SPANNED`` off (round 38's spanned gather, the rule, overrides these): the passive
    #: gather by the B-spline weight alone, renormalised over the nodes with mass (False), or weighted by the nodes'
    #: mass (True: measured in round 37 and not adopted, docs/fracture.md "Round 37"), its mean read at the weights'
    #: centroid or, with PASSIVE_AT_POINT, the weighted fit read at the point
    PASSIVE_BY_MASS = False
    PASSIVE_AT_POINT = True
    #: The spanned gather's inverse by ``M``'s plain inverse where Gershgorin's bound proves all three directions
    #: spanned (:meth:`spans_all`), the Jacobi only elsewhere (round 39: docs/performance.md); False: always the Jacobi
    PASSIVE_FAST_INVERSE = True

    @ti.func
    def base_fx(self, xp):
        X = (xp - self.lo[None]) * self.inv_dx[None]
        base = ti.cast(ti.floor(X - 0.5), ti.i32)
        ok = base.min() >= 0 and base.max() <= self.n_grid - 3
        fx = X - ti.cast(base, self.real)
        return base, fx, ok

    @ti.func
    def weights(self, fx):
        return [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]

    @ti.func
    def mv_value(self, mv, m, mv_apic, eta_v, budget):
        """What a point adds to a node of grid_mv per unit weight: momentum, mass (then the APIC momentum with flip;
        the viscous volume ``J V eta`` with a viscous material, :mod:`gasp_taichi_mpm.viscosity`; last, the particle
        contact's friction budget with its planes or colliders, ``pc``, :mod:`gasp_taichi_mpm.contact`)."""
        if ti.static(self.flip > 0 and self.viscous and self.pc):
            return ti.Vector([mv[0], mv[1], mv[2], m, mv_apic[0], mv_apic[1], mv_apic[2], eta_v, budget])
        elif ti.static(self.flip > 0 and self.viscous):
            return ti.Vector([mv[0], mv[1], mv[2], m, mv_apic[0], mv_apic[1], mv_apic[2], eta_v])
        elif ti.static(self.flip > 0 and self.pc):
            return ti.Vector([mv[0], mv[1], mv[2], m, mv_apic[0], mv_apic[1], mv_apic[2], budget])
        elif ti.static(self.flip > 0):
            return ti.Vector([mv[0], mv[1], mv[2], m, mv_apic[0], mv_apic[1], mv_apic[2]])
        elif ti.static(self.viscous and self.pc):
            return ti.Vector([mv[0], mv[1], mv[2], m, eta_v, budget])
        elif ti.static(self.viscous):
            return ti.Vector([mv[0], mv[1], mv[2], m, eta_v])
        elif ti.static(self.pc):
            return ti.Vector([mv[0], mv[1], mv[2], m, budget])
        else:
            return ti.Vector([mv[0], mv[1], mv[2], m])

    @ti.func
    def p2g_prep(self, p, base, fx):
        """Point p's stress update (``F``, the return mapping) and the scatters beside grid_mv's (the contact's, the
        flow's, the two fields'); returns ``mv0, A, S, m, jvec, eta_v, budget`` for :meth:`node_val`."""
        dt = self.dt[None]
        inv_dx = self.inv_dx[None]
        C = self.C[p]
        Cf = C
        a, d_held = -1, ti.cast(0.0, self.real)
        if ti.static(self.any_fixed or self.n_set_boxes > 0):   # in a held box: the image gradient (grid.py)
            a, d_held = self.held_axis(p), self.Jp[p]
            Cf = self.along_flip(p, a, C, self.image_gradient(C, a))   # "along": the mirror's rows along its pull
        if ti.static(self.trap_stress):   # round 69: F by the mean of the last two gradients (mid_stress.py)
            Cf = self.trap_gradient(p, a, C, Cf)
        F = (ti.Matrix.identity(self.real, 3) + dt * Cf) @ self.F[p]
        tau = self.return_mapping(p, F)
        if ti.static(self.any_fixed or self.n_set_boxes > 0):   # its stress scattered to match; no damage
            tau = self.held_stress(p, tau, a, d_held)
        if ti.static(self.mid_stress or self.trap_stress):   # round 68: the increment's midpoint stress, a free point (mid_stress.py)
            if a < 0:
                tau = self.mid_tau(p, C, F, tau)
        eta_v = ti.cast(0.0, self.real)
        if ti.static(self.viscous):   # Kelvin-Voigt, implicit on the grid: the point's J V eta (docs/dissipation.md)
            eta_v = self.mat[self.body[p]][P_ETA] * F.determinant() * self.p_vol[p]
        m = self.p_mass[p]
        mc = m   # the affine momentum's mass: none for a point of A at B (p_pic, gasp_core.mpm.fields.PIC_AT_B)
        if ti.static(self.pic_on):
            if self.p_pic[p] != 0:
                mc = ti.cast(0.0, self.real)
        dx = self.dx[None]
        affine = (-dt * self.p_vol[p] * 4.0 * inv_dx * inv_dx) * tau + mc * C
        A = affine * dx
        S = (affine - mc * C) * dx   # the stress part of A (AFLIP sums the momentum without it)
        mv0 = m * self.v[p] - A @ fx
        # the particle contact (zeros without it): not in AFLIP's APIC momentum (a boundary, as in warp_mpm)
        jvec, budget, fn, fv, sup = self.point_contact(p)
        mv0 += jvec
        w = self.weights(fx)
        self.mark_contact_nodes(base, w, jvec, sup)   # the contact's balance (balance.py)
        self.scatter_contact(base, w, budget, fn, fv)   # with colliders: the budget's normal, supports' velocity
        self.scatter_flow(p, base, w, m)   # with the contact chosen per body: the flowing bodies' mass
        self.scatter_field(p, base, w, mv0, A, m, S, fx, jvec)   # with the two-field contact: the point's field (fields.py)
        self.scatter_cells(p, base, w, mv0, A, m)   # Grady's cells: the point's field at each node (cells.py)
        return mv0, A, S, m, jvec, eta_v, budget

    @ti.func
    def node_val(self, i: ti.template(), j: ti.template(), k: ti.template(), fx, mv0, A, S, m, jvec, eta_v, budget):
        """What a point adds to stencil node (i, j, k) of grid_mv per unit weight (:meth:`mv_value`)."""
        mv = mv0
        if ti.static(i > 0):
            mv += ti.static(float(i)) * ti.Vector([A[0, 0], A[1, 0], A[2, 0]])
        if ti.static(j > 0):
            mv += ti.static(float(j)) * ti.Vector([A[0, 1], A[1, 1], A[2, 1]])
        if ti.static(k > 0):
            mv += ti.static(float(k)) * ti.Vector([A[0, 2], A[1, 2], A[2, 2]])
        return self.mv_value(mv, m, mv - S @ (ti.Vector([float(i), float(j), float(k)]) - fx) - jvec, eta_v, budget)

    @ti.func
    def p2g_point(self, p, t, bmin, bmax):
        """Scatter point p into grid copy t; returns the updated touched-node box."""
        base, fx, ok = self.base_fx(self.x[p])
        if not ok:
            ti.atomic_add(self.n_out[None], 1)
        else:
            mv0, A, S, m, jvec, eta_v, budget = self.p2g_prep(p, base, fx)
            w = self.weights(fx)
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                weight = w[i][0] * w[j][1] * w[k][2]
                val = weight * self.node_val(i, j, k, fx, mv0, A, S, m, jvec, eta_v, budget)
                node = base + ti.Vector([i, j, k])
                if ti.static(self.atomic and self.fixed_point):   # deterministic (schedule/fixed.py)
                    self.add_fixed(node, val)
                elif ti.static(self.atomic):
                    self.grid_mv[0, node] += val
                else:
                    self.grid_mv[t, node] = self.grid_mv[t, node] + val
                if ti.static(self.has_wind):
                    # p_vol grad N_ip: d N / d x_node per axis is (1.5 - fx, 2 (fx - 1), 0.5 - fx) inv_dx
                    dw = [1.5 - fx, 2.0 * (fx - 1.0), 0.5 - fx]
                    gv = (self.p_vol[p] * self.inv_dx[None]) * ti.Vector([dw[i][0] * w[j][1] * w[k][2],
                                                                          w[i][0] * dw[j][1] * w[k][2],
                                                                          w[i][0] * w[j][1] * dw[k][2]])
                    if ti.static(self.atomic):
                        self.grid_g[0, node] += gv
                    else:
                        self.grid_g[t, node] = self.grid_g[t, node] + gv
            bmin = ti.min(bmin, base)
            bmax = ti.max(bmax, base + 2)
        return bmin, bmax

    @ti.func
    def g2p_point(self, p):
        base, fx, ok = self.base_fx(self.x[p])
        if ok:
            w = self.weights(fx)
            new_v = ti.Vector.zero(self.real, 3)
            B = ti.Matrix.zero(self.real, 3, 3)
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                weight = w[i][0] * w[j][1] * w[k][2]
                gv = weight * self.node_v(p, base + ti.Vector([i, j, k]))   # two fields: its own (fields.py)
                new_v += gv
                if ti.static(i > 0):
                    B[0, 0] += ti.static(float(i)) * gv[0]
                    B[1, 0] += ti.static(float(i)) * gv[1]
                    B[2, 0] += ti.static(float(i)) * gv[2]
                if ti.static(j > 0):
                    B[0, 1] += ti.static(float(j)) * gv[0]
                    B[1, 1] += ti.static(float(j)) * gv[1]
                    B[2, 1] += ti.static(float(j)) * gv[2]
                if ti.static(k > 0):
                    B[0, 2] += ti.static(float(k)) * gv[0]
                    B[1, 2] += ti.static(float(k)) * gv[1]
                    B[2, 2] += ti.static(float(k)) * gv[2]
            new_C = (4.0 * self.inv_dx[None]) * (B - new_v.outer_product(fx))
            v_p = new_v
            if ti.static(self.flip > 0):   # AFLIP: v_PIC(new) + alpha (v_p - v_PIC(old))
                old_v = ti.Vector.zero(self.real, 3)
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    old_v += w[i][0] * w[j][1] * w[k][2] * self.node_v0(p, base + ti.Vector([i, j, k]))
                v_p = new_v + self.flip * (self.v[p] - old_v)
            if ti.static(self.any_fixed or self.n_set_boxes > 0):   # near a held box's face: its image's gradient
                if ti.static(self.held_rule):   # the brittle held rule (grid.py held_rule)
                    if self.kind[self.body[p]] == BRITTLE:
                        a = self.held_axis(p)
                        if a >= 0 and self.fixed[p] == 0:   # a set box's (not a fixed region's: as before)
                            new_C = self.image_C(p, a, new_C)
            if ti.static(self.any_fixed):
                if self.fixed[p] != 0:   # held; near its region's face its F follows the image gradient (p2g_prep)
                    new_v = ti.Vector.zero(self.real, 3)
                    v_p = new_v
                    if self.fixed[p] == 1:
                        new_C = ti.Matrix.zero(self.real, 3, 3)
            self.v[p] = v_p
            self.C[p] = new_C
            self.x[p] += self.dt[None] * new_v
            self.hold_point(p)   # the colliders' and rigid bodies' holds (colliders.py, rigid_hold.py)

    # ------------------------------------------------------------------ kernels
    @ti.kernel
    def g2p(self):
        """G2P alone (last substep of a frame)."""
        for p in range(self.n_points[None]):
            if self.asleep[self.body[p]] == 0:   # a sleeping body's points keep x, v, C (sleeping.py)
                self.g2p_point(p)

    @ti.kernel
    def g2p_p2g(self, with_g2p: ti.i32):
        """G2P of one substep (if ``with_g2p``) fused with the P2G of the next."""
        if ti.static(self.atomic):
            for p in range(self.n_points[None]):
                if self.asleep[self.body[p]] == 0:   # a sleeping body's points: no transfer (sleeping.py)
                    if with_g2p:
                        self.fused_g2p(p)   # a rigid body's points: done before (rigid.py)
                    self.p2g_point(p, 0, ti.Vector([0, 0, 0]), ti.Vector([0, 0, 0]))
        else:
            self.p2g_chunks(with_g2p)   # one thread a chunk (schedule/ordered.py)

    @ti.kernel
    def full_box(self):
        """The whole grid as the touched box (atomic P2G, which records none; the viscous solve reads it)."""
        self.box[0, 0] = ti.Vector([0, 0, 0])
        self.box[0, 1] = ti.Vector([self.n_grid - 1, self.n_grid - 1, self.n_grid - 1])

    def allocate_passive_span(self, p_mass, p_vol):
        """The spanned passive gather's cutoff (kg cells^2, ``grid_tables.passive_span_mass`` of the points' masses
        and volumes, shapes (n,)) in a scalar field."""
        self.span_mass = ti.field(self.real, shape=())
        self.span_mass[None] = grid_tables.passive_span_mass(p_mass, p_vol)
        grid_tables.passive_mean_at()   # a misspelt switch fails here, before the kernels read it

    @ti.func
    def spans_all(self, M, wsum):
        """Whether all three directions of the symmetric moment ``M`` (3x3, cells^2 per unit weight; ``wsum`` kg) are
        provably spanned, ``lam_min wsum > span_mass``, by Gershgorin's lower bound on its smallest eigenvalue,
        ``min_i (M_ii - sum_{j != i} |M_ij|)`` (Golub & Van Loan, "Matrix Computations", Thm. 7.2.1); round 39."""
        lb = M[0, 0] - ti.abs(M[0, 1]) - ti.abs(M[0, 2])
        lb = ti.min(lb, M[1, 1] - ti.abs(M[1, 0]) - ti.abs(M[1, 2]))
        lb = ti.min(lb, M[2, 2] - ti.abs(M[2, 0]) - ti.abs(M[2, 1]))
        return lb * wsum > self.span_mass[None]

    @ti.func
    def spanned_inverse(self, M, wsum):
        """The pseudo-inverse of the symmetric moment ``M`` (3x3, cells^2 per unit weight; ``wsum`` the weights' sum,
        kg) over the eigen-directions the material spans, ``lam wsum > span_mass`` (``grid_tables``'
        ``PASSIVE_SPAN_MOMENT``): ``sum_k V_k V_k^T / lam_k`` (cyclic Jacobi, :meth:`sym_eig`). The passive gather's
        gradient is fitted only there (round 38). With :attr:`PASSIVE_FAST_INVERSE` (round 39), where
        :meth:`spans_all` proves all three spanned, ``M``'s plain inverse (the same ``M^+``, without the Jacobi)."""
        Minv = ti.Matrix.zero(self.real, 3, 3)
        full = False
        if ti.static(self.PASSIVE_FAST_INVERSE):
            full = self.spans_all(M, wsum)
        if full:
            Minv = M.inverse()
        else:
            V, lam = self.sym_eig(M)
            for k in ti.static(range(3)):
                if lam[k] * wsum > self.span_mass[None]:
                    e = ti.Vector([V[0, k], V[1, k], V[2, k]])
                    Minv += e.outer_product(e) / lam[k]
        return Minv

    @ti.func
    def passive_mean(self, v_bar, rbar, v_m, r_m, G, P_s):
        """The spanned gather's velocity at the point (m/s; ``grid_tables.PASSIVE_MEAN_AT``, round 39): ``v_bar`` at
        ``rbar`` (the ``N m`` weights' mean and centroid, cells from the point), ``v_m`` at ``r_m`` (the nodes' by mass
        alone), ``G`` the spanned gradient (1/s), ``P_s = M^+ M`` the projector on the spanned directions."""
        dx = self.dx[None]
        v = v_bar - G @ (rbar * dx)
        if ti.static(grid_tables.PASSIVE_MEAN_AT == "material"):
            v = v_m - G @ (r_m * dx)
        if ti.static(grid_tables.PASSIVE_MEAN_AT == "unspanned"):
            d = r_m - rbar
            du = d - P_s @ d
            f = du.dot(du) / ti.max(d.dot(d), 1e-30)
            v += f * (v_m - v_bar - G @ (d * dx))
        return v

    @ti.func
    def g2p_passive_point(self, p, pair):
        """A passive point: velocity ``v`` and affine velocity gradient ``C`` from the grid (no F, no P2G).
        It is long because the gather over the nodes, the fit and the affine advance are one pass per point.

        Only nodes that received mass count, with the weights renormalised over them: a surface point
        half a spacing outside the material sees empty nodes (velocity 0, not the material's) in its
        stencil, which would hold it back. With ``grid_tables.PASSIVE_SPANNED`` (the rule, round 38) each node counts
        by its weight times its mass: the mean at the weights' centroid (``PASSIVE_MEAN_AT``, round 39: moved towards
        the material's centroid along the unspanned directions, :meth:`passive_mean`) plus the weighted least-squares
        gradient along the directions the material spans (:meth:`spanned_inverse`), read at the point, ``C`` that
        gradient; off, by the weight alone, ``C`` the weighted fit (:attr:`PASSIVE_BY_MASS`: round 37's variants).
        The point then advances over the ``m = passive_substeps[pair]`` substeps since its last gather through the
        affine field
        ``v(y, k) = v_prev + (k/m)(v_new - v_prev) + (C_prev + (k/m)(C_new - C_prev)) y``,
        ``y += dt v(y, k)`` for ``k = 1..m`` (:func:`gasp_core.mpm.substeps.passive_schedule`), so it turns with
        the material; ``m = 1`` is plain G2P. A point with no node of mass in its stencil (stranded: the material
        flowed away, issue 55's specks in the air) falls freely, ``v_new = v_prev + m dt g``, until the material or
        the boundaries' box takes it again (on the floor, slowed by its friction)."""
        base, fx, ok = self.base_fx(self.x[p])
        # out of the grid (not ok): it drops out where it is, uncounted here (n_out is the material points' count,
        # the blow-up verdict's; gasp_core.mpm.points.blow_up_rows), counted by the core (run.json left_domain)
        if ok:
            w = self.weights(fx)
            new_v = ti.Vector.zero(self.real, 3)
            wsum = ti.cast(0.0, self.real)
            rbar = ti.Vector.zero(self.real, 3)
            Svr = ti.Matrix.zero(self.real, 3, 3)
            Srr = ti.Matrix.zero(self.real, 3, 3)
            msum = ti.cast(0.0, self.real)   # the nodes by their mass alone: the material's centroid (round 39)
            mv = ti.Vector.zero(self.real, 3)
            mr = ti.Vector.zero(self.real, 3)
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                node = base + ti.Vector([i, j, k])
                if self.grid_m[node] > 0.0:
                    wn = w[i][0] * w[j][1] * w[k][2]
                    if ti.static(self.PASSIVE_BY_MASS or grid_tables.PASSIVE_SPANNED):
                        wn *= self.grid_m[node]   # the node's say: its share of the material at the point
                    r = ti.Vector([ti.static(float(i)), ti.static(float(j)), ti.static(float(k))], self.real) - fx
                    gv = self.node_v(p, node)   # its body's field (fields.py): a passive sand point slides too
                    new_v += wn * gv
                    wsum += wn
                    rbar += wn * r
                    Svr += wn * gv.outer_product(r)
                    Srr += wn * r.outer_product(r)
                    if ti.static(grid_tables.PASSIVE_SPANNED and grid_tables.PASSIVE_MEAN_AT != "weights"):
                        msum += self.grid_m[node]
                        mv += self.grid_m[node] * gv
                        mr += self.grid_m[node] * r
            new_C = ti.Matrix.zero(self.real, 3, 3)
            if wsum > 0.0:
                new_v /= wsum
                rbar /= wsum
                # moments per unit weight (unscaled: a crack's lone far corner underflowed f32); ridge for planar nodes
                Svr = Svr / wsum - new_v.outer_product(rbar)
                if ti.static(grid_tables.PASSIVE_SPANNED):   # the gradient along the spanned directions, at the point
                    M = Srr / wsum - rbar.outer_product(rbar)
                    Minv = self.spanned_inverse(M, wsum)
                    new_C = self.inv_dx[None] * (Svr @ Minv)
                    msum = ti.max(msum, 1e-30)   # (0 only where PASSIVE_MEAN_AT is "weights": unread)
                    new_v = self.passive_mean(new_v, rbar, mv / msum, mr / msum, new_C, Minv @ M)
                else:
                    Srr = Srr / wsum + ti.Matrix.identity(self.real, 3) * 2.5e-5 - rbar.outer_product(rbar)
                    new_C = self.inv_dx[None] * (Svr @ Srr.inverse())
                    if ti.static(self.PASSIVE_BY_MASS and self.PASSIVE_AT_POINT):   # the fit read at the point
                        new_v -= new_C @ (rbar * self.dx[None])
            else:   # stranded, no material in its stencil: it falls freely until material or a boundary takes it
                new_v = self.v[p] + ti.cast(self.passive_substeps[pair], self.real) * self.dt[None] * self.gravity[None]
            v_prev = self.v[p]
            C_prev = self.C[p]
            if ti.static(self.any_fixed):
                if self.fixed[p] != 0:
                    new_v = ti.Vector.zero(self.real, 3)
                    new_C = ti.Matrix.zero(self.real, 3, 3)
                    v_prev = new_v
                    C_prev = new_C
            m = self.passive_substeps[pair]
            dt = self.dt[None]
            y = ti.Vector.zero(self.real, 3)
            for kk in range(m):
                t = ti.cast(kk + 1, self.real) / ti.cast(m, self.real)
                y += dt * (v_prev + t * (new_v - v_prev) + (C_prev + t * (new_C - C_prev)) @ y)
            # then held in the box the boundaries leave it (gasp_core.mpm.points.passive_bounds)
            self.x[p], self.v[p] = self.hold_passive(self.x[p] + y, new_v + new_C @ y, wsum <= 0.0)
            self.C[p] = new_C

    @ti.func
    def _passive_box(self):
        """The passive points' node box (the nodes they will read, for the next grid update on the CPU schedule's
        private box), into every chunk's row of ``pbox``: one thread a point, the bounds by integer atomic min and max
        (the same in any order, so the same bits as a serial walk)."""
        for t in range(self.n_chunks):
            self.pbox[t, 0] = ti.Vector([self.n_grid, self.n_grid, self.n_grid])
            self.pbox[t, 1] = ti.Vector([-1, -1, -1])
        for p in range(self.n_points[None], self.n_total[None]):
            base, _fx, ok = self.base_fx(self.x[p])
            if ok:   # an atomic only where it may move a bound (they only widen): no contended writes (round 39)
                for t in range(self.n_chunks):
                    for d in ti.static(range(3)):
                        if base[d] < self.pbox[t, 0][d]:
                            ti.atomic_min(self.pbox[t, 0][d], base[d])
                        if base[d] + 2 > self.pbox[t, 1][d]:
                            ti.atomic_max(self.pbox[t, 1][d], base[d] + 2)

    @ti.kernel
    def g2p_passive(self, pair: ti.i32):
        """G2P of the passive points with weight pair ``pair``, one thread a point on either device (each point reads
        the grid and writes only its own row), then, without atomics (the CPU schedule), their node box
        (:meth:`_passive_box`)."""
        for p in range(self.n_points[None], self.n_total[None]):
            self.g2p_passive_point(p, pair)
        if ti.static(not self.atomic):
            self._passive_box()

    @ti.kernel
    def passive_box(self):
        """The passive points' node box, at the start."""
        self._passive_box()
