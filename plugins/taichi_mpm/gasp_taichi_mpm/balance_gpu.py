"""The contact's balance on the GPU schedule (:mod:`gasp_taichi_mpm.schedule`), a mixin of
:class:`gasp_taichi_mpm.solver.MPMSolver` beside :class:`gasp_taichi_mpm.balance.Balance`, whose per-point, per-node
and per-support funcs it maps (``moment_terms``, ``shift_body``, ``node_terms``, ``body_fix``, ``apply_fix``): the same
sums with every loop parallel. The moments over slices of ``m_slice`` points summed by a fixed tree; the fix with no
list and no sort: the marked nodes listed in node order by count, scan and scatter, their terms summed per support
over chunks of :data:`FR_CHUNK` list entries by a fixed tree, then applied one thread a node.
"""
import taichi as ti

from .balance import N_NODE_TERMS
from .schedule.primitives import BoxCompaction, SliceSums, slice_points

#: Listed contact nodes a chunk of the fix's sums holds.
FR_CHUNK = 64


class BalanceGPU:
    """The GPU schedule's kernels of the balance (module docstring)."""

    def fix_contact(self) -> None:
        """The balance's fix in the grid update, before the holds (:mod:`gasp_taichi_mpm.balance`), on the run's
        schedule; nothing without a balance."""
        if not self.n_spin:
            return
        if self.gpu:
            self.contact_fix_gpu()
        else:
            self.contact_fix()

    def allocate_balance_gpu(self, nb: int, ns: int) -> None:
        """Slice sums of the moments (``nb`` bodies) and of the fix (``ns`` supports), the node list and its
        compaction."""
        cap = self.x.shape[0]
        self.m_slice = slice_points(cap, nb * 19)
        self.moments = SliceSums(-(-cap // self.m_slice), nb * 19)
        self.fr_list = ti.Vector.field(3, ti.i32, shape=self.fr_nodes.shape[0])
        self.fr_comp = BoxCompaction(self, self.n_grid, (self.fr_list,))
        self.fr_parts = SliceSums(-(-self.fr_list.shape[0] // FR_CHUNK), ns * N_NODE_TERMS)

    @ti.func
    def listed(self, I, q: ti.template()):
        """A node the contact marked (:class:`gasp_taichi_mpm.schedule.primitives.BoxCompaction`'s test)."""
        return self.grid_fbody[I] >= 0

    @ti.func
    def overflow(self, I, q: ti.template()):
        self.grid_fbody[I] = -1   # past the list's capacity: left out of the fix, as balance_node does

    @ti.kernel
    def contact_moments_gpu(self):
        """:meth:`contact_moments` and :meth:`contact_shift` on the GPU schedule: slices of ``m_slice`` points, one
        thread a slice, into ``moments.part``; their fixed-tree sums per body into ``c_shift``."""
        n = self.n_points[None]
        D = ti.cast(0.25 * self.dx[None] * self.dx[None], ti.f64)
        nt = (n + self.m_slice - 1) // self.m_slice
        self.moments.clear(nt)
        for t in range(nt):
            acc = ti.Vector.zero(ti.f64, 19)
            cur = -1
            for p in range(t * self.m_slice, ti.min(t * self.m_slice + self.m_slice, n)):
                b = self.body[p]
                if b != cur:
                    if cur >= 0:
                        for q in ti.static(range(19)):
                            self.moments.part[t, cur * 19 + q] += acc[q]
                    acc = ti.Vector.zero(ti.f64, 19)
                    cur = b
                if self.asleep[b] == 0:
                    acc += self.moment_terms(p, D)
            if cur >= 0:
                for q in ti.static(range(19)):
                    self.moments.part[t, cur * 19 + q] += acc[q]
        self.moments.reduce(nt)
        for b in range(self.n_spin):
            sums = ti.Vector.zero(ti.f64, 19)
            for q in ti.static(range(19)):
                sums[q] = self.moments.out[b * 19 + q]
            self.shift_body(b, sums)

    @ti.kernel
    def contact_fix_gpu(self):
        """:meth:`contact_fix` on the GPU schedule: the marked nodes listed in node order (flag, scan, scatter), their
        terms summed per support over chunks of :data:`FR_CHUNK` entries by a fixed tree, each support's fix, then
        each node moved: every loop parallel, no sort, no atomics on the sums."""
        ng = self.n_grid
        self.fr_comp.run(ti.Vector([0, 0, 0]), ti.Vector([ng, ng, ng]))
        n = ti.min(self.fr_comp.count[0], self.fr_list.shape[0])
        nch = (n + FR_CHUNK - 1) // FR_CHUNK
        self.fr_parts.clear(nch)
        for ch in range(nch):
            for k in range(ch * FR_CHUNK, ti.min(ch * FR_CHUNK + FR_CHUNK, n)):
                I = self.fr_list[k]
                b = self.grid_fbody[I]
                t = self.node_terms(I)
                for q in ti.static(range(N_NODE_TERMS)):
                    self.fr_parts.part[ch, b * N_NODE_TERMS + q] += t[q]
        self.fr_parts.reduce(nch)
        for s in range(self.n_slots):
            for q in ti.static(range(N_NODE_TERMS)):
                self.fr_sums[s, q] = self.fr_parts.out[s * N_NODE_TERMS + q]
            self.body_fix(s)
        for k in range(n):
            self.apply_fix(self.fr_list[k])
        for s in range(self.n_slots):
            for q in ti.static(range(26)):
                self.fr_sums[s, q] = 0.0
            self.clear_box(s)
