"""The substep taken from the state in :class:`~gasp_taichi_mpm.engine.TaichiMPMEngine` (round 57,
``gasp_core.mpm.state_step``): in a scene with snow whose step is automatic, every substep is followed by a
reduction on the device (per body the smallest ``Jp``, the largest speed of a material point: :func:`state_reduce`,
a top-level parallel loop of atomic mins) read back, and the step (the solver's ``dt`` field) follows snow's
hardening. Such a frame runs ``MPMSolver.substeps(1)``'s substep one at a time (its passive points moved after each;
with colliders, forces or impulses each substep's row of their time table loaded before it (round 59,
``gasp_core.mpm.grid_tables.substep_table``); no rigid bodies there, ``gasp_core.mpm.state_step.applies``)."""

import numpy as np
import taichi as ti

from gasp_core.mpm.grid_tables import substep_table
from gasp_core.mpm.rigid import step_view
from gasp_core.mpm.state_step import StateStep


@ti.kernel
def state_reduce(n: ti.i32, Jp: ti.template(), v: ti.template(), body: ti.template(), out: ti.template()):
    """``out[body[p]] = min(.., Jp[p])`` and ``out[n_bodies] = min(.., -|v[p]|)`` (the largest speed, negated) over
    the first ``n`` points (the material ones), in float64 (atomics: any order gives the same min)."""
    for p in range(n):
        ti.atomic_min(out[body[p]], ti.cast(Jp[p], ti.f64))
        ti.atomic_min(out[out.shape[0] - 1], -ti.cast(v[p].norm(), ti.f64))


class StateClock:
    """Mixed into the engine: :meth:`state_clock` builds its :class:`gasp_core.mpm.state_step.StateStep`,
    :meth:`clock_frame` runs a frame by it."""

    def state_clock(self) -> StateStep:
        """The engine's :class:`StateStep` (``on`` False: the setup's step, nothing here runs)."""
        clock = StateStep(step_view(self.setup), self.options, self.n_substeps, self._state_reduce, self._take_dt)
        if clock.on:
            self._reduced = ti.field(ti.f64, shape=len(self.setup.materials) + 1)   # Jp per body, -|v|
        return clock

    def _state_reduce(self):
        """Per body the smallest ``Jp`` (shape (n_bodies,); ``inf`` where none), the largest material speed (m/s)."""
        s = self.solver
        self._reduced.fill(np.inf)
        state_reduce(self.n_material, s.Jp, s.v, s.body, self._reduced)
        out = self._reduced.to_numpy()   # the one read of the substep
        return out[:-1], max(-float(out[-1]), 0.0)

    def _take_dt(self, dt: float) -> None:
        """Substeps of ``dt`` (s) from the next (rounded once to the working precision, as the build's)."""
        self.dt = dt
        self.solver.dt[None] = dt

    def clock_frame(self) -> None:
        """One frame, its substeps one by one as the state asks (:meth:`StateStep.begin`, :meth:`StateStep.after`)."""
        clock, s = self.clock, self.solver
        clock.begin()
        t0 = self.frame * self.setup.frame_dt   # the frame's start (step_frame counts the frame after)
        while True:   # MPMSolver.substeps(1), the substep's index passed on (the block sort's SORT_EVERY)
            if s.has_extras:   # colliders, forces, impulses: this substep's row of the time table
                s.ex_tab.from_numpy(substep_table(self.setup, t0 + clock.elapsed, clock.dt,
                                                  s.ex_tab.shape[0]).astype(s._ex_np))
                s.ex_step[None] = 0
            s.p2g_substep(0, clock.done)
            s.grid_update()
            s.last_g2p(s._passive_at(1)[-1])
            if clock.after():
                break
        self.n_substeps = clock.n
