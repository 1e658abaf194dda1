"""Snow's step from its state with colliders, forces and impulses (round 59; ``gasp_core.mpm.state_step``,
``gasp_core.mpm.grid_tables.substep_table``; docs/fracture.md "Round 59: snow's step beside colliders, forces and
impulses").

Before round 59 a scene with snow and any collider, force or impulse kept the setup's step (``applies``), and snow
hardened past it: the snow ball of ``benchmarks/energy_ledger_plastic.py`` at 5 m/s leaves +23.90 % of its energy
untraced on the fixed step (round 58). Now the state's clock runs there too, each substep reading its own row of the
time table (collider poses, impulse weights at the substep's own time and step). Both engines:

- a compacted snow block (``Jp`` written 0.7, :mod:`tests.test_state_step`'s) beside a static collider, a moving
  collider, a wind and an impulse each takes its hardened wave speed's substeps, as alone; the rule of before (no
  clock where there are tables) fails it;
- the rows follow the clock's time: an ``add`` impulse of 0.3 m/s spread over the middle fifth of frame 2 gives the
  compacted block, in the air, no x-momentum in frame 1 and all of it by the end of frame 2 (momentum exact to
  1e-5, whatever the substeps); rows a frame early (a broken clock) put it in frame 1 and fail.
"""
from __future__ import annotations

import numpy as np
import pytest

from gasp_core.colliders.model import ForceField, Impulse, Motion
from gasp_core.colliders.sdf import box_collider
from gasp_core.mpm import grid_tables, state_step
from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import engines

from test_state_step import block, expected_substeps

ENGINES = ["taichi_mpm", "warp_mpm"]
#: The impulse's window in frame 2 (s) and its velocity change (m/s).
T0, T1, DV = 1.4 / 30, 1.6 / 30, 0.3
FAR = (0.2, 0.2, 0.4)   # a corner of the 0.6 m box, away from the block (m)


def extras(kind: str) -> dict:
    """One collider, force or impulse that leaves the block's fall alone (``kind``)."""
    if kind == "static collider":
        return {"colliders": [box_collider((0.03, 0.03, 0.03), 0.01, position=FAR)]}
    if kind == "moving collider":
        return {"colliders": [box_collider((0.03, 0.03, 0.03), 0.01, position=FAR,
                                           motion=Motion(velocity=(-0.1, 0.0, 0.0)))]}
    if kind == "wind":   # a breeze along x: a drag on the block's surface
        return {"forces": [ForceField("wind", direction=(1.0, 0.0, 0.0), speed=0.5)]}
    return {"impulses": [Impulse("box", (DV, 0.0, 0.0), T0, T1, lo=(-0.3, -0.3, -0.02), hi=(0.3, 0.3, 0.58))]}


def compacted(engine: str, setup):
    """``setup`` on ``engine`` with every point's ``Jp`` written 0.7 (``h = e^3``)."""
    e = build_engine(engines()[engine], setup)
    state = e.get_state()
    e.set_state({**state, "Jp": np.full_like(state["Jp"], 0.7)})
    return e


def with_extras(setup, kind: str):
    for k, v in extras(kind).items():
        setattr(setup, k, v)
    return setup


@pytest.mark.parametrize("kind", ["static collider", "moving collider", "wind", "impulse"])
@pytest.mark.parametrize("engine", ENGINES)
def test_snow_beside_extras_takes_its_hardened_step(engine, kind):
    setup = with_extras(block(), kind)
    assert state_step.applies(setup, {})
    e = compacted(engine, setup)
    try:
        e.step_frame()
        n = e.stats()["n_substeps"]
    finally:
        e.close()
    want = expected_substeps(block(), 0.7)
    assert want <= n < 1.2 * want, (kind, n, want)


def test_the_rule_of_before_is_caught(monkeypatch):
    """The rule of before (the setup's step where there are tables) fails the check above."""
    before = state_step.applies
    monkeypatch.setattr(state_step, "applies",
                        lambda s, o: before(s, o) and not grid_tables.grid_tables(s).any)
    setup = with_extras(block(), "static collider")
    e = compacted("taichi_mpm", setup)
    try:
        e.step_frame()
        n = e.stats()["n_substeps"]
    finally:
        e.close()
    assert not expected_substeps(block(), 0.7) <= n


def impulse_momentum(engine: str) -> list[float]:
    """The compacted block 10 cm up, falling from rest, with the impulse (module notes): its mean x-velocity after
    frames 1 and 2 over ``DV``."""
    setup = with_extras(block(v=(0.0, 0.0, 0.0)), "impulse")
    setup.x = setup.x + np.array([0.0, 0.0, 0.1])
    e = compacted(engine, setup)
    out = []
    try:
        for _ in range(2):
            e.step_frame()
            v = np.asarray(e.velocities(), np.float64)
            out.append(float(setup.p_mass @ v[:, 0]) / float(setup.p_mass.sum()) / DV)
        n, want = e.stats()["n_substeps"], expected_substeps(block(v=(0.0, 0.0, 0.0)), 0.7)
        assert e.clock.on and n >= want, (n, want)   # the state's substeps, not the setup's
    finally:
        e.close()
    return out


@pytest.mark.parametrize("engine", ENGINES)
def test_an_impulse_lands_in_its_frame_on_the_state_clock(engine):
    f1, f2 = impulse_momentum(engine)
    assert abs(f1) < 1e-5 and abs(f2 - 1.0) < 1e-5, (f1, f2)


def test_rows_a_frame_early_are_caught(monkeypatch):
    """A clock whose rows run a frame ahead (the frame's start misread) puts the impulse in frame 1."""
    import gasp_taichi_mpm.state_step as ts
    real = grid_tables.substep_table
    monkeypatch.setattr(ts, "substep_table", lambda setup, t, dt, size: real(setup, t + setup.frame_dt, dt, size))
    f1, f2 = impulse_momentum("taichi_mpm")
    assert not (abs(f1) < 1e-5 and abs(f2 - 1.0) < 1e-5), (f1, f2)
