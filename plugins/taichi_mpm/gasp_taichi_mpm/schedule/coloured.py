"""The CPU schedule's P2G: coloured blocks (the solver's notes, :mod:`gasp_taichi_mpm.solver`). The material points
are sorted by block of 4^3 nodes (a stable counting sort, the same order on any thread count), then G2P and P2G run in
8 passes, one per colour, each block scattered by one thread with plain adds: every node's sum in a fixed order.

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`; its per-point functions are :mod:`gasp_taichi_mpm.transfers`'.
"""
import taichi as ti

#: Block side of the coloured P2G, nodes. A point is filed under the block of its stencil base ``floor(X - 0.5)``;
#: blocks of one colour are a block apart, so the 3-node stencils of two same-colour blocks do not overlap while
#: their points stay within :data:`MARGIN` cells of their block (``2 MARGIN < BLOCK - 1``).
BLOCK = 4
#: Cells a point may drift out of its block since the last sort and still scatter in its block's pass.
MARGIN = 1
#: The coloured P2G re-sorts the points by block every this many substeps (and at every frame's start).
SORT_EVERY = 10
#: Fixed chunks of the counting sort (each counts and places its points serially, in order: a stable sort).
SORT_CHUNKS = 16


class ColouredP2G:
    """The coloured block P2G of the CPU schedule: the block sort, the 8 colour passes, the late points."""

    @ti.func
    def block_key(self, p):
        """Sort key of point p: its block (of the stencil base), colour-major (colour = parity of the block index)."""
        X = (self.x[p] - self.lo[None]) * self.inv_dx[None]
        base = ti.cast(ti.floor(X - 0.5), ti.i32)
        bi = ti.min(ti.max(base, 0), self.n_grid - 1) // BLOCK
        colour = (bi[0] & 1) + 2 * (bi[1] & 1) + 4 * (bi[2] & 1)
        h = bi >> 1
        return ((colour * self.nbh + h[0]) * self.nbh + h[1]) * self.nbh + h[2]

    @ti.func
    def block_origin(self, key):
        """First node of the block with sort key ``key``."""
        per = self.nbh * self.nbh * self.nbh
        colour = key // per
        r = key % per
        h = ti.Vector([r // (self.nbh * self.nbh), (r // self.nbh) % self.nbh, r % self.nbh])
        return (2 * h + ti.Vector([colour & 1, (colour >> 1) & 1, (colour >> 2) & 1])) * BLOCK

    @ti.kernel
    def sort_blocks(self):
        """Counting sort of the material points by block key, stable in the solver's point order: ``order``,
        ``skey`` (the sorted keys) and ``colour_lo`` (where each colour starts). Deterministic: the chunks count
        and place their points serially, and the offsets are summed in (key, chunk) order."""
        n = self.n_points[None]
        for q, kk in self.hist:
            self.hist[q, kk] = 0
        for p in range(n):
            self.key[p] = self.block_key(p)
        per = (n + SORT_CHUNKS - 1) // SORT_CHUNKS
        for p0 in range(n):   # one iteration per chunk start does the chunk (Taichi splits the loop by points)
            if p0 % per == 0:
                for p in range(p0, ti.min(p0 + per, n)):
                    if self.asleep[self.body[p]] == 0:   # a sleeping body's points are in no block (sleeping.py)
                        self.hist[p0 // per, self.key[p]] += 1
        self.colour_offsets()   # in (key, chunk) order, one thread (ordered.py)
        for p0 in range(n):
            if p0 % per == 0:
                for p in range(p0, ti.min(p0 + per, n)):
                    if self.asleep[self.body[p]] == 0:
                        k = self.key[p]
                        slot = self.hist[p0 // per, k]
                        self.hist[p0 // per, k] = slot + 1
                        self.order[slot] = p
                        self.skey[slot] = k

    @ti.kernel
    def p2g_begin(self):
        """Clear the late-point count; the touched-node box starts at the passive points' box (or empty)."""
        self.n_late[None] = 0
        if ti.static(self.has_passive):
            self.box[0, 0] = self.pbox[0, 0]
            self.box[0, 1] = self.pbox[0, 1]
        else:
            self.box[0, 0] = ti.Vector([self.n_grid, self.n_grid, self.n_grid])
            self.box[0, 1] = ti.Vector([-1, -1, -1])

    @ti.kernel
    def g2p_p2g_colour(self, c: ti.i32, with_g2p: ti.i32):
        """G2P (if ``with_g2p``) and P2G of the blocks of colour ``c``, plain adds into ``grid_mv[0]``.

        One flat loop over the colour's sorted points (Taichi gives each thread a contiguous share of at least
        512 iterations); the iteration at a block's first point does the whole block in sorted order, the
        others nothing. A point more than ``MARGIN`` cells out of its block is marked late."""
        for k0 in range(self.colour_lo[c], self.colour_lo[c + 1]):
            if k0 == self.colour_lo[c] or self.skey[k0] != self.skey[k0 - 1]:
                key = self.skey[k0]
                o = self.block_origin(key)
                bmin = ti.Vector([self.n_grid, self.n_grid, self.n_grid])
                bmax = ti.Vector([-1, -1, -1])
                k = k0
                while k < self.colour_lo[c + 1] and self.skey[k] == key:
                    p = self.order[k]
                    if with_g2p:
                        self.fused_g2p(p)   # a rigid body's points: done before (rigid.py)
                    X = (self.x[p] - self.lo[None]) * self.inv_dx[None]
                    base = ti.cast(ti.floor(X - 0.5), ti.i32)
                    if (base >= o - MARGIN).all() and (base <= o + BLOCK - 1 + MARGIN).all():
                        bmin, bmax = self.p2g_point(p, 0, bmin, bmax)
                    else:
                        self.late[p] = ti.cast(1, ti.i8)
                        ti.atomic_add(self.n_late[None], 1)
                    k += 1
                ti.atomic_min(self.box[0, 0], bmin)
                ti.atomic_max(self.box[0, 1], bmax)

    @ti.kernel
    def p2g_late(self):
        """P2G of the late points, serially in sorted order (after the 8 colours)."""
        if self.n_late[None] > 0:   # not the outermost scope: serial
            bmin = self.box[0, 0]
            bmax = self.box[0, 1]
            for k in range(self.colour_lo[8]):
                p = self.order[k]
                if self.late[p] != 0:
                    self.late[p] = ti.cast(0, ti.i8)
                    bmin, bmax = self.p2g_point(p, 0, bmin, bmax)
            self.box[0, 0] = bmin
            self.box[0, 1] = bmax

    def p2g_coloured(self, with_g2p: int, substep: int) -> None:
        """(G2P and) P2G of one substep in colours: the block sort at a frame's first substep and every
        :data:`SORT_EVERY`, the 8 colour passes, the late points (launched, and compiled, only when one was late)."""
        if substep % SORT_EVERY == 0:
            self.sort_blocks()
        self.p2g_begin()
        for c in range(8):
            self.g2p_p2g_colour(c, with_g2p)
        n_late = int(self.n_late[None])
        if n_late:
            self.p2g_late()
        self.late_points += n_late
