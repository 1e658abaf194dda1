"""Implicit Kelvin-Voigt viscosity on the grid (``docs/dissipation.md``, "Time step"; ``docs/mpm.md`` step 3a).

After P2G the grid holds each node's momentum ``m v*`` (elastic stress included), mass ``m`` and viscous
volume ``(eta V)_i = sum_p w_ip J_p V_p eta_p`` (Pa s m^3). The viscous stress ``2 eta D`` is linear in the
velocity, so one backward-Euler step of it is the linear system

    (M + dt K) v = M v*,      (K v)_i = sum_c (eta V)_c (G_c + G_c^T) g_ic,

over the nodes with mass, where ``c`` runs over the grid cells whose 8 corner nodes all have mass and one body label
(round 50: no viscous bridge between two bodies across empty cells; :attr:`ImplicitViscosity.same_label`),
``G_c = sum_i v_i g_ic^T`` is the cell's velocity gradient (trilinear shape functions at the cell centre,
``g_ic = (+-1, +-1, +-1) / (4 dx)``) and ``(eta V)_c = sum_corners (eta V)_i / n_i`` shares each node's viscous
volume among its ``n_i`` valid cells (their sum is the body's ``sum_p J_p V_p eta_p``). ``K`` is the Hessian of
the Rayleigh dissipation ``sum_c (eta V)_c D_c : D_c``: symmetric, positive semi-definite, zero on rigid
motions, so the step conserves linear and angular momentum and is stable at any ``dt``. It is solved by
conjugate gradients with the diagonal as preconditioner, starting from ``v*``, until the preconditioned
residual falls below :data:`TOL` of its start (at most :data:`MAX_ITERS` iterations). The nodes with mass and the
valid cells are listed in node order by a flag, scan and scatter over the box
(:class:`gasp_taichi_mpm.schedule.primitives.BoxCompaction`: every loop parallel, the lists those of a serial walk).
The dot products: on the CPU schedule summed in fixed chunks of :data:`CHUNK` nodes and the chunks' sums in order;
on the GPU schedule each list entry's term stored, then summed by a fixed tree
(:class:`~gasp_taichi_mpm.schedule.primitives.SliceSums`); either way the result does not depend on the thread count.
The GPU schedule reads the convergence flag every :data:`gasp_taichi_mpm.schedule.CHECK_EVERY` iterations (an
iteration after convergence changes nothing: ``alpha = beta = 0``).

The CG's iterate ``u`` leaves the residual ``r = M v* - (M + dt K) u``, whose sum is the momentum ``M u`` lacks
(``K`` sums to zero). With :attr:`ImplicitViscosity.conserve` the step adds one uniform velocity per body label,
``du_b = sum_{i in b} r_i / sum_{i in b} m_i`` (fixed-order sums; a node's label: the least body id of the points
reaching it with a positive weight, by ``atomic_min``; a node none labelled joins the last body's). The labels
partition the nodes, so ``sum m (u + du) = sum m v*`` exactly and a body the solve left alone gets ``du = 0``
(docs/dissipation.md "Round 50"; round 49's one ``du`` moved a resting cube beside a sheared one; ``m u + r`` per
node diverged the README quick start, docs/contact.md "Round 49"). The label shares ``n_valid`` (bits 4 and up), the
sums take one row a group of ``WIDTH`` entries (:class:`~gasp_taichi_mpm.schedule.primitives.GroupSums`).
"""
import taichi as ti

from .schedule import CHECK_EVERY
from .schedule.ordered import sum_in_order
from .schedule.primitives import WIDTH, BoxCompaction, GroupSums, SliceSums

#: CG stops when sqrt(r.z) has fallen to this fraction of its value at v* (the viscous correction's accuracy).
TOL = 1e-2
#: At most this many CG iterations per substep.
MAX_ITERS = 200
#: Nodes per partial sum of a dot product (fixed: the sums do not depend on the threads).
CHUNK = 256


@ti.data_oriented
class ImplicitViscosity:
    """The viscous solve of one :class:`gasp_taichi_mpm.solver.MPMSolver` (its ``grid_mv[0]``, ``box[0]``).

    Parameters
    ----------
    solver : MPMSolver
        Its ``grid_mv`` copy 0 holds momentum (channels 0-2), mass (3) and the viscous volume
        (channel ``eta_channel``); ``box[0]`` the nodes touched by P2G.
    eta_channel : int
    """

    #: True: the step returns ``m (u + du)`` (total momentum that of ``M v*`` to round-off whatever :data:`TOL`);
    #: False: ``m u``, the rule before round 49 (the damped jelly slid 23 % fast on n_grid 48, docs/contact.md).
    conserve = True
    #: True: one ``du`` per body label; False: one over all solved nodes (round 49's rule).
    per_body = True
    #: True: a valid cell's 8 corners share one label (bodies apart are not bridged by the viscous stress); False:
    #: any 8 corners with mass, the rule before (docs/dissipation.md "Round 50: ... inside material only").
    same_label = True

    def __init__(self, solver, eta_channel: int):
        self.s = solver
        self.ch = int(eta_channel)
        real, ng = solver.real, solver.n_grid
        shape = (ng, ng, ng)
        # the solution u (m/s), the CG's residual, preconditioned residual, direction and A p
        self.u, self.r, self.z, self.p, self.Ap = (ti.Vector.field(3, real, shape=shape) for _ in range(5))
        self.diag = ti.field(real, shape=shape)           # m_i + dt sum_c (eta V)_c / (4 dx^2)
        self.wc = ti.field(real, shape=shape)             # (eta V)_c of the cell with lower corner I; 0: not valid
        self.S = ti.Matrix.field(3, 3, real, shape=shape)  # (eta V)_c (G_c + G_c^T) of the current direction
        self.n_valid = ti.field(ti.i32, shape=shape)   # valid cells at the node (bits 0-3), its label << 4
        self.nodes = ti.Vector.field(3, ti.i32, shape=ng ** 3)   # nodes with mass, in node order
        self.cells = ti.Vector.field(3, ti.i32, shape=ng ** 3)   # valid cells (lower corner), in node order
        self.n_nodes, self.n_cells = ti.field(ti.i32, shape=()), ti.field(ti.i32, shape=())
        self.part = ti.field(real, shape=ng ** 3 // CHUNK + 1)   # partial sums of a dot product
        self.rz, self.rz0, self.alpha, self.beta = (ti.field(real, shape=()) for _ in range(4))
        self.done = ti.field(ti.i32, shape=())
        self.active = ti.field(ti.i32, shape=())   # iterations run before convergence (the GPU schedule's batches)
        self.iters, self.solves = 0, 0        # CG iterations done in all, solves (statistics)
        self.gpu = bool(solver.gpu)   # the GPU schedule (gasp_taichi_mpm.schedule)
        self.comp = BoxCompaction(self, ng, (self.nodes, self.cells))
        self.dots = SliceSums(ng ** 3 if self.gpu else 1, 1, real)   # a dot product's terms per list entry (GPU)
        self.n_labels = int(solver.n_bodies)   # sum r, sum m per label (a node no point's: the last), fixed tree
        self.moms = GroupSums(ng ** 3, 4, real)
        self.mom = ti.Vector.field(4, real, shape=self.n_labels)

    @ti.func
    def listed(self, I, q: ti.template()):
        """List 0: the nodes with mass; list 1: the valid cells (``wc`` set by :meth:`_start`'s first loop)."""
        ok = False
        if ti.static(q == 0):
            ok = self.s.grid_mv[0, I][3] > 0.0
        else:
            ok = self.wc[I] > 0.0
        return ok

    @ti.func
    def overflow(self, I, q: ti.template()):
        pass   # the lists hold the whole grid

    @ti.func
    def _box(self):
        lo = self.s.box[0, 0]
        hi = self.s.box[0, 1]
        return lo, ti.max(hi - lo + 1, 0)

    @ti.func
    def _node(self, lo, ext, idx):
        return lo + ti.Vector([idx // (ext[1] * ext[2]), (idx // ext[2]) % ext[1], idx % ext[2]])

    @ti.func
    def _active(self, I, lo, hi):
        ok = False
        if (I >= lo).all() and (I <= hi).all():
            ok = self.s.grid_mv[0, I][3] > 0.0
        return ok

    @ti.func
    def _in(self, c, lo, hi):
        return (c >= lo).all() and (c <= hi).all()

    @ti.func
    def _g(self, a: ti.template(), b: ti.template(), e: ti.template()):
        """Gradient of the trilinear shape function of corner (a, b, e) at the cell centre."""
        q = 0.25 * self.s.inv_dx[None]
        return ti.Vector([ti.static(2.0 * a - 1.0), ti.static(2.0 * b - 1.0), ti.static(2.0 * e - 1.0)]) * q

    @ti.func
    def _cell_stress(self, c, field: ti.template()):
        """(eta V)_c (G + G^T) of ``field`` over valid cell ``c``."""
        G = ti.Matrix.zero(self.s.real, 3, 3)
        for a, b, e in ti.static(ti.ndrange(2, 2, 2)):
            G += field[c + ti.Vector([a, b, e])].outer_product(self._g(a, b, e))
        return self.wc[c] * (G + G.transpose())

    @ti.func
    def _cell_stress_zp(self, c, beta):
        """(eta V)_c (G + G^T) over valid cell ``c`` of the CG direction ``z + beta p``."""
        G = ti.Matrix.zero(self.s.real, 3, 3)
        for a, b, e in ti.static(ti.ndrange(2, 2, 2)):
            J = c + ti.Vector([a, b, e])
            G += (self.z[J] + beta * self.p[J]).outer_product(self._g(a, b, e))
        return self.wc[c] * (G + G.transpose())

    @ti.func
    def _node_force(self, I, lo, hi):
        """sum_c S_c g_ic over the valid cells holding node I: (K x)_i."""
        f = ti.Vector.zero(self.s.real, 3)
        for a, b, e in ti.static(ti.ndrange(2, 2, 2)):
            c = I - ti.Vector([a, b, e])
            if self._in(c, lo, hi):
                if self.wc[c] > 0.0:
                    f += self.S[c] @ self._g(a, b, e)
        return f

    @ti.func
    def _sum_parts(self, n):
        """The partial sums of ``n`` entries in chunk order (CPU schedule: ``schedule.ordered.sum_in_order``)."""
        return sum_in_order(self.part, (n + CHUNK - 1) // CHUNK)

    @ti.func
    def _start_node(self, k, lo, hi, kd, dt):
        """List entry k's diagonal, residual ``-dt K v*``, ``z`` and ``p``; returns its ``r.z``."""
        I = self.nodes[k]
        wsum = ti.cast(0.0, self.s.real)
        for a, b, e in ti.static(ti.ndrange(2, 2, 2)):
            c = I - ti.Vector([a, b, e])
            if self._in(c, lo, hi):
                wsum += self.wc[c]
        d = self.s.grid_mv[0, I][3] + kd * wsum
        r = -dt * self._node_force(I, lo, hi)
        self.diag[I] = d
        self.r[I] = r
        z = r / d
        self.z[I] = z
        self.p[I] = z
        return r.dot(z)

    @ti.func
    def _direction_node(self, k, beta, dt, lo, hi):
        """List entry k's direction ``p = z + beta p`` and ``A p``; returns its ``p.Ap``."""
        I = self.nodes[k]
        p = self.z[I] + beta * self.p[I]
        self.p[I] = p
        ap = self.s.grid_mv[0, I][3] * p + dt * self._node_force(I, lo, hi)
        self.Ap[I] = ap
        return p.dot(ap)

    @ti.func
    def _update_node(self, k, alpha):
        """List entry k's ``u += alpha p``, ``r -= alpha Ap``, ``z = r / diag``; returns its ``r.z``."""
        I = self.nodes[k]
        self.u[I] += alpha * self.p[I]
        r = self.r[I] - alpha * self.Ap[I]
        self.r[I] = r
        z = r / self.diag[I]
        self.z[I] = z
        return r.dot(z)

    @ti.kernel
    def _start(self, same: ti.i32):
        """Lists, cell weights, diagonal; u = v*, r = M v* - A u, z = r / diag, p = z, rz."""
        lo, ext = self._box()
        hi = lo + ext - 1
        count = ext[0] * ext[1] * ext[2]
        for idx in range(count):   # v*, and which cells are valid (all 8 corners with mass; with same, one label)
            I = self._node(lo, ext, idx)
            acc = self.s.grid_mv[0, I]
            u = ti.Vector.zero(self.s.real, 3)
            if acc[3] > 0.0:
                u = ti.Vector([acc[0], acc[1], acc[2]]) / acc[3]
            self.u[I] = u
            valid = True
            for a, b, e in ti.static(ti.ndrange(2, 2, 2)):
                J = I + ti.Vector([a, b, e])
                if not self._active(J, lo, hi):
                    valid = False
                elif same != 0 and (self.n_valid[J] >> 4) != (self.n_valid[I] >> 4):
                    valid = False
            self.wc[I] = 1.0 if valid else 0.0
        self.comp.run(lo, ext)   # the lists, in node order
        nn = self.comp.count[0]
        nc = self.comp.count[1]
        self.n_nodes[None] = nn
        self.n_cells[None] = nc
        for k in range(nn):   # valid cells per node
            I = self.nodes[k]
            n = 0
            for a, b, e in ti.static(ti.ndrange(2, 2, 2)):
                c = I - ti.Vector([a, b, e])
                if self._in(c, lo, hi):
                    if self.wc[c] > 0.0:
                        n += 1
            self.n_valid[I] = (self.n_valid[I] & ~15) | n
        for k in range(nc):   # each node's viscous volume shared among its valid cells
            c = self.cells[k]
            w = ti.cast(0.0, self.s.real)
            for a, b, e in ti.static(ti.ndrange(2, 2, 2)):
                J = c + ti.Vector([a, b, e])
                w += self.s.grid_mv[0, J][self.ch] / ti.cast(self.n_valid[J] & 15, self.s.real)
            self.wc[c] = w
        for k in range(nc):
            c = self.cells[k]
            self.S[c] = self._cell_stress(c, self.u)
        dt = self.s.dt[None]
        kd = 0.25 * dt * self.s.inv_dx[None] * self.s.inv_dx[None]
        rz = ti.cast(0.0, self.s.real)
        if ti.static(self.gpu):
            for k in range(nn):
                self.dots.part[k, 0] = self._start_node(k, lo, hi, kd, dt)
            self.dots.reduce(nn)
            rz = self.dots.out[0]
        else:
            for k0 in range(nn):
                if k0 % CHUNK == 0:
                    acc = ti.cast(0.0, self.s.real)
                    for k in range(k0, ti.min(k0 + CHUNK, nn)):
                        acc += self._start_node(k, lo, hi, kd, dt)
                    self.part[k0 // CHUNK] = acc
            rz = self._sum_parts(nn)
        self.rz[None] = rz
        self.rz0[None] = rz
        self.beta[None] = 0.0   # the first direction is z
        self.done[None] = 0
        if rz <= 0.0:
            self.done[None] = 1

    @ti.kernel
    def _iterate(self):
        """One preconditioned CG iteration (a no-op once converged)."""
        lo, ext = self._box()
        hi = lo + ext - 1
        nn = self.n_nodes[None]
        beta = self.beta[None]
        for k in range(self.n_cells[None]):   # S of the new direction z + beta p (p itself is updated below)
            c = self.cells[k]
            self.S[c] = self._cell_stress_zp(c, beta)
        dt = self.s.dt[None]
        if self.done[None] == 0:
            self.active[None] += 1
        pap = ti.cast(0.0, self.s.real)
        if ti.static(self.gpu):
            for k in range(nn):
                self.dots.part[k, 0] = self._direction_node(k, beta, dt, lo, hi)
            self.dots.reduce(nn)
            pap = self.dots.out[0]
        else:
            for k0 in range(nn):
                if k0 % CHUNK == 0:
                    acc = ti.cast(0.0, self.s.real)
                    for k in range(k0, ti.min(k0 + CHUNK, nn)):
                        acc += self._direction_node(k, beta, dt, lo, hi)
                    self.part[k0 // CHUNK] = acc
            pap = self._sum_parts(nn)
        self.alpha[None] = 0.0
        if pap > 0.0 and self.done[None] == 0:
            self.alpha[None] = self.rz[None] / pap
        else:
            self.done[None] = 1
        rz = ti.cast(0.0, self.s.real)
        if ti.static(self.gpu):
            for k in range(nn):
                self.dots.part[k, 0] = self._update_node(k, self.alpha[None])
            self.dots.reduce(nn)
            rz = self.dots.out[0]
        else:
            for k0 in range(nn):
                if k0 % CHUNK == 0:
                    alpha = self.alpha[None]
                    acc = ti.cast(0.0, self.s.real)
                    for k in range(k0, ti.min(k0 + CHUNK, nn)):
                        acc += self._update_node(k, alpha)
                    self.part[k0 // CHUNK] = acc
            rz = self._sum_parts(nn)
        self.beta[None] = 0.0
        if self.done[None] == 0:
            if self.rz[None] > 0.0:
                self.beta[None] = rz / self.rz[None]
            self.rz[None] = rz
            if rz <= TOL * TOL * self.rz0[None]:
                self.done[None] = 1

    @ti.kernel
    def _label(self, per_body: ti.i32):
        """The box's labels cleared (to the last body; 0 without per_body), then each point's body id by atomic_min."""
        lo, ext = self._box()
        none = self.n_labels - 1 if per_body != 0 else 0
        for idx in range(ext[0] * ext[1] * ext[2]):
            self.n_valid[self._node(lo, ext, idx)] = none << 4
        if per_body != 0:
            for p in range(self.s.n_material):
                base, fx, ok = self.s.base_fx(self.s.x[p])
                if ok and self.s.p_mass[p] > 0.0:
                    w = self.s.weights(fx)
                    b = self.s.body[p] << 4
                    for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                        if w[i][0] * w[j][1] * w[k][2] > 0.0:
                            ti.atomic_min(self.n_valid[base + ti.Vector([i, j, k])], b)

    @ti.kernel
    def _label_sum(self, b: ti.i32):
        """``mom[b]``: sum r and sum m over the entries labelled ``b`` (in-order groups, then :class:`GroupSums`)."""
        nn = self.n_nodes[None]
        for g in range((nn + WIDTH - 1) // WIDTH):
            acc = ti.Vector.zero(self.s.real, 4)
            for k in range(g * WIDTH, ti.min(g * WIDTH + WIDTH, nn)):
                I = self.nodes[k]
                if self.n_valid[I] >> 4 == b:
                    r = self.r[I]
                    acc += ti.Vector([r[0], r[1], r[2], self.s.grid_mv[0, I][3]])
            for c in ti.static(range(4)):
                self.moms.l1[g, c] = acc[c]
        self.moms.reduce((nn + WIDTH - 1) // WIDTH)
        self.mom[b] = ti.Vector([self.moms.out[0], self.moms.out[1], self.moms.out[2], self.moms.out[3]])

    @ti.kernel
    def _finish(self, conserve: ti.i32):
        """Momentum ``m (u + du)`` into grid_mv; ``du`` the node label's (:meth:`_label_sum`) when ``conserve``."""
        for k in range(self.n_nodes[None]):
            I = self.nodes[k]
            s = self.mom[self.n_valid[I] >> 4]
            du = ti.Vector.zero(self.s.real, 3)
            if conserve != 0 and s[3] > 0.0:
                du = ti.Vector([s[0], s[1], s[2]]) / s[3]
            m = self.s.grid_mv[0, I][3]
            mu = m * (self.u[I] + du)
            self.s.grid_mv[0, I][0] = mu[0]
            self.s.grid_mv[0, I][1] = mu[1]
            self.s.grid_mv[0, I][2] = mu[2]

    def solve(self) -> None:
        """One backward-Euler viscous step on the grid momentum (between P2G and the grid update)."""
        if self.n_labels > 1:   # one body: every label 0 from the start
            self._label(int(self.per_body))
        self._start(int(self.same_label))
        k = 0
        every = CHECK_EVERY if self.gpu else 1   # GPU: the flag read every few iterations (no-ops once converged)
        while k < MAX_ITERS and not self.done[None]:
            for _ in range(min(every, MAX_ITERS - k)):
                self._iterate()
                k += 1
        for b in range(self.n_labels if self.per_body else 1):
            self._label_sum(b)
        self._finish(int(self.conserve))
        self.iters += k if not self.gpu else 0   # the GPU schedule counts on the device (active)
        self.solves += 1

    def mean_iterations(self) -> float:
        """CG iterations a viscous solve took, on average (the GPU schedule's no-op iterations left out)."""
        iters = self.iters if not self.gpu else int(self.active[None])
        return iters / max(self.solves, 1)
