"""Where in the increment P2G takes the stress (round 68, issue 66 item 6 "No energy is gained"; docs/fracture.md
"Round 68: the midpoint stress"): the engine option :data:`STRESS_AT`.

MLS-MPM's P2G advances ``F`` by the point's velocity gradient ``C`` and scatters the Kirchhoff stress of that ``F``;
the grid update then sets the velocities that advance ``F`` over the next increment, so the stress is taken at the
increment's start (symplectic Euler). Its stored energy then rises by ``P : dF + dF : A : dF / 2`` while the stress
does ``P : dF`` of work: the second-order term ``dF : A : dF / 2 >= 0`` (``A`` the tangent, positive on a convex
energy) is a gain on every increment, which the symplectic step returns on a free vibration (the other half of its
bounded offset) but not where the velocity gradient was set by something else than the stress: the contact's
impulse, the ground's friction (round 68: the jelly donut's gain 2.75 % of the energy brought with the scene's
friction 0.5, 1.33 % without; docs/fracture.md).

``"trapezoid"`` (round 69, docs/fracture.md "Round 69: the trapezoidal stress"; **the default since round 70**,
docs/fracture.md "Round 70: the trapezoid as the default"; an engine without trial passes refuses
``stress_passes`` > 1) advances ``F`` by the mean of the increment's start and end gradients and scatters the stress of
that increment's midpoint, the end gradient from :data:`STRESS_PASSES` fixed-point passes (1: the start's as the
guess): the trapezoidal rule, no gain and no damping on a free vibration. Both "trapezoid" and "mid" scatter the
symmetric part of their midpoint stress (round 71, docs/fracture.md "Round 71 (lead)"): the whole ``tau(F_mid)
H^-T`` is not symmetric, and its antisymmetric part (about ``-dt/2 skew(tau C^T)``) is a torque that moved a free
spun jelly ball's angular momentum by 8.4e-4 of itself in 4 frames (``tests/test_stress_spin.py``).

``"mid"`` scatters the work-conjugate stress of the increment's midpoint, ``P(F_mid) F^T = tau(F_mid) (I + dt/2
C)^-T`` with ``F_mid = (I + dt/2 C) F``, ``C`` the point's last gradient (the fixed-point guess of the next one, one
pass: no extra transfer), so the stress's work is the stored energy's rise to third order and the elastic step cannot
gain; its cost is the first-order loss of the explicit step (the impulse's ``|J|^2 / 2m`` a node, which the start's
stress returns as the gain above): a stiffness-proportional damping of ratio about ``omega dt / 4``. Only the
hyperelastic models (jelly, neo-Hookean), whose stress is a function of ``F`` alone; the others keep their return
mapping's stress, and a held point (``fixed_region``, a set box) its image's. An option, never the default (the
figures and why: docs/fracture.md "Round 68").

``"start"`` (the default until round 70) stays selectable: a scene's ``options: {stress_at: start}`` gives the
symplectic Euler step of rounds 1-69 (its figures: ``tests/test_energy_ledger.py`` runs both).
"""
from __future__ import annotations

from gasp_core.seam.options import Option

#: The stress's point in the increment: the start (symplectic Euler, the default until round 70), the midpoint, or
#: the trapezoid's (the default since round 70; module notes).
STRESS_ATS = ("start", "mid", "trapezoid")

#: The most passes a substep under "trapezoid" (round 69: converged at 3 on the jelly donut).
MAX_STRESS_PASSES = 8

STRESS_AT = Option(
    "stress_at", "trapezoid", "where P2G takes the hyperelastic stress (jelly, neo-Hookean; the other models keep "
    "their return mapping's increment and stress under every choice): 'start', of F (symplectic "
    "Euler, the default until round 70), or 'mid', the work-conjugate stress of F_mid = (I + dt/2 C) F, whose work is the stored "
    "energy's rise to third order (the jelly donut thrown at 4.43 m/s at cfl 0.8: its elastic step gains 2.75 % of "
    "the energy brought with 'start', 0.18 % with 'mid', which damps it instead: 16 % of it lost by the step; "
    "gasp_core.mpm.stress_at, docs/fracture.md round 68), or 'trapezoid' (the default since round 70), F advanced "
    "by the mean of the increment's start and end velocity gradients and the stress at that increment's midpoint "
    "(stress_passes; an engine without trial passes refuses more than one): the donut gains 0.17-0.45 % and keeps "
    "75 % (start 77.4, mid 64.3), a free vibration its energy (docs/fracture.md rounds 69, 70)", kind="str",
    choices=STRESS_ATS)

STRESS_PASSES = Option(
    "stress_passes", 1, "P2G-grid-G2P passes a substep under stress_at = 'trapezoid' (the last the real one, each "
    "before it a trial substep whose end velocity gradient the next pass's midpoint takes; 1: the start's gradient "
    "as the guess, no trial; a pass costs about a substep: docs/fracture.md round 69)", kind="int", lo=1,
    hi=MAX_STRESS_PASSES)

