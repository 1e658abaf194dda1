"""The substep taken from the state in :class:`~gasp_warp_mpm.engine.WarpMPMEngine` (round 57,
``gasp_core.mpm.state_step``): in a scene with snow whose step is automatic, every substep is followed by a
reduction on the device (per body the smallest ``Jp``, the largest speed of a material point: atomic min and max,
:func:`build_state_reduce`) read back, and the step follows snow's hardening. Such a frame runs its substeps one by one
(no CUDA graph: their number is known only as they run), the passive points moved after every substep; the
launches are recorded again when the step changes. With colliders, forces or impulses each substep's row of their
time table is loaded before it (round 59, ``gasp_core.mpm.grid_tables.substep_table``)."""

import functools

import numpy as np
import warp as wp

from gasp_core.mpm.grid_tables import substep_table
from gasp_core.mpm.rigid import step_view
from gasp_core.mpm.state_step import StateStep

from .precision import MODULE_OPTIONS, build_types


@functools.cache
def build_state_reduce(Ft):
    """``state_reduce(Jp, v, body, out)``, one thread a material point: ``out[body[p]] = min(.., Jp[p])`` and
    ``out[n_bodies] = min(.., -|v[p]|)`` (the largest speed, negated; Warp's atomics: any order gives the same min)."""
    vec3 = build_types(Ft)[0]

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def state_reduce(Jp: wp.array(dtype=Ft), v: wp.array(dtype=vec3), body: wp.array(dtype=wp.int32),
                     out: wp.array(dtype=Ft)):
        p = wp.tid()
        wp.atomic_min(out, body[p], Jp[p])
        wp.atomic_min(out, out.shape[0] - 1, -wp.length(v[p]))

    return state_reduce


class StateClock:
    """Mixed into the engine: :meth:`state_clock` builds its :class:`gasp_core.mpm.state_step.StateStep`,
    :meth:`clock_frame` runs a frame by it."""

    def state_clock(self, Ft) -> StateStep:
        """The engine's :class:`StateStep` (``on`` False: the setup's step, nothing here runs)."""
        nb = len(self.setup.materials)
        clock = StateStep(step_view(self.setup), self.options, self.n_substeps, self._state_reduce, self._take_dt)
        if clock.on:
            self._reduce_k = build_state_reduce(Ft)
            self._reduced = wp.zeros(nb + 1, dtype=Ft, device=self.device)   # Jp per body, -|v|
            self._dt_recorded = None   # recorded for one substep: the passive points moved after every substep
            self._take_dt(self.dt)
        return clock

    def _state_reduce(self) -> tuple[np.ndarray, float]:
        """Per body the smallest ``Jp`` (shape (n_bodies,); ``inf`` where none), the largest material speed (m/s)."""
        self._reduced.fill_(np.inf)
        wp.launch(self._reduce_k, dim=self.n_material, device=self.device,
                  inputs=[self.Jp, self.v, self.body, self._reduced])
        out = self._reduced.numpy().astype(np.float64)   # the one read of the substep
        return out[:-1], max(-float(out[-1]), 0.0)

    def _take_dt(self, dt: float) -> None:
        """Substeps of ``dt`` (s) from the next: the launches recorded again when it changed."""
        self.dt = dt
        if dt != self._dt_recorded and self.n_points:
            n, self.n_substeps = self.n_substeps, 1
            self._record_launches(*self._recorded)
            self.n_substeps, self._dt_recorded = n, dt

    def clock_frame(self) -> None:
        """One frame, its substeps one by one as the state asks (:meth:`StateStep.begin`, :meth:`StateStep.after`)."""
        clock = self.clock
        clock.begin()
        t0 = (self.frame - 1) * self.setup.frame_dt   # the frame's start (step_frame counts the frame first)
        while True:
            if self._ex_tables is not None:   # colliders, forces, impulses: this substep's row of the time table
                self._ex.tab.assign(substep_table(self.setup, t0 + clock.elapsed, clock.dt,
                                                  self._ex.tab.shape[0]).astype(self._np_dtype))
                self._ex.step.zero_()
            self._substep(0)   # the launches recorded for one substep (_take_dt)
            if clock.after():
                break
        self.n_substeps = clock.n
