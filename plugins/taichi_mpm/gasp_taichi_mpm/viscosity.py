"""Implicit Kelvin-Voigt viscosity on the grid (``docs/dissipation.md``, "Time step"; ``docs/mpm.md`` step 3a).

After P2G the grid holds each node's momentum ``m v*`` (elastic stress included), mass ``m`` and viscous
volume ``(eta V)_i = sum_p w_ip J_p V_p eta_p`` (Pa s m^3). The viscous stress ``2 eta D`` is linear in the
velocity, so one backward-Euler step of it is the linear system

    (M + dt K) v = M v*,      (K v)_i = sum_c (eta V)_c (G_c + G_c^T) g_ic,

over the nodes with mass, where ``c`` runs over the grid cells whose 8 corner nodes all have mass,
``G_c = sum_i v_i g_ic^T`` is the cell's velocity gradient (trilinear shape functions at the cell centre,
``g_ic = (+-1, +-1, +-1) / (4 dx)``) and ``(eta V)_c = sum_corners (eta V)_i / n_i`` shares each node's viscous
volume among its ``n_i`` valid cells (their sum is the body's ``sum_p J_p V_p eta_p``). ``K`` is the Hessian of
the Rayleigh dissipation ``sum_c (eta V)_c D_c : D_c``: symmetric, positive semi-definite, zero on rigid
motions, so the step conserves linear and angular momentum and is stable at any ``dt``. It is solved by
conjugate gradients with the diagonal as preconditioner, starting from ``v*``, until the preconditioned
residual falls below :data:`TOL` of its start (at most :data:`MAX_ITERS` iterations); the dot products are
summed serially in node order, so the result does not depend on the thread count.
"""
import taichi as ti

#: CG stops when sqrt(r.z) has fallen to this fraction of its value at v* (the viscous correction's accuracy).
TOL = 1e-4
#: At most this many CG iterations per substep.
MAX_ITERS = 200


@ti.data_oriented
class ImplicitViscosity:
    """The viscous solve of one :class:`gasp_taichi_mpm.solver.MPMSolver` (its ``grid_acc[0]``, ``box[0]``).

    Parameters
    ----------
    solver : MPMSolver
        Its ``grid_acc`` copy 0 holds momentum (channels 0-2), mass (3) and the viscous volume
        (channel ``eta_channel``); ``box[0]`` the nodes touched by P2G.
    eta_channel : int
    """

    def __init__(self, solver, eta_channel: int):
        self.s = solver
        self.ch = int(eta_channel)
        real, ng = solver.real, solver.n_grid
        shape = (ng, ng, ng)
        self.u = ti.Vector.field(3, real, shape=shape)     # the solution (m/s)
        self.r = ti.Vector.field(3, real, shape=shape)
        self.z = ti.Vector.field(3, real, shape=shape)
        self.p = ti.Vector.field(3, real, shape=shape)
        self.Ap = ti.Vector.field(3, real, shape=shape)
        self.diag = ti.field(real, shape=shape)           # m_i + dt sum_c (eta V)_c / (4 dx^2); 0: not an unknown
        self.wc = ti.field(real, shape=shape)             # (eta V)_c of the cell with lower corner I; 0: not valid
        self.S = ti.Matrix.field(3, 3, real, shape=shape)  # (eta V)_c (G_c + G_c^T) of the current direction
        self.n_valid = ti.field(ti.i32, shape=shape)
        self.rz = ti.field(real, shape=())
        self.rz0 = ti.field(real, shape=())
        self.done = ti.field(ti.i32, shape=())
        self.iters = 0        # CG iterations done in all (statistics)
        self.solves = 0

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
            ok = self.s.grid_acc[0, I][3] > 0.0
        return ok

    @ti.func
    def _cell_valid(self, c, lo, hi):
        ok = True
        for a, b, e in ti.static(ti.ndrange(2, 2, 2)):
            if not self._active(c + ti.Vector([a, b, e]), lo, hi):
                ok = False
        return ok

    @ti.func
    def _cell_stress(self, c, field: ti.template()):
        """(eta V)_c (G + G^T) of ``field`` over cell ``c`` (zero when the cell is not valid)."""
        S = ti.Matrix.zero(self.s.real, 3, 3)
        w = self.wc[c]
        if w > 0.0:
            G = ti.Matrix.zero(self.s.real, 3, 3)
            q = 0.25 * self.s.inv_dx[None]
            for a, b, e in ti.static(ti.ndrange(2, 2, 2)):
                g = ti.Vector([2.0 * a - 1.0, 2.0 * b - 1.0, 2.0 * e - 1.0]) * q
                G += field[c + ti.Vector([a, b, e])].outer_product(g)
            S = w * (G + G.transpose())
        return S

    @ti.func
    def _node_force(self, I, lo, hi):
        """sum_c S_c g_ic over the (up to 8) valid cells holding node I: (K x)_i."""
        f = ti.Vector.zero(self.s.real, 3)
        q = 0.25 * self.s.inv_dx[None]
        for a, b, e in ti.static(ti.ndrange(2, 2, 2)):
            c = I - ti.Vector([a, b, e])
            if (c >= lo).all() and (c <= hi).all():
                g = ti.Vector([2.0 * a - 1.0, 2.0 * b - 1.0, 2.0 * e - 1.0]) * q
                f += self.S[c] @ g
        return f

    @ti.kernel
    def _start(self):
        """u = v*, the cells' weights and the diagonal, r = M v* - A u, z = r / diag, p = z, rz."""
        lo, ext = self._box()
        hi = lo + ext - 1
        count = ext[0] * ext[1] * ext[2]
        for idx in range(count):   # v*, and which cells are valid (all 8 corners with mass)
            I = self._node(lo, ext, idx)
            acc = self.s.grid_acc[0, I]
            u = ti.Vector.zero(self.s.real, 3)
            if acc[3] > 0.0:
                u = ti.Vector([acc[0], acc[1], acc[2]]) / acc[3]
            self.u[I] = u
            self.wc[I] = 1.0 if self._cell_valid(I, lo, hi) else 0.0
        for idx in range(count):   # valid cells per node
            I = self._node(lo, ext, idx)
            n = 0
            for a, b, e in ti.static(ti.ndrange(2, 2, 2)):
                c = I - ti.Vector([a, b, e])
                if (c >= lo).all() and (c <= hi).all():
                    if self.wc[c] > 0.0:
                        n += 1
            self.n_valid[I] = n
        for idx in range(count):   # each node's viscous volume shared among its valid cells
            c = self._node(lo, ext, idx)
            if self.wc[c] > 0.0:
                w = ti.cast(0.0, self.s.real)
                for a, b, e in ti.static(ti.ndrange(2, 2, 2)):
                    J = c + ti.Vector([a, b, e])
                    w += self.s.grid_acc[0, J][self.ch] / ti.cast(self.n_valid[J], self.s.real)
                self.wc[c] = w
        for idx in range(count):
            c = self._node(lo, ext, idx)
            self.S[c] = self._cell_stress(c, self.u)
        dt = self.s.dt[None]
        k = 0.25 * dt * self.s.inv_dx[None] * self.s.inv_dx[None]
        for idx in range(count):
            I = self._node(lo, ext, idx)
            m = self.s.grid_acc[0, I][3]
            d = ti.cast(0.0, self.s.real)
            r = ti.Vector.zero(self.s.real, 3)
            if m > 0.0:
                wsum = ti.cast(0.0, self.s.real)
                for a, b, e in ti.static(ti.ndrange(2, 2, 2)):
                    c = I - ti.Vector([a, b, e])
                    if (c >= lo).all() and (c <= hi).all():
                        wsum += self.wc[c]
                d = m + k * wsum
                r = -dt * self._node_force(I, lo, hi)
            self.diag[I] = d
            self.r[I] = r
            z = ti.Vector.zero(self.s.real, 3)
            if d > 0.0:
                z = r / d
            self.z[I] = z
            self.p[I] = z
        rz = ti.cast(0.0, self.s.real)
        ti.loop_config(serialize=True)
        for idx in range(count):
            I = self._node(lo, ext, idx)
            rz += self.r[I].dot(self.z[I])
        self.rz[None] = rz
        self.rz0[None] = rz
        self.done[None] = 0
        if rz <= 0.0:
            self.done[None] = 1

    @ti.kernel
    def _iterate(self):
        """One preconditioned CG iteration (a no-op once converged)."""
        lo, ext = self._box()
        hi = lo + ext - 1
        count = ext[0] * ext[1] * ext[2]
        for idx in range(count):
            c = self._node(lo, ext, idx)
            self.S[c] = self._cell_stress(c, self.p)
        dt = self.s.dt[None]
        for idx in range(count):
            I = self._node(lo, ext, idx)
            ap = ti.Vector.zero(self.s.real, 3)
            if self.diag[I] > 0.0:
                ap = self.s.grid_acc[0, I][3] * self.p[I] + dt * self._node_force(I, lo, hi)
            self.Ap[I] = ap
        pap = ti.cast(0.0, self.s.real)
        ti.loop_config(serialize=True)
        for idx in range(count):
            I = self._node(lo, ext, idx)
            pap += self.p[I].dot(self.Ap[I])
        alpha = ti.cast(0.0, self.s.real)
        if pap > 0.0 and self.done[None] == 0:
            alpha = self.rz[None] / pap
        for idx in range(count):
            I = self._node(lo, ext, idx)
            if self.diag[I] > 0.0:
                self.u[I] += alpha * self.p[I]
                r = self.r[I] - alpha * self.Ap[I]
                self.r[I] = r
                self.z[I] = r / self.diag[I]
        rz = ti.cast(0.0, self.s.real)
        ti.loop_config(serialize=True)
        for idx in range(count):
            I = self._node(lo, ext, idx)
            rz += self.r[I].dot(self.z[I])
        beta = ti.cast(0.0, self.s.real)
        if self.done[None] == 0 and self.rz[None] > 0.0:
            beta = rz / self.rz[None]
        for idx in range(count):
            I = self._node(lo, ext, idx)
            self.p[I] = self.z[I] + beta * self.p[I]
        if self.done[None] == 0:
            self.rz[None] = rz
            if rz <= TOL * TOL * self.rz0[None] or pap <= 0.0:
                self.done[None] = 1

    @ti.kernel
    def _finish(self):
        """Momentum m u back into grid_acc (the grid update divides by m again)."""
        lo, ext = self._box()
        count = ext[0] * ext[1] * ext[2]
        for idx in range(count):
            I = self._node(lo, ext, idx)
            m = self.s.grid_acc[0, I][3]
            if m > 0.0:
                mu = m * self.u[I]
                self.s.grid_acc[0, I][0] = mu[0]
                self.s.grid_acc[0, I][1] = mu[1]
                self.s.grid_acc[0, I][2] = mu[2]

    def solve(self) -> None:
        """One backward-Euler viscous step on the grid momentum (between P2G and the grid update)."""
        self._start()
        k = 0
        while k < MAX_ITERS and not self.done[None]:
            self._iterate()
            k += 1
        self._finish()
        self.iters += k
        self.solves += 1
