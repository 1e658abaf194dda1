"""The grid contact's touch dashpot speed, one rule for both engines (issue 67; docs/contact.md "Round 50: one dashpot
speed"; ``gasp_core.mpm.contact.touch_dashpot_speed``).

The dashpot on the node layers above a ground's held ones (round 48) damps the cell's compression mode of a body that
does not flow, at the speed ``2 DAMPING c - 2 eta / (rho dx)`` of its P-wave speed ``c``. A rigid body
(``model = "rigid"``) has zero stress (``gasp_core.mpm.rigid.zero_stress``): it has no such mode, and its ``E`` sets no
step (``step_view``), so it counts no speed. Before round 50 warp_mpm counted a wooden block's 4385 m/s (and so a
dashpot some 400 times the jelly's beside it, ``s dt / dx`` about 90 at the jelly's step) while taichi_mpm counted 0.

Checked here (default tier, both engines): a scene of a jelly block and a rigid wooden block on a ground with friction
(``contact = "grid"``) gives the jelly's speed on both engines, the same float; the catch: the rule before (the rigid
body's P-wave speed counted) gives the wood's speed, which the check refuses.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from slopes import ENGINES

from gasp_core.mpm.contact import DAMPING, FLOWING, touch_dashpot_speed
from gasp_core.seam import build_engine, get_engine
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points

JELLY = Material("jelly", E=1e5, nu=0.3, rho=1000.0)
WOOD = Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0)


def _scene() -> SimSetup:
    """A jelly block and a rigid wooden block side by side on a ground (friction 0.5), n_grid 16, the grid contact."""
    xa, va = box_points((0.25, 0.4, 0.0625), (0.4, 0.55, 0.15), 1.0 / 32)
    xb, vb = box_points((0.6, 0.4, 0.0625), (0.75, 0.55, 0.15), 1.0 / 32)
    x = np.concatenate([xa, xb])
    return SimSetup(x=x, v=0.0, p_vol=np.r_[np.full(len(xa), va), np.full(len(xb), vb)],
                    body_id=np.r_[np.zeros(len(xa), int), np.ones(len(xb), int)], materials=[JELLY, WOOD],
                    gravity=np.array([0.0, 0.0, -9.81]), domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=16,
                    boundaries=[Boundary("ground", height=0.0625, friction=0.5)], frame_dt=1.0 / 30.0,
                    options={"contact": "grid"})


def _old_speed(setup) -> float:
    """The rule before round 50 (warp_mpm's): every body that does not flow counted, rigid ones too."""
    return max(0.0, max((2.0 * DAMPING * m.p_wave_speed - 2.0 * m.viscosity / (m.rho * setup.dx)
                         for m in setup.materials if m.name not in FLOWING), default=0.0))


def _engine_speed(engine: str) -> float:
    """The dashpot speed (m/s) engine ``engine`` built for :func:`_scene`."""
    e = build_engine(get_engine(engine), _scene())
    s = getattr(e, "solver", e)
    assert s.touch_on is True
    return float(s.touch_speed)


def _check(speed: float) -> None:
    """The speed is the jelly's ``2 DAMPING c`` (its P-wave speed ``c``), to 1e-12 relative."""
    c = math.sqrt(JELLY.E * (1 - JELLY.nu) / ((1 + JELLY.nu) * (1 - 2 * JELLY.nu)) / JELLY.rho)
    want = 2.0 * DAMPING * c
    assert abs(speed - want) <= 1e-12 * want, f"touch speed {speed:.6g} m/s, the jelly's {want:.6g} m/s"


@pytest.mark.parametrize("engine", ENGINES)
def test_a_rigid_body_counts_no_dashpot_speed_on_either_engine(engine):
    speed = _engine_speed(engine)
    _check(speed)
    assert speed == touch_dashpot_speed(_scene())   # the one core rule


def test_the_rule_before_is_caught():
    old = _old_speed(_scene())   # the wood's 2 DAMPING 4385 m/s
    assert old > 4000.0
    with pytest.raises(AssertionError):
        _check(old)
