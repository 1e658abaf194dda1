"""The substep taken from the state: snow's hardening (round 57, ``gasp_core.mpm.state_step``; docs/mpm.md "Time
step", docs/fracture.md "Round 57: snow's step from its state").

Fast: the clock alone (fake reductions): a frame's substeps follow the state's step, at least the setup's, cut finer
within the frame where the state asks it, each frame ending on ``frame_dt``; where it acts. Both engines: a snow
block compacted through the engine's state (``Jp`` written 0.7, ``h = e^3``) takes the substeps of its hardened
wave speed, counted here from Stomakhin et al.'s moduli, and a jelly block beside the same options keeps the setup's.
The catch, on the ledger (``tests/test_energy_ledger_plastic.py``): the fixed step of round 56 fails its gate on the
snow block.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from gasp_core.mpm.state_step import StateStep, applies, snow_speed
from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing.helpers import box_points, make_setup

ENGINES = ["taichi_mpm", "warp_mpm"]


def block(mat="snow", n_grid=16, options=None, v=(0.0, 0.0, -2.0)):
    """A 12 x 12 x 5 cm block of ``mat`` 5 mm over the ground of a 0.6 m box (2 x 2 x 2 points a cell)."""
    dx = 0.6 / n_grid
    x, vol = box_points((-0.06, -0.06, 0.005), (0.06, 0.06, 0.055), dx / 2)
    return make_setup(x, np.full(len(x), vol), Material(mat), v=v, lo=(-0.3, -0.3, -0.02), hi=(0.3, 0.3, 0.58),
                      n_grid=n_grid, frame_dt=1 / 30, boundaries=[Boundary("ground", height=0.0, friction=0.5)],
                      options=dict(options or {}))


def expected_substeps(setup, jp: float) -> int:
    """``ceil(frame_dt (c + v) / (cfl dx))``: ``c = sqrt(e^(xi (1 - Jp)) (lambda + 2 mu) / rho)`` (Stomakhin et al.
    2013), ``v = |v0| + sqrt(2 g H)`` the setup's fall bound, cfl 0.4 (rule "sum")."""
    m = setup.materials[0]
    c = math.sqrt(math.exp(m.hardening * (1 - jp)) * (m.lam + 2 * m.mu) / m.rho)
    v = float(np.linalg.norm(setup.v, axis=1).max()) + math.sqrt(2 * 9.81 * 0.6)
    return math.ceil(setup.frame_dt * (c + v) / (0.4 * setup.dx) - 1e-9)


class Fake:
    """A state: ``jp`` per substep taken (the last repeated), the dt each substep took."""

    def __init__(self, jps):
        self.jps, self.k, self.dts = list(jps), 0, []

    def reduce(self):
        return np.array([self.jps[min(self.k, len(self.jps) - 1)]]), 0.0

    def apply(self, dt):
        self.dt = dt


def run_frame(clock, fake):
    clock.begin()
    while True:
        fake.dts.append(fake.dt)
        fake.k += 1
        if clock.after():
            return


def test_the_clock_follows_the_state_within_a_frame():
    setup = block()
    n0 = expected_substeps(setup, 1.0 - 0.025)   # the setup's rule: h at most exp(xi theta_c)
    fake = Fake([1.0] * 5 + [0.9, 0.8, 0.75])
    clock = StateStep(setup, {}, n0, fake.reduce, fake.apply)
    assert clock.on and fake.dts == []
    run_frame(clock, fake)
    assert fake.dts[:5] == [pytest.approx(setup.frame_dt / n0, rel=1e-12)] * 5   # the setup's step before
    assert sum(fake.dts) == pytest.approx(setup.frame_dt, rel=1e-12)   # the frame ends on frame_dt
    assert all(b <= a * (1 + 1e-12) for a, b in zip(fake.dts, fake.dts[1:]))   # never longer within a frame
    dt_075 = 0.4 * setup.dx / (snow_speed(setup.materials[0], 0.75) + clock.v_fall)
    assert fake.dts[-1] <= dt_075 * (1 + 1e-12) and fake.dts[-1] > 0.9 * dt_075
    fake.dts = []
    run_frame(clock, fake)   # the next frame starts from the compacted state
    assert clock.frames[-1] == expected_substeps(setup, 0.75) == len(fake.dts) > clock.frames[0] > n0


def test_never_fewer_than_the_setups_substeps():
    setup = block()
    fake = Fake([1.0])
    clock = StateStep(setup, {}, 500, fake.reduce, fake.apply)
    run_frame(clock, fake)
    assert clock.frames == [500]


def test_where_the_state_step_acts():
    assert applies(block(), {}) and not applies(block("jelly"), {})
    assert not applies(block(), {"dt": 1e-4}) and not applies(block(), {"n_substeps": 100})


@pytest.mark.parametrize("engine", ENGINES)
def test_a_compacted_snow_block_takes_more_substeps(engine):
    """Both engines: ``Jp`` written 0.7 (``h = e^3``): the frame takes :func:`expected_substeps` at ``Jp`` 0.7 or
    more (the block lands in it; the engines agree), over twice the setup's; a jelly block keeps the setup's."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    setup = block()
    e = build_engine(engines()[engine], setup)
    try:
        n_setup = e.n_substeps
        assert n_setup == expected_substeps(setup, 1.0 - 0.025)
        state = e.get_state()
        e.set_state({**state, "Jp": np.full_like(state["Jp"], 0.7)})
        e.step_frame()
        n = e.stats()["n_substeps"]
        assert expected_substeps(setup, 0.7) <= n < 1.2 * expected_substeps(setup, 0.7), (n, n_setup)
        assert n > 2 * n_setup
    finally:
        e.close()
    jelly = dataclasses.replace(setup, materials=[Material("jelly")])
    e = build_engine(engines()[engine], jelly)
    try:
        n0 = e.n_substeps
        e.step_frame()
        assert e.stats()["n_substeps"] == n0 and not e.clock.on
    finally:
        e.close()


def test_a_state_past_max_substeps_is_a_divergence():
    from gasp_core.errors import EngineDivergence
    setup = block()
    fake = Fake([1.0, 1.0, 0.0])   # Jp 0: h = e^10, 148x the stiffness
    clock = StateStep(setup, {"max_substeps": 100}, 42, fake.reduce, fake.apply)
    with pytest.raises(EngineDivergence, match="max_substeps = 100"):
        run_frame(clock, fake)
    fake = Fake([float("nan")])   # a non-finite state: the setup's step (the frame's checks report it)
    clock = StateStep(setup, {}, 42, fake.reduce, fake.apply)
    run_frame(clock, fake)
    assert clock.frames == [42]
