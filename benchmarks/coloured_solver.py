"""Prototype kernels of the coloured block P2G (issue 29, phase A): see ``coloured_p2g.py``.

A subclass of taichi_mpm's ``MPMSolver`` with one grid copy (``n_chunks = 1``, plain adds), a block sort and
a G2P + P2G in 8 coloured passes; everything else (constitutive models, grid update) is the solver's.
"""
import numpy as np
import taichi as ti

import gasp_taichi_mpm.solver as S

B = 4            # block side, nodes: with margin 1 the stencils of same-colour blocks never overlap (2 m < B - 1)
MARGIN = 1       # cells a point may drift out of its block since the sort and still scatter in its pass
N_SORT_CHUNKS = 16
IMPLICIT = True  # implicit viscosity on the grid (gasp_taichi_mpm.viscosity)


@ti.data_oriented
class ColouredSolver(S.MPMSolver):
    def __init__(self, *a, sort_every=10, **kw):
        kw["n_chunks"] = 1
        kw["atomic"] = False
        self.sort_every = int(sort_every)
        super().__init__(*a, **kw)
        ng = self.n_grid
        self.nb = -(-ng // B)
        self.nbh = -(-self.nb // 2)
        self.n_keys = 8 * self.nbh ** 3
        cap = self.x.shape[0]
        self.key = ti.field(ti.i32, shape=cap)
        self.order = ti.field(ti.i32, shape=cap)
        self.skey = ti.field(ti.i32, shape=cap)
        self.late = ti.field(ti.i8, shape=cap)
        self.hist = ti.field(ti.i32, shape=(N_SORT_CHUNKS, self.n_keys))
        self.colour_lo = ti.field(ti.i32, shape=9)
        self.n_late = ti.field(ti.i32, shape=())
        self.late_total = 0
        self.n_sorts = 0
        self.sort_s = 0.0

    def _allocate_grid(self):
        """One more grid channel with a viscous material: the viscous volume sum_p w J V eta (implicit viscosity)."""
        self.implicit_viscosity = self.viscous and IMPLICIT
        if self.implicit_viscosity:
            self.eta_ch = self.acc_width
            self.acc_width += 1
        super()._allocate_grid()
        if self.implicit_viscosity:
            from gasp_taichi_mpm.viscosity import ImplicitViscosity
            self.visc = ImplicitViscosity(self, self.eta_ch)

    @ti.func
    def _p2g_point(self, p, t, bmin, bmax):
        """The solver's P2G of point p (no wind), with the viscous volume in its own channel instead of the
        explicit viscous stress when the viscosity is implicit."""
        base, fx, ok = self._base_fx(self.x[p])
        if not ok:
            ti.atomic_add(self.n_out[None], 1)
        else:
            dt = self.dt[None]
            inv_dx = self.inv_dx[None]
            C = self.C[p]
            F = (ti.Matrix.identity(self.real, 3) + dt * C) @ self.F[p]
            tau = self._constitutive(p, F)
            eta_v = ti.cast(0.0, self.real)
            if ti.static(self.viscous):
                eta_j = self.mat[self.body[p]][S.P_ETA] * F.determinant()
                if ti.static(self.implicit_viscosity):
                    eta_v = eta_j * self.p_vol[p]
                else:
                    tau += eta_j * (C + C.transpose())
            m = self.p_mass[p]
            dx = self.dx[None]
            affine = (-dt * self.p_vol[p] * 4.0 * inv_dx * inv_dx) * tau + m * C
            A = affine * dx
            S_ = (affine - m * C) * dx
            mv0 = m * self.v[p] - A @ fx
            w = self._weights(fx)
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                weight = w[i][0] * w[j][1] * w[k][2]
                mv = mv0
                if ti.static(i > 0):
                    mv += ti.static(float(i)) * ti.Vector([A[0, 0], A[1, 0], A[2, 0]])
                if ti.static(j > 0):
                    mv += ti.static(float(j)) * ti.Vector([A[0, 1], A[1, 1], A[2, 1]])
                if ti.static(k > 0):
                    mv += ti.static(float(k)) * ti.Vector([A[0, 2], A[1, 2], A[2, 2]])
                val = weight * self._acc_val(mv, m, mv - S_ @ (ti.Vector([float(i), float(j), float(k)]) - fx))
                node = base + ti.Vector([i, j, k])
                if ti.static(self.implicit_viscosity):
                    val2 = ti.Vector.zero(self.real, self.acc_width)
                    for q in ti.static(range(self.acc_width - 1)):
                        val2[q] = val[q]
                    val2[self.acc_width - 1] = weight * eta_v
                    self.grid_acc[t, node] = self.grid_acc[t, node] + val2
                else:
                    self.grid_acc[t, node] = self.grid_acc[t, node] + val
            bmin = ti.min(bmin, base)
            bmax = ti.max(bmax, base + 2)
        return bmin, bmax

    @ti.func
    def _key(self, p):
        X = (self.x[p] - self.lo[None]) * self.inv_dx[None]
        base = ti.cast(ti.floor(X - 0.5), ti.i32)
        bi = ti.min(ti.max(base, 0), self.n_grid - 1) // B
        colour = (bi[0] & 1) + 2 * (bi[1] & 1) + 4 * (bi[2] & 1)
        h = bi >> 1
        return ((colour * self.nbh + h[0]) * self.nbh + h[1]) * self.nbh + h[2]

    @ti.kernel
    def sort_blocks(self):
        """Stable counting sort of the material points by block key (colour-major): ``order``, ``skey``, ``colour_lo``."""
        n = self.n_points[None]
        for q, kk in self.hist:
            self.hist[q, kk] = 0
        for p in range(n):
            self.key[p] = self._key(p)
        per = (n + N_SORT_CHUNKS - 1) // N_SORT_CHUNKS
        for p0 in range(n):   # one iteration per chunk start does the chunk (Taichi splits the loop by points)
            if p0 % per == 0:
                q = p0 // per
                for p in range(p0, ti.min(p0 + per, n)):
                    self.hist[q, self.key[p]] += 1
        off = 0
        ti.loop_config(serialize=True)
        for kk in range(self.n_keys):
            if kk % (self.nbh ** 3) == 0:
                self.colour_lo[kk // (self.nbh ** 3)] = off
            for q in range(N_SORT_CHUNKS):
                c = self.hist[q, kk]
                self.hist[q, kk] = off
                off += c
        self.colour_lo[8] = off
        for p0 in range(n):
            if p0 % per == 0:
                q = p0 // per
                for p in range(p0, ti.min(p0 + per, n)):
                    k = self.key[p]
                    slot = self.hist[q, k]
                    self.hist[q, k] = slot + 1
                    self.order[slot] = p
                    self.skey[slot] = k

    @ti.func
    def _block_origin(self, k):
        per_c = self.nbh ** 3
        colour = k // per_c
        r = k % per_c
        h = ti.Vector([r // (self.nbh * self.nbh), (r // self.nbh) % self.nbh, r % self.nbh])
        c = ti.Vector([colour & 1, (colour >> 1) & 1, (colour >> 2) & 1])
        return (2 * h + c) * B

    @ti.kernel
    def _p2g_start(self):
        self.n_late[None] = 0
        if ti.static(self.has_passive):
            self.box[0, 0] = self.pbox[0, 0]
            self.box[0, 1] = self.pbox[0, 1]
        else:
            self.box[0, 0] = ti.Vector([self.n_grid, self.n_grid, self.n_grid])
            self.box[0, 1] = ti.Vector([-1, -1, -1])

    @ti.kernel
    def _p2g_colour(self, c: ti.i32, with_g2p: ti.i32):
        """(G2P and) P2G of the blocks of colour c: one flat loop over their points, a block per first point."""
        for k0 in range(self.colour_lo[c], self.colour_lo[c + 1]):
            if k0 == self.colour_lo[c] or self.skey[k0] != self.skey[k0 - 1]:
                key = self.skey[k0]
                o = self._block_origin(key)
                bmin = ti.Vector([self.n_grid, self.n_grid, self.n_grid])
                bmax = ti.Vector([-1, -1, -1])
                k = k0
                while k < self.colour_lo[c + 1] and self.skey[k] == key:
                    p = self.order[k]
                    if with_g2p:
                        self._g2p_point(p)
                    X = (self.x[p] - self.lo[None]) * self.inv_dx[None]
                    base = ti.cast(ti.floor(X - 0.5), ti.i32)
                    if (base >= o - MARGIN).all() and (base <= o + B - 1 + MARGIN).all():
                        bmin, bmax = self._p2g_point(p, 0, bmin, bmax)
                    else:
                        self.late[p] = ti.cast(1, ti.i8)
                        ti.atomic_add(self.n_late[None], 1)
                    k += 1
                ti.atomic_min(self.box[0, 0], bmin)
                ti.atomic_max(self.box[0, 1], bmax)

    @ti.kernel
    def _p2g_late(self):
        """The points that drifted more than MARGIN out of their block: serially, in sorted order."""
        if self.n_late[None] > 0:   # serial (not the outermost scope)
            bmin = self.box[0, 0]
            bmax = self.box[0, 1]
            for k in range(self.colour_lo[8]):
                p = self.order[k]
                if self.late[p] != 0:
                    self.late[p] = ti.cast(0, ti.i8)
                    bmin, bmax = self._p2g_point(p, 0, bmin, bmax)
            self.box[0, 0] = bmin
            self.box[0, 1] = bmax

    def g2p_p2g(self, with_g2p):
        self._p2g_start()
        for c in range(8):
            self._p2g_colour(c, with_g2p)
        self._p2g_late()
        if self.implicit_viscosity:
            self.visc.solve()

    def substeps(self, n_substeps: int) -> None:
        import time
        at = self._passive_at(n_substeps)
        if self.has_extras:
            self.ex_tab.from_numpy(self._time_table().astype(self._ex_np))
            self.ex_step[None] = 0
        self._sort()
        self.g2p_p2g(0)
        self._count_late()
        for s in range(n_substeps - 1):
            self.grid_update()
            if at[s] is not None:
                self.g2p_passive(at[s])
            if self.has_extras:
                self.ex_step[None] = s + 1
            if (s + 1) % self.sort_every == 0:
                self._sort()
            self.g2p_p2g(1)
            self._count_late()
        self.grid_update()
        self.g2p()
        if at[-1] is not None:
            self.g2p_passive(at[-1])

    def _sort(self):
        import time
        ti.sync()
        t0 = time.perf_counter()
        self.sort_blocks()
        ti.sync()
        self.sort_s += time.perf_counter() - t0
        self.n_sorts += 1

    def _count_late(self):
        self.late_total += int(self.n_late[None])

    def sort_stats(self):
        return {"sorts": self.n_sorts, "sort_ms": 1e3 * self.sort_s / max(self.n_sorts, 1),
                "late_total": self.late_total}


def install(sort_every=10):
    """Make taichi_mpm build :class:`ColouredSolver` (call before ``build_engine``)."""
    import functools
    import gasp_taichi_mpm.solver as mod
    mod.MPMSolver = functools.partial(ColouredSolver, sort_every=sort_every)
