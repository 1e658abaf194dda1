"""Grady's cells parted at their faces (``gasp_core.run.grady_cells``; ``docs/fracture.md`` "Round 102: Grady's cells
in the engines"), the engines' feature ``fracture_cells``; warp_mpm's ``cells.py`` is the same steps.

Each substep, before P2G, :meth:`Cells.cell_ref` gives every node its reference cell: the cell of its point of
largest weight, by an atomic max of a key packing the weight above the cell id (one thread a point on a GPU, the
same bits in any order). In P2G a split point whose cell is the node's reference scatters its momentum and mass to
``grid_cs`` as well (field A; field B is the rest of the node), and each field's largest damage to ``grid_cd``.
:meth:`Cells.cell_contact` then turns them into each field's velocity offset ``grid_cdv``: the fields move as one
unless each has a broken point (damage 1) there, and then meet in Coulomb contact when they approach (the normal
field B's mass gradient, as the two-field contact of ``gasp_core.mpm.fields`` takes it) and part freely when they
do not. G2P reads a split point's velocity at a node as the grid's plus its field's offset (:meth:`Cells.cell_v`).
A cell's inside (``SimSetup.cells`` <= -2) starts at ``Jp`` -1 and never damages, and a broken point of a body in
cells keeps its tension-free stress (``P_CELLS``; ``gasp_core.mpm.materials``, constitutive.py).

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver` (its ``x``, ``Jp``, ``grid_mv``, ``touched_box``).
"""
import numpy as np
import taichi as ti

from gasp_core.mpm.fields import MIN_FRACTION, MIN_GRADIENT
from gasp_core.mpm.cells import FACE_MU, KEY_SCALE
from gasp_core.seam import SceneError


@ti.data_oriented
class Cells:
    """The cells' fields and kernels (none without cells: ``cells_on`` False)."""

    cells_on = False

    def allocate_cells(self, cells: np.ndarray | None, order: np.ndarray) -> None:
        """``cells`` (n,) int32, ``SimSetup.cells`` (None: none), ``order`` the solver's point order (n,) int. Before
        the first substep.

        Raises
        ------
        SceneError
            With the two-field contact between bodies (a scene of one body only: ``gasp_core.run.grady_cells``).
        """
        if cells is None:
            return
        cells = np.asarray(cells)[order]
        if self.fields:
            raise SceneError("SimSetup.cells: Grady's cells need a scene of one body (no two-field contact)")
        ng, cap = self.n_grid, self.x.shape[0]
        self.p_cell = ti.field(ti.i32, shape=cap)
        buf = np.full(cap, -1, np.int32)
        buf[:self.n] = cells
        self.p_cell.from_numpy(buf)
        self.grid_ref = ti.field(ti.i32, shape=(ng, ng, ng))
        self.grid_cs = ti.Vector.field(4, self.real, shape=(ng, ng, ng))
        self.grid_cd = ti.field(self.real, shape=(2, ng, ng, ng))
        self.grid_cdv = ti.Vector.field(6, self.real, shape=(ng, ng, ng))
        self.grid_ref.fill(-1)
        self.cells_on = True

    @ti.func
    def cell_of(self, p):
        """Point p's cell (-1: none)."""
        c = self.p_cell[p]
        if c <= -2:
            c = -2 - c
        return c

    @ti.func
    def cell_side(self, c, node):
        """0 where cell ``c`` is ``node``'s reference cell (or ``c`` is none), else 1."""
        ref = self.grid_ref[node]
        side = 0
        if c >= 0 and ref >= 0 and ref % 256 != c:
            side = 1
        return side

    @ti.kernel
    def cell_ref(self):
        """Each node's reference cell key (module notes), from the points' positions now."""
        for p in range(self.n_points[None]):
            c = self.cell_of(p)
            if c >= 0 and self.asleep[self.body[p]] == 0 and self.p_mass[p] > 0.0:
                base, fx, ok = self.base_fx(self.x[p])
                if ok:
                    w = self.weights(fx)
                    for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                        key = ti.cast(w[i][0] * w[j][1] * w[k][2] * KEY_SCALE, ti.i32) * 256 + c
                        ti.atomic_max(self.grid_ref[base + ti.Vector([i, j, k])], key)

    def cells_before_p2g(self, with_g2p: int) -> int:
        """Before a substep's P2G: its G2P alone (the reference cells need the points where they moved), then the
        reference cells; returns the ``with_g2p`` the P2G takes (0 with cells: done here)."""
        if not self.cells_on:
            return with_g2p
        if with_g2p:
            self.g2p()
        self.grid_ref.fill(-1)
        self.cell_ref()
        return 0

    @ti.func
    def scatter_cells(self, p, base, w, mv0, A, m):
        """P2G of point p's share to its field at each node (module notes)."""
        if ti.static(self.cells_on):
            c = self.cell_of(p)
            d = ti.max(self.Jp[p], 0.0)
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                node = base + ti.Vector([i, j, k])
                side = self.cell_side(c, node)
                if side == 0:
                    mv = mv0 + A @ ti.Vector([float(i), float(j), float(k)])
                    ti.atomic_add(self.grid_cs[node], (w[i][0] * w[j][1] * w[k][2]) * ti.Vector([mv[0], mv[1], mv[2], m]))
                ti.atomic_max(self.grid_cd[side, node[0], node[1], node[2]], d)

    @ti.func
    def cell_grad_b(self, I):
        """Field B's mass gradient at the inner node I (central differences, kg per cell): it rises into B, so its
        direction is field A's outward normal (the two-field contact's normal, fields.py)."""
        out = ti.Vector.zero(self.real, 3)
        for a in ti.static(range(3)):
            e = ti.Vector.unit(3, a, ti.i32)
            out[a] = (self.grid_mv[0, I + e][3] - self.grid_cs[I + e][3]) - (self.grid_mv[0, I - e][3] - self.grid_cs[I - e][3])
        return out

    @ti.kernel
    def cell_contact(self):
        """Each node's field offsets (module notes), then the scatters cleared; over the nodes P2G touched."""
        ng = self.n_grid
        lo, ext = self.touched_box()
        for idx in range(ext[0] * ext[1] * ext[2]):
            I = lo + ti.Vector([idx // (ext[1] * ext[2]), (idx // ext[2]) % ext[1], idx % ext[2]])
            g = self.grid_mv[0, I]
            m = g[3]
            cs = self.grid_cs[I]
            m_a = cs[3]
            m_b = m - m_a
            dv = ti.Vector.zero(self.real, 6)
            inner = (I > 0).all() and (I < ng - 1).all()
            broken = self.grid_cd[0, I[0], I[1], I[2]] >= 1.0 and self.grid_cd[1, I[0], I[1], I[2]] >= 1.0
            if inner and broken and m_a > MIN_FRACTION * m and m_b > MIN_FRACTION * m:
                gb = self.cell_grad_b(I)
                if gb.norm() > MIN_GRADIENT * m:
                    n = gb.normalized()   # field A's outward normal
                    v_a = ti.Vector([cs[0], cs[1], cs[2]]) / m_a
                    v_b = ti.Vector([g[0] - cs[0], g[1] - cs[1], g[2] - cs[2]]) / m_b
                    vcm = ti.Vector([g[0], g[1], g[2]]) / m
                    new_a, new_b = v_a, v_b   # parting: free
                    if (v_a - v_b).dot(n) > 0.0:   # approaching: Coulomb
                        u = v_a - vcm
                        un = u.dot(n)
                        ut = u - un * n
                        lt = ut.norm()
                        scale = ti.max(0.0, 1.0 - FACE_MU * ti.max(un, 0.0) / ti.max(lt, 1e-30))
                        new_a = vcm + scale * ut
                        new_b = vcm - (m_a / m_b) * scale * ut
                    da, db = new_a - vcm, new_b - vcm
                    dv = ti.Vector([da[0], da[1], da[2], db[0], db[1], db[2]])
            self.grid_cdv[I] = dv
        for idx in range(ext[0] * ext[1] * ext[2]):
            I = lo + ti.Vector([idx // (ext[1] * ext[2]), (idx // ext[2]) % ext[1], idx % ext[2]])
            self.grid_cs[I] = ti.Vector.zero(self.real, 4)
            self.grid_cd[0, I[0], I[1], I[2]] = 0.0
            self.grid_cd[1, I[0], I[1], I[2]] = 0.0

    @ti.func
    def cell_v(self, p, node):
        """Point p's field's offset at ``node`` (zero without cells or for a point in no cell)."""
        out = ti.Vector.zero(self.real, 3)
        if ti.static(self.cells_on):
            c = self.cell_of(p)
            if c >= 0 and self.p_mass[p] > 0.0:   # a passive point follows the grid's velocity
                d = self.grid_cdv[node]
                out = ti.Vector([d[0], d[1], d[2]])
                if self.cell_side(c, node) == 1:
                    out = ti.Vector([d[3], d[4], d[5]])
        return out
