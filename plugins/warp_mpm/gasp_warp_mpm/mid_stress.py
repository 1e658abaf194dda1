"""The midpoint stress (round 68, issue 66 item 6 "No energy is gained"; docs/fracture.md "Round 68"): an engine
option, off by default. P2G scatters the stress of the increment's midpoint, ``F_mid = (I + dt/2 C) F``, instead of
the stress of ``F`` at the increment's start, ``C`` the point's last velocity gradient (the fixed-point guess of the
next one), as the work-conjugate Kirchhoff stress ``P(F_mid) F^T = tau(F_mid) (I + dt/2 C)^-T``. Only the hyperelastic
models (jelly, neo-Hookean), whose stress is a function of ``F`` alone; every other model keeps its return mapping's
stress. As Warp functions per scalar type (:mod:`gasp_warp_mpm.precision`).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from gasp_core.mpm.materials import JELLY, NEO_HOOKEAN

from .constitutive import build_return_mapping
from .precision import build_types

#: The ``rule`` argument's bit of the P2G kernel that selects the midpoint stress (bits 0-2: the brittle held rule's,
#: :mod:`gasp_warp_mpm.held_rule`).
MID_BIT = 8
#: The midpoint's place in the increment (1/2; read when the kernel is built: a change needs a fresh process). The catch
#: of ``tests/test_stress_at.py`` (taichi_mpm's ``MidStress.mid_fraction``) sets -1/2: the stress extrapolated back.
MID_FRACTION = 0.5
#: 1: scatter the symmetric part of the midpoint stress (round 71: its antisymmetric part, of order ``dt tau C``,
#: is a torque: a free spun jelly ball lost 8.4e-4 of its angular momentum in 4 frames; tests/test_stress_spin.py).
#: 0, the broken variant (rounds 68-70), a change needs a fresh process.
SYMMETRIC = 1


@functools.cache
def build_mid_stress(Ft):
    """``mid_tau(C, F, tau, dt, p, body, mat_kind, mat_par, Jp, fx)``: the midpoint stress of a hyperelastic point
    (module notes), else ``tau`` unchanged (``F`` the point's new ``F``, ``tau`` its return mapping's stress)."""
    vec3, vec4, mat33 = build_types(Ft)
    return_mapping = build_return_mapping(Ft)
    frac = Ft(MID_FRACTION)

    @wp.func
    def mid_tau(Cp: mat33, Fp: mat33, tau: mat33, dt: Ft, p: int, body: wp.array(dtype=wp.int32),
                mat_kind: wp.array(dtype=wp.int32), mat_par: wp.array2d(dtype=Ft), Jp: wp.array(dtype=Ft), fx: vec3):
        kind = mat_kind[body[p]]
        if kind != JELLY and kind != NEO_HOOKEAN:
            return tau
        H = wp.identity(3, dtype=Ft) + (frac * dt) * Cp
        Fm, tm = return_mapping(H * Fp, p, body, mat_kind, mat_par, Jp, dt, fx, 0)   # no Jp written for these two
        S = tm * wp.transpose(wp.inverse(H))
        if SYMMETRIC == 0:
            return S
        return Ft(0.5) * (S + wp.transpose(S))   # its symmetric part: no torque (round 71)

    return mid_tau
