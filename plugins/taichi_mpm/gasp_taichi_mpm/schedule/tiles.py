"""The GPU schedule's P2G on CUDA: tiles in shared memory (issue 65; the design of Gao et al. 2018 and
taichi_elements, built here on Taichi's ``ti.simt.block`` shared arrays).

The atomic P2G adds each point's 27 stencil nodes to the global grid: 27 x (4 to 9) float atomics a point, 77 % of an
H100's time on a 1M-point block (docs/performance.md). Here, every substep:

1. :meth:`TileP2G.g2p_keys`: G2P (as the fused kernel), then each point's block of ``TILE_BLOCK^3`` nodes (of its
   stencil base) and its rank in the block (an integer atomic);
2. :meth:`TileP2G.scan_keys`: each block's first slot and the list of non-empty blocks, by a two-level scan
   (:data:`SCAN_CHUNK` blocks a thread, then the chunks before each one summed in order: no atomics, no serial loop
   over the grid), and the points placed in block order;
3. :meth:`TileP2G.p2g_tiles`: one CUDA thread block a non-empty grid block:
   its points add their stencils into a shared-memory tile of ``(TILE_BLOCK + 2)^3`` nodes, then the tile's nonzero
   nodes are added to the global grid, one atomic a node and channel.

A point still outside its tile (only one outside the grid, which P2G counts) takes the atomic path. The sums are
those of the atomic P2G in another order (float atomics on CUDA repeat to rounding, docs/performance.md). Shared
arrays exist on CUDA only: the CPU (and the GPU schedule on ``ti.cpu``) keeps the atomic P2G; the tiles are tested
on a lent GPU (``benchmarks/gpu_checks.py``, the grids of both P2Gs compared).
"""
import taichi as ti

#: Nodes a side of a tile's block: a point is filed under the block of its stencil base ``floor(X - 0.5)``.
TILE_BLOCK = 4
#: Nodes a side of a tile: the block and the stencil's reach of 2 beyond it.
TILE = TILE_BLOCK + 2
#: Threads of a CUDA block (one tile).
TILE_THREADS = 128
#: Blocks one thread of the scan walks.
SCAN_CHUNK = 256


class TileP2G:
    """The tiled P2G (module notes). Needs ``allocate_tiles`` and the solver's fields."""

    def allocate_tiles(self, sort_every: int = 1) -> None:
        """The sort's fields: per point its block key and rank, the points in block order, per block its count and
        first slot, the non-empty blocks' list; the points are sorted every ``sort_every`` substeps."""
        self.tile_sort_every = max(1, int(sort_every))
        cap = self.x.shape[0]
        self.nb_tile = (self.n_grid + TILE_BLOCK - 1) // TILE_BLOCK
        self.n_tile_keys = self.nb_tile ** 3
        self.n_scan = (self.n_tile_keys + SCAN_CHUNK - 1) // SCAN_CHUNK
        self.t_key, self.t_rank, self.t_order = (ti.field(ti.i32, shape=cap) for _ in range(3))
        self.t_count, self.t_lo, self.t_active = (ti.field(ti.i32, shape=self.n_tile_keys) for _ in range(3))
        self.t_chunk = ti.Vector.field(2, ti.i32, shape=self.n_scan)   # per scan chunk: points, non-empty blocks
        self.t_n_active = ti.field(ti.i32, shape=())

    @ti.func
    def tile_key(self, p):
        """The block of point p's stencil base (clamped into the grid), as ``(bx nb + by) nb + bz``."""
        X = (self.x[p] - self.lo[None]) * self.inv_dx[None]
        bi = ti.min(ti.max(ti.cast(ti.floor(X - 0.5), ti.i32), 0), self.n_grid - 1) // TILE_BLOCK
        return (bi[0] * self.nb_tile + bi[1]) * self.nb_tile + bi[2]

    @ti.kernel
    def g2p_keys(self, with_g2p: ti.i32):
        """G2P (if ``with_g2p``; a rigid body's points had theirs) and each awake point's block and rank."""
        for q in range(self.n_tile_keys):
            self.t_count[q] = 0
        for p in range(self.n_points[None]):
            key = -1
            if self.asleep[self.body[p]] == 0:   # a sleeping body's points: no transfer (sleeping.py)
                if with_g2p:
                    self.fused_g2p(p)
                key = self.tile_key(p)
                self.t_rank[p] = ti.atomic_add(self.t_count[key], 1)
            self.t_key[p] = key

    @ti.kernel
    def scan_keys(self):
        """Each block's first slot (``t_lo``), the non-empty blocks in key order (``t_active``, ``t_n_active``) and
        the points in block order (``t_order``): per chunk its totals, then per chunk the chunks before it summed in
        order."""
        for c in range(self.n_scan):
            tot = ti.Vector([0, 0])
            for q in range(c * SCAN_CHUNK, ti.min((c + 1) * SCAN_CHUNK, self.n_tile_keys)):
                n = self.t_count[q]
                tot += ti.Vector([n, 1 if n > 0 else 0])
            self.t_chunk[c] = tot
        for c in range(self.n_scan):
            off = ti.Vector([0, 0])
            for c2 in range(c):
                off += self.t_chunk[c2]
            for q in range(c * SCAN_CHUNK, ti.min((c + 1) * SCAN_CHUNK, self.n_tile_keys)):
                n = self.t_count[q]
                self.t_lo[q] = off[0]
                if n > 0:
                    self.t_active[off[1]] = q
                off += ti.Vector([n, 1 if n > 0 else 0])
            if c == self.n_scan - 1:
                self.t_n_active[None] = off[1]
        for p in range(self.n_points[None]):   # the points in block order
            key = self.t_key[p]
            if key >= 0:
                self.t_order[self.t_lo[key] + self.t_rank[p]] = p

    @ti.func
    def tile_point(self, p, o, pad: ti.template()):
        """P2G of point p into the tile of origin node ``o`` (shared array ``pad``, ``TILE^3`` nodes x channels);
        a point outside it takes the atomic path."""
        base, fx, ok = self.base_fx(self.x[p])
        if ok and (base >= o).all() and (base < o + TILE_BLOCK).all():
            mv0, A, S, m, jvec, eta_v, budget = self.p2g_prep(p, base, fx)
            w = self.weights(fx)
            r = base - o
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                val = (w[i][0] * w[j][1] * w[k][2]) * self.node_val(i, j, k, fx, mv0, A, S, m, jvec, eta_v, budget)
                s = (((r[0] + i) * TILE + r[1] + j) * TILE + r[2] + k) * self.acc_width
                for c in ti.static(range(self.acc_width)):
                    ti.atomic_add(pad[s + c], val[c])
        else:
            self.p2g_point(p, 0, ti.Vector([0, 0, 0]), ti.Vector([0, 0, 0]))

    @ti.func
    def tile_origin(self, key):
        """The first node of block ``key`` (:meth:`tile_key`)."""
        b = ti.Vector([key // (self.nb_tile * self.nb_tile), (key // self.nb_tile) % self.nb_tile, key % self.nb_tile])
        return b * TILE_BLOCK

    @ti.func
    def tile_flush(self, o, s, pad: ti.template()):
        """Tile node ``s`` (of ``TILE^3``, x-major) of the tile at ``o`` added to ``grid_mv[0]``, its nonzero channels
        one atomic each."""
        node = o + ti.Vector([s // (TILE * TILE), (s // TILE) % TILE, s % TILE])
        if (node < self.n_grid).all():
            for c in ti.static(range(self.acc_width)):
                val = pad[s * self.acc_width + c]
                if val != 0.0:
                    ti.atomic_add(self.grid_mv[0, node][c], val)

    @ti.kernel
    def p2g_tiles(self):
        """One CUDA block a non-empty grid block: its points' stencils summed in a shared-memory tile, then added to
        ``grid_mv[0]``. CUDA only (``ti.simt.block``)."""
        ti.loop_config(block_dim=TILE_THREADS)
        for g in range(self.t_n_active[None] * TILE_THREADS):
            tid = g % TILE_THREADS
            key = self.t_active[g // TILE_THREADS]
            pad = ti.simt.block.SharedArray((TILE * TILE * TILE * self.acc_width,), self.real)
            s = tid
            while s < TILE * TILE * TILE * self.acc_width:
                pad[s] = 0.0
                s += TILE_THREADS
            ti.simt.block.sync()
            o = self.tile_origin(key)
            k = self.t_lo[key] + tid
            while k < self.t_lo[key] + self.t_count[key]:
                self.tile_point(self.t_order[k], o, pad)
                k += TILE_THREADS
            ti.simt.block.sync()
            s = tid
            while s < TILE * TILE * TILE:
                self.tile_flush(o, s, pad)
                s += TILE_THREADS
            ti.simt.block.sync()   # a CUDA block takes its next tile (grid-stride) only once this one is flushed

    @ti.kernel
    def g2p_awake(self):
        """G2P of the awake points (a rigid body's points had theirs), between two sorts."""
        for p in range(self.n_points[None]):
            if self.asleep[self.body[p]] == 0:
                self.fused_g2p(p)

    def p2g_tiled(self, with_g2p: int, substep: int = 0) -> None:
        """(G2P and) P2G of one substep by tiles: three launches; two (G2P, then the tiles on the last sort's lists)
        on the substeps between sorts, which come at a frame's first substep and every ``tile_sort_every``-th
        (a point that has left its block since takes the atomic path: the same sums)."""
        if with_g2p == 0 or substep % self.tile_sort_every == 0:
            self.g2p_keys(with_g2p)
            self.scan_keys()
        else:
            self.g2p_awake()
        self.p2g_tiles()
