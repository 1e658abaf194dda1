"""The trapezoidal stress (round 69, issue 66 item 6 "No energy is gained"; docs/fracture.md "Round 69"): the engine
option ``stress_at = "trapezoid"``, off by default. The implicit midpoint (Newmark's average acceleration) of the
elastic step, converged by fixed-point passes:

- the increment: ``F_{n+1} = (I + dt C_avg) F_n``, ``C_avg = (C_n + C_{n+1}) / 2``, the mean of the point's velocity
  gradients at the substep's start and end (the P2G of substep ``n + 1`` advances ``F`` by the mean of its ``C`` and
  the one the point had at the P2G before, kept in ``C_prev``; the positions still move by the end velocity: the
  difference ``dt / 2 (C_{n+1} - C_n)`` telescopes over the run, so ``F`` and the positions differ by ``dt/2`` of a
  gradient, never more);
- the stress: the symmetric part of the work-conjugate stress of that increment's midpoint, ``tau(H F_n) H^-T``
  with ``H = I + dt/2 C_avg`` (round 71: its antisymmetric part is a torque; mid_stress.py's ``SYMMETRIC``), where
  ``C_{n+1}`` is the guess ``C_guess``: pass 0 takes ``C_n`` (round 68's "mid"), each further pass the ``C``
  gathered by the pass before, a trial substep from the saved state (the points' ``x, v, C, F, Jp, C_prev`` copied
  before and back after; the grid's arrays are cleared by every substep).

On the oscillator ``m x'' = -k x`` this is the trapezoidal rule (``det = 1``: no gain, no damping) once converged; the
start's stress with the end velocity is symplectic Euler (bounded), round 68's "mid" a damping of ``dt/2`` (``det = 1
/ (1 + (omega dt)^2 / 2)``). Only the hyperelastic models (jelly, neo-Hookean) and free points; every other model and
a held point keep their return mapping's increment and stress. Not for scenes with rigid bodies or moving colliders'
state (their state is not restored between passes).

The option ``stress_passes`` (P2G-grid-G2P passes a substep, the last the real one; 1 by default: the guess ``C_n``,
no trial) is read each substep; :data:`TRAP_WEIGHT` when the kernels are built (a change needs a fresh process).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from gasp_core.mpm.materials import JELLY, NEO_HOOKEAN

from .forces import build_extras_struct
from .mid_stress import build_mid_stress
from .precision import build_types

#: The ``rule`` argument's bit of the P2G kernel that selects the trapezoidal stress (bit 3: round 68's "mid").
TRAP_BIT = 16
#: The weight of the end gradient in ``C_avg`` (1/2: the trapezoid). A catch of ``tests/test_stress_at.py`` sets 1
#: (the end gradient alone: round 68's damping class) in a fresh process.
TRAP_WEIGHT = 0.5

POINT_STATE = ("x", "v", "C", "F", "Jp", "C_prev")


@functools.cache
def trapezoid_return(Ft, held_return):
    """``trap_return(C, F, dt, p, code, X, dx, ex, body, mat_kind, mat_par, Jp, rule, fx, C_prev, C_guess)``: P2G's
    ``held_return`` (given, :func:`gasp_warp_mpm.held.build_held_return`'s; ``rule``'s bits 0-3) with the increment's
    gradient and the stress of :data:`TRAP_BIT`; ``(F, tau)``. Of ``trap_gradient(Cp, p, rule, body, mat_kind,
    C_prev)``: the gradient that advances ``F`` (``C_avg`` of the increment that ends now, ``C_prev`` its start's, for a
    hyperelastic point under :data:`TRAP_BIT`, else ``Cp``), ``C_prev`` set to ``Cp``; and ``trap_tau(Cp, F, tau, dt,
    p, code, X, dx, ex, body, mat_kind, mat_par, Jp, fx, C_guess, rule)``: the midpoint stress of the increment that
    starts now (module notes), else ``tau``. Not a ``build_*`` (warmup.py calls those with ``Ft`` alone): transfers.py
    builds it with P2G."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)
    from .held import build_image_flip   # here: held.py imports this module (through held_rule.py)
    held_axis = build_image_flip(Ft)[0]
    mid_tau = build_mid_stress(Ft)
    w = Ft(TRAP_WEIGHT)

    @wp.func
    def trap_gradient(Cp: mat33, p: int, rule: int, body: wp.array(dtype=wp.int32),
                      mat_kind: wp.array(dtype=wp.int32), C_prev: wp.array(dtype=mat33)):
        if rule < TRAP_BIT:
            return Cp
        kind = mat_kind[body[p]]
        Cu = Cp
        if kind == JELLY or kind == NEO_HOOKEAN:
            Cu = (Ft(1.0) - w) * C_prev[p] + w * Cp
        C_prev[p] = Cp
        return Cu

    @wp.func
    def trap_tau(Cp: mat33, Fp: mat33, tau: mat33, dt: Ft, p: int, code: int, X: vec3, dx: Ft, ex: Extras,
                 body: wp.array(dtype=wp.int32), mat_kind: wp.array(dtype=wp.int32), mat_par: wp.array2d(dtype=Ft),
                 Jp: wp.array(dtype=Ft), fx: vec3, C_guess: wp.array(dtype=mat33), rule: int):
        if rule < TRAP_BIT:
            return tau
        if held_axis(code, X, dx, ex) >= 0:
            return tau
        Ca = (Ft(1.0) - w) * Cp + w * C_guess[p]
        return mid_tau(Ca, Fp, tau, dt, p, body, mat_kind, mat_par, Jp, fx)   # H = I + dt/2 C_avg

    @wp.func
    def trap_return(Cp: mat33, Fp: mat33, dt: Ft, p: int, code: int, X: vec3, dx: Ft, ex: Extras,
                    body: wp.array(dtype=wp.int32), mat_kind: wp.array(dtype=wp.int32), mat_par: wp.array2d(dtype=Ft),
                    Jp: wp.array(dtype=Ft), rule: int, fx: vec3, C_prev: wp.array(dtype=mat33),
                    C_guess: wp.array(dtype=mat33)):
        F_new, tau = held_return(trap_gradient(Cp, p, rule, body, mat_kind, C_prev), Fp, dt, p, code, X, dx, ex, body,
                                 mat_kind, mat_par, Jp, rule % TRAP_BIT, fx)
        return F_new, trap_tau(Cp, F_new, tau, dt, p, code, X, dx, ex, body, mat_kind, mat_par, Jp, fx, C_guess, rule)

    return trap_return


class TrapezoidStress:
    """The engine's trial passes (a mixin of :class:`gasp_warp_mpm.engine.WarpMPMEngine`, through ``HeldRule``)."""

    def trap_on(self) -> bool:
        return self.config.stress_at == "trapezoid"

    def trap_arrays(self) -> list:
        """``[C_prev, C_guess]`` for P2G (one entry each when the option is off; ``C_guess`` is ``C`` with one pass),
        allocated once."""
        if getattr(self, "C_prev", None) is None:
            on = self.trap_on()
            if on and int(self.config.stress_passes) > 1 and (getattr(self, "any_rigid", False)
                                                              or self.setup.colliders):
                from gasp_core.seam import EngineError
                raise EngineError(f"engine 'warp_mpm': stress_passes = {int(self.config.stress_passes)} under "
                                  "stress_at = \"trapezoid\" runs trial substeps that do not restore rigid bodies' "
                                  "or colliders' state; this scene has them: use stress_passes = 1 (round 69, "
                                  "docs/fracture.md)")
            trials = on and int(self.config.stress_passes) > 1
            self.C_prev = wp.clone(self.C) if on else wp.zeros(1, dtype=self.C.dtype, device=self.device)
            # one pass: the guess is C itself (P2G only reads it), no copy a substep, no saved state
            self.C_guess = (wp.zeros(self.C.shape[0], dtype=self.C.dtype, device=self.device) if trials
                            else self.C if on else wp.zeros(1, dtype=self.C.dtype, device=self.device))
            self._trap_saved = [(n, wp.empty_like(getattr(self, n))) for n in POINT_STATE] if trials else []
        return [self.C_prev, self.C_guess]

    def trap_sorted(self) -> list:
        """The per-point arrays the CPU's sort moves besides the engine's own (``C_prev``)."""
        return [self.C_prev] if self.trap_on() else []

    def trial_passes(self, capturing: bool = False) -> None:
        """Before a substep's launches: ``C_guess`` set to ``C`` (pass 0), then ``stress_passes - 1`` trial
        substeps from the saved points, each leaving its gathered ``C`` in ``C_guess`` (one pass: nothing to do,
        ``C_guess`` is ``C``)."""
        if not getattr(self, "_trap_saved", None):
            return
        wp.copy(self.C_guess, self.C)
        for _ in range(int(self.config.stress_passes) - 1):
            for n, saved in self._trap_saved:
                wp.copy(saved, getattr(self, n))
            for cmd in self._pre:
                cmd.launch()
            for i, cmd in enumerate(self._launches):
                cmd.launch()
                if i == 0 and self.visc is not None:
                    self.visc.solve(capturing)
            wp.copy(self.C_guess, self.C)
            for n, saved in self._trap_saved:
                wp.copy(getattr(self, n), saved)
