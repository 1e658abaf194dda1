"""The substep taken from the state: snow's hardening (round 57; issue 66 item 6 "No energy is gained"; ``docs/mpm.md``
"Time step", ``docs/fracture.md`` "Round 57: snow's step from its state").

The setup's step (:func:`gasp_core.mpm.substeps.mpm_stable_dt`) takes each material's P-wave speed from its constants;
snow's (``Material.p_wave_speed``) assumes its hardening ``h = exp(xi (1 - Jp))`` (Stomakhin et al. 2013) at most
``exp(xi theta_c)``, but ``Jp`` has no lower bound in the model (each return multiplies it by ``det F_trial / det
F_clamped``): the snow block of ``benchmarks/energy_ledger_plastic.py`` thrown down at 2 m/s compacts to ``Jp`` 0.747
(``h`` 12.5) within 10 substeps of its landing, in its first frame, and its points then cross cells at ``(c(h) + |v|)
dt / dx`` = 0.90 (round 56: +6.8 % of its energy gained). :class:`StateStep` takes the step from the state instead,
as Stomakhin et al. 2013 choose theirs (an adaptive CFL step): with the largest hardening over each snow body (its
smallest ``Jp``: ``c = sqrt(h (lambda + 2 mu) / rho)``) and the largest speed of a material point now, ``dt = cfl dx /
(c + v)`` (``cfl_rule`` ``"sum"``; ``"max"``: ``cfl dx / max(c, v)``), ``v`` at least the setup's fall bound. It is
never longer than the setup's step, so a frame takes ``max(n_setup, n_state)`` substeps; it is checked after every
substep (the landing compacts the snow within a frame), and where the state asks a shorter step the rest of the frame
is cut into more substeps (never fewer within a frame; each frame starts again from its state).

Where it acts (:func:`applies`): a scene with a snow body whose step is automatic (no option ``dt`` or
``n_substeps``); the rest keep the setup's step and their bits. With colliders, forces and impulses since round 59
(each substep's row of their time table loaded before it, at the substep's own time and step). Not yet with rigid
bodies (their per-frame state is laid out for a fixed substep count) or the ``deterministic`` option: these keep the
setup's step.
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

from gasp_core.mpm.rigid import rigid_mask
from gasp_core.mpm.substeps import CFL, CFL_RULE, MAX_SUBSTEPS


def applies(setup, opts) -> bool:
    """Whether the step of ``setup`` (the engines' step view) with the options ``opts`` follows its state (module
    notes): a snow body, an automatic step, no rigid body, not deterministic (colliders, forces and impulses since
    round 59: their time table loaded a substep at a time, ``gasp_core.mpm.grid_tables.substep_table``)."""
    if opts.get("dt") is not None or opts.get("n_substeps") is not None or opts.get("deterministic"):
        return False
    return any(m.name == "snow" for m in setup.materials) and not rigid_mask(setup.materials).any()


def snow_speed(m, jp_min: float) -> float:
    """P-wave speed (m/s) of snow ``m`` hardened at ``Jp = jp_min``: ``sqrt(exp(xi (1 - Jp)) (lambda + 2 mu) /
    rho)`` (Stomakhin et al. 2013's moduli ``mu h, lambda h``), at least ``m.p_wave_speed`` (the setup's)."""
    h = math.exp(min(m.hardening * (1.0 - float(jp_min)), 700.0))
    return max(math.sqrt(h * (m.lam + 2.0 * m.mu) / m.rho), m.p_wave_speed)


class StateStep:
    """The substep of each part of a frame, from the state (module notes).

    Parameters
    ----------
    setup : SimSetup
        The engine's step view (``gasp_core.mpm.rigid.step_view``).
    opts : dict
        The engine options (``cfl``, ``cfl_rule``, ``max_substeps``).
    n_setup : int
        The setup's substeps a frame (``gasp_core.mpm.grid_engine.choose_dt``): the fewest a frame takes.
    reduce : callable
        ``reduce() -> (jp_min, v_max)``: per body the smallest ``Jp`` of its points (shape (n_bodies,), 1 or more
        where it has none) and the largest speed of a material point (m/s), a parallel reduction on the device.
    apply : callable
        ``apply(dt)``: the engine takes the substep ``dt`` (s) from its next substep.
    """

    def __init__(self, setup, opts, n_setup: int, reduce: Callable, apply: Callable):
        self.on = applies(setup, opts)
        self.frame_dt, self.dx = float(setup.frame_dt), float(setup.dx)
        self.n_setup, self.dt_setup = n_setup, float(setup.frame_dt) / n_setup
        self.cfl, self.rule = float(opts.get("cfl") or CFL), opts.get("cfl_rule") or CFL_RULE
        self.bound = opts.get("max_substeps") or MAX_SUBSTEPS
        self.snow = [(b, m) for b, m in enumerate(setup.materials) if m.name == "snow"]
        g = float(np.linalg.norm(setup.gravity))
        v0 = float(np.max(np.linalg.norm(setup.v, axis=1))) if len(setup.v) else 0.0
        self.v_fall = v0 + math.sqrt(2.0 * g * max(float(setup.domain_hi[2] - setup.domain_lo[2]), 0.0))
        self.reduce, self.apply = reduce, apply
        self.dt, self.n, self.done, self.elapsed = self.dt_setup, n_setup, 0, 0.0
        self.frames: list[int] = []   # the substeps each frame took (``EngineInfo``, the benchmarks)

    def dt_state(self, jp_min, v_max: float) -> float:
        """The step the state asks (s): ``cfl dx / (c + v)`` over the snow bodies (``"max"``: ``/ max(c, v)``),
        ``c`` :func:`snow_speed` at the body's ``jp_min``, ``v`` the larger of ``v_max`` and the setup's fall bound."""
        v = max(float(v_max), self.v_fall)
        c = max(snow_speed(m, jp_min[b]) for b, m in self.snow)
        dt = self.cfl * self.dx / max(c + v if self.rule == "sum" else max(c, v), 1e-12)
        return dt if math.isfinite(dt) else self.dt_setup   # a non-finite state: the frame's checks report it

    def _take(self, rest: float, dt_need: float) -> None:
        """Cut the ``rest`` of the frame (s) into whole substeps no longer than ``dt_need``; raises
        :class:`gasp_core.errors.EngineDivergence` (cause unstable) where the frame would take more than the engine
        option ``max_substeps``."""
        n_rest = max(1, math.ceil(rest / dt_need - 1e-9))
        if self.done + n_rest > self.bound:
            from gasp_core.errors import EngineDivergence
            from gasp_core.seam.runner import CAUSE_UNSTABLE
            raise EngineDivergence(
                f"snow's hardening asks a substep of {dt_need:.3g} s ({self.done + n_rest} substeps in this frame of "
                f"{self.frame_dt:g} s), more than max_substeps = {self.bound}: raise the engine option max_substeps, "
                "or lower the snow's hardening or E", len(self.frames) + 1, CAUSE_UNSTABLE)
        self.n, self.dt = self.done + n_rest, rest / n_rest
        self.apply(self.dt)

    def begin(self) -> int:
        """Start a frame: its substeps from the state (at least the setup's); returns how many (the state may add
        more after a substep, :meth:`after`)."""
        self.done, self.elapsed = 0, 0.0
        if not self.on:
            return self.n
        self._take(self.frame_dt, min(self.dt_state(*self.reduce()), self.dt_setup))   # at least n_setup substeps
        return self.n

    def after(self) -> bool:
        """After a substep: True where the frame is done; else, where the state asks a shorter step than the one taken,
        the rest of the frame is cut into more, shorter substeps (:meth:`_take`)."""
        self.done += 1
        self.elapsed += self.dt
        if self.done >= self.n:
            self.frames.append(self.n)
            return True
        if self.on:
            dt_need = self.dt_state(*self.reduce())
            if dt_need < self.dt * (1.0 - 1e-9):
                self._take(self.frame_dt - self.elapsed, dt_need)
        return False

