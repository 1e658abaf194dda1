"""A frame's checks on the device (:class:`FrameChecks`, a mixin of :class:`gasp_taichi_mpm.solver.MPMSolver`): the
out-of-grid counter of the substeps and, on the GPU schedule, the finite tests of every point and the in-grid
tests of the material points counted
where the points are, so a frame reads back four integers instead of running NumPy over every point.
"""
import taichi as ti


class FrameChecks:
    """The kernels of a frame's checks (module docstring)."""

    @ti.kernel
    def reset_out(self):
        self.n_out[None] = 0

    @ti.kernel
    def check_points(self):
        """The frame's checks on the device (GPU schedule: one small read a frame instead of NumPy over every
        point): ``bad`` = [points with a non-finite x or v, the first of them, material points whose stencil
        leaves the grid, the first of them] (solver order; ``n`` when none)."""
        self.bad[0], self.bad[1], self.bad[2], self.bad[3] = 0, self.n_total[None], 0, self.n_total[None]
        for p in range(self.n_total[None]):
            x, v = self.x[p], self.v[p]
            finite = True
            for d in ti.static(range(3)):
                if ti.math.isnan(x[d]) or ti.math.isinf(x[d]) or ti.math.isnan(v[d]) or ti.math.isinf(v[d]):
                    finite = False
            if not finite:
                ti.atomic_add(self.bad[0], 1)
                ti.atomic_min(self.bad[1], p)
            elif p < self.n_material:   # the material points (first): a passive one out drops out (blow_up_rows)
                base = ti.floor((x - self.lo[None]) * self.inv_dx[None] - 0.5, ti.i32)
                if (base < 0).any() or (base > self.n_grid - 3).any():
                    ti.atomic_add(self.bad[2], 1)
                    ti.atomic_min(self.bad[3], p)

    def positions_setup_order(self, order) -> "np.ndarray":
        """The positions (n, 3) in the setup's order, permuted on the device (GPU schedule: the host's NumPy scatter
        of 16M rows took longer than the frame's GPU work): row ``p`` of the solver goes to ``order[p]``
        (:meth:`gasp_core.mpm.grid_engine.GridEngineBase.to_setup_order`'s ``out[order] = x``)."""
        if not hasattr(self, "x_setup"):
            import numpy as np
            self.x_setup = ti.Vector.field(3, self.real, shape=self.x.shape[0])
            self.setup_row = ti.field(ti.i32, shape=self.x.shape[0])
            rows = np.zeros(self.x.shape[0], np.int32)
            rows[:self.n] = order
            self.setup_row.from_numpy(rows)
        self._to_setup_order()
        return self.x_setup.to_numpy()[:self.n]

    @ti.kernel
    def _to_setup_order(self):
        for p in range(self.n_total[None]):
            self.x_setup[self.setup_row[p]] = self.x[p]

    @ti.kernel
    def _init_box(self):
        for t in range(self.n_chunks):
            self.box[t, 0] = ti.Vector([self.n_grid, self.n_grid, self.n_grid])
            self.box[t, 1] = ti.Vector([-1, -1, -1])
