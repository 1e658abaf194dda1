"""The CPU schedule's ordered loops (issue 65, :mod:`gasp_taichi_mpm.schedule`): every ``ti.loop_config(serialize=
True)``, ``block_dim=1`` and one-thread sort of taichi_mpm lives here, and only the CPU schedule (``self.gpu`` False)
launches or inlines it. Each fixes the order of a float sum (or of a list the sums read), so the CPU schedule's
frames repeat bit for bit on any thread count; on a GPU each would be one GPU thread (issue 65: 7.7 s a frame on an
H100), so the GPU schedule runs the parallel variant named beside each, in the topic's own module.

- :meth:`OrderedCPU.rigid_reduce` (GPU: ``Rigid.rigid_reduce_gpu``) and :meth:`OrderedCPU.rigid_depth` (GPU:
  ``RigidLift.rigid_depth_gpu``): the rigid bodies' momenta and plane depths, summed serially in the point order;
- :meth:`OrderedCPU.contact_moments`, :meth:`OrderedCPU.contact_shift` (GPU: ``BalanceGPU.contact_moments_gpu``) and
  :meth:`OrderedCPU.contact_fix` (GPU: ``BalanceGPU.contact_fix_gpu``): the balance's sums (:mod:`..balance`);
- :meth:`OrderedCPU.p2g_chunks`: the chunked P2G's chunks, one thread a chunk (GPU: atomic P2G,
  :meth:`gasp_taichi_mpm.transfers.Transfers.g2p_p2g`);
- :meth:`OrderedCPU.colour_offsets`: the coloured P2G's block offsets (:mod:`.coloured`, a CPU-only P2G);
- :func:`sum_in_order`: a list of partial sums added in order (the viscous CG's dots; GPU: a
  :class:`~gasp_taichi_mpm.schedule.primitives.SliceSums` tree, :mod:`gasp_taichi_mpm.viscosity`).

``plugins/taichi_mpm/tests/test_taichi_schedule.py`` checks that no other module of taichi_mpm holds such a loop (by the source's syntax
tree) and that no GPU-schedule substep compiles one (by a spy on ``ti.loop_config``).
Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields it reads.
"""
import taichi as ti

from .coloured import SORT_CHUNKS

#: Slices of the points the balance's moments run over (each summed serially on one thread into its own row of
#: ``c_part``; the rows are then added in slice order, so the sums do not depend on which thread finished first).
N_PARTS = 64


@ti.func
def sum_in_order(part: ti.template(), n_parts):
    """``part[0] + part[1] + ... + part[n_parts - 1]`` added in this order on one thread (``part`` a scalar field)."""
    total = ti.cast(0.0, part.dtype)
    ti.loop_config(serialize=True)
    for q in range(n_parts):
        total += part[q]
    return total


class OrderedCPU:
    """The CPU schedule's ordered kernels and funcs (module docstring)."""

    @ti.kernel
    def rigid_reduce(self):
        """Each rigid body's momentum and angular momentum about the origin into ``rb_acc`` (with the hold's
        impulses, ``rigid_hold.py``), summed serially in the point order (:mod:`gasp_taichi_mpm.rigid`)."""
        for b in range(self.n_bodies):
            self.rb_acc[b] = self.held(b)   # the hold's impulses since the last projection (rigid_hold.py)
        quarter = 0.25 * ti.cast(self.dx[None], ti.f64) ** 2
        ti.loop_config(serialize=True)
        for p in range(self.n_points[None]):
            b = self.body[p]
            if self.rb_rigid[b] != 0:
                self.rb_acc[b] += self.rigid_terms(p, quarter)

    @ti.kernel
    def rigid_depth(self):
        """Per rigid body and plane of the particle contact its deepest point's penetration ``offset + skin - n . x``
        (m) and the penetration-weighted sum of its touching points (serially in the point order, as
        :meth:`rigid_reduce`; warp_mpm's ``rigid_depth``; :mod:`gasp_taichi_mpm.rigid_lift`)."""
        ti.loop_config(serialize=True)
        for p in range(self.n_points[None]):
            self.depth_point(p, 0, False)

    @ti.kernel
    def contact_moments(self):
        """Per slice of the points and per body into ``c_part``: mass, first and second mass moments, momentum,
        angular momentum (columns ``gasp_core.mpm.contact.SUMS``; the normal impulse's columns stay 0: P2G sums
        them into ``c_jsums``). No atomics: a slice is one thread's; :meth:`contact_shift` adds the slices in order."""
        n = self.n_points[None]
        D = ti.cast(0.25 * self.dx[None] * self.dx[None], ti.f64)
        ti.loop_config(block_dim=1)
        for t in range(N_PARTS):
            acc = ti.Vector.zero(ti.f64, 19)
            cur = -1
            for p in range(t * n // N_PARTS, (t + 1) * n // N_PARTS):
                b = self.body[p]
                if b != cur:
                    if cur >= 0:
                        for q in ti.static(range(19)):
                            self.c_part[t, cur, q] += acc[q]
                    acc = ti.Vector.zero(ti.f64, 19)
                    cur = b
                if self.asleep[b] == 0:   # a sleeping body has no moments (sleeping.py)
                    acc += self.moment_terms(p, D)
            if cur >= 0:
                for q in ti.static(range(19)):
                    self.c_part[t, cur, q] += acc[q]

    @ti.kernel
    def contact_shift(self):
        """Per body: the slices' sums added in slice order (``c_part`` cleared), then into ``c_shift``: ``c``, ``V``,
        ``omega``, ``I^-1``."""
        for b in range(self.n_spin):
            sums = ti.Vector.zero(ti.f64, 19)
            for q in ti.static(range(19)):
                for t in range(N_PARTS):
                    sums[q] += self.c_part[t, b, q]
                    self.c_part[t, b, q] = 0.0
            self.shift_body(b, sums)

    @ti.func
    def sort_listed(self):
        """The listed nodes in node order (a serial Shell sort; the list is filled by threads in any order, and
        ``Balance.sum_node``'s float64 sums must not depend on it)."""
        n = ti.min(self.fr_nodes[0][0], self.fr_nodes.shape[0] - 1)
        ng = self.n_grid
        gap = 1
        while gap * 3 + 1 < n:
            gap = gap * 3 + 1
        while gap > 0:
            for i in range(gap, n):
                I = self.fr_nodes[i + 1]
                key = (I[0] * ng + I[1]) * ng + I[2]
                j = i
                while j >= gap:
                    J = self.fr_nodes[j - gap + 1]
                    if (J[0] * ng + J[1]) * ng + J[2] <= key:
                        break
                    self.fr_nodes[j + 1] = J
                    j -= gap
                self.fr_nodes[j + 1] = I
            gap = gap // 3

    @ti.kernel
    def contact_fix(self):
        """Each support's listed nodes summed, then moved by ``dv + alpha x (X - x_m)``; the sums and the list
        cleared (``Balance.sum_node``, ``body_fix``, ``apply_fix``)."""
        self.sort_listed()
        ti.loop_config(serialize=True)
        for s in range(ti.min(self.fr_nodes[0][0], self.fr_nodes.shape[0] - 1)):
            self.sum_node(self.fr_nodes[s + 1])
        ti.loop_config(serialize=True)
        for s in range(self.n_slots):
            self.body_fix(s)
        ti.loop_config(serialize=True)
        for s in range(ti.min(self.fr_nodes[0][0], self.fr_nodes.shape[0] - 1)):
            self.apply_fix(self.fr_nodes[s + 1])
        ti.loop_config(serialize=True)
        for s in range(self.n_slots):
            for q in ti.static(range(26)):
                self.fr_sums[s, q] = 0.0
            self.clear_box(s)
        self.fr_nodes[0][0] = 0

    @ti.func
    def p2g_chunks(self, with_g2p):
        """The chunked P2G (``Transfers.g2p_p2g`` without ``atomic``): chunk t's points, one thread a chunk, into
        its private grid copy; the node box they touched into ``box[t]``."""
        ti.loop_config(block_dim=1)
        for t in range(self.n_chunks):
            bmin = ti.Vector([self.n_grid, self.n_grid, self.n_grid])
            bmax = ti.Vector([-1, -1, -1])
            if ti.static(self.has_passive):   # nodes the passive points will read
                bmin, bmax = self.pbox[t, 0], self.pbox[t, 1]
            for p in range(self.chunk_lo[t], self.chunk_hi[t]):
                if self.asleep[self.body[p]] == 0:
                    if with_g2p:
                        self.fused_g2p(p)   # a rigid body's points: done before (rigid.py)
                    bmin, bmax = self.p2g_point(p, t, bmin, bmax)
            self.box[t, 0] = bmin
            self.box[t, 1] = bmax

    @ti.func
    def colour_offsets(self):
        """The coloured P2G's counting sort (``ColouredP2G.sort_blocks``): each (chunk, key) count in ``hist``
        made its first slot, in (key, chunk) order on one thread; ``colour_lo`` where each colour starts."""
        off = 0
        per_colour = self.nbh * self.nbh * self.nbh
        ti.loop_config(serialize=True)
        for kk in range(self.n_keys):
            if kk % per_colour == 0:
                self.colour_lo[kk // per_colour] = off
            for q in range(SORT_CHUNKS):
                c = self.hist[q, kk]
                self.hist[q, kk] = off
                off += c
        self.colour_lo[8] = off
