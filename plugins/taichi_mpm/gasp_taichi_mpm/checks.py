"""A frame's checks on the device (:class:`FrameChecks`, a mixin of :class:`gasp_taichi_mpm.solver.MPMSolver`): the
out-of-grid counter of the substeps and, on the GPU schedule, the finite and in-grid tests of every point counted
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
        point): ``bad`` = [points with a non-finite x or v, the first of them, points whose stencil leaves the grid,
        the first of them] (solver order; ``n`` when none)."""
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
            else:
                base = ti.floor((x - self.lo[None]) * self.inv_dx[None] - 0.5, ti.i32)
                if (base < 0).any() or (base > self.n_grid - 3).any():
                    ti.atomic_add(self.bad[2], 1)
                    ti.atomic_min(self.bad[3], p)

    @ti.kernel
    def _init_box(self):
        for t in range(self.n_chunks):
            self.box[t, 0] = ti.Vector([self.n_grid, self.n_grid, self.n_grid])
            self.box[t, 1] = ti.Vector([-1, -1, -1])
