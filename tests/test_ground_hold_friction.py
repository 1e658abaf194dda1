"""The grid contact's ground hold keeps the ground's friction (both MLS-MPM engines).

Since issue 66 the engines hold a point of a body on the grid contact (sand, snow, liquid under ``contact = "auto"``)
on the ground's plane after its G2P (``gasp_warp_mpm.colliders.build_box_hold``, ``gasp_taichi_mpm.colliders
.Colliders.hold_box``). The grid rule's friction acts at the ground's node layers, and the plane lies a fraction
``f`` of a cell above the top one (``gasp_core.mpm.points.ground_top_node``): a point held on the plane reads that
stopped layer with a weight of 7/8 at ``f = 0`` but 1/2 at ``f = 0.5`` and 1/8 as ``f`` nears 1. Without the hold's
own friction a sand body held there slid nearly free: the user's sand column (``benchmarks/sand_ball_pipeline.py``,
its plane 0.78 cell above the layer) flowed out flat (``tests/test_runout.py``'s slow pile test; every drawn
Gaussian on the ground at frame 20).

Known answer (Coulomb): while a body slides on the ground, the only horizontal force on it is the ground's friction,
``mu`` times the normal force, and the normal impulse over ``[0, t]`` is ``M (g t + v_z(t))`` (``v_z`` the mass
centre's vertical velocity; it starts at 0), so its mass centre's horizontal speed falls by ``mu (g t + v_z(t))``.
A sand block (20 x 20 x 10 cm, 1 m/s along x, ground friction 0.5, ``contact = "grid"``) sliding 0.1 s (its base
still slides at 0.6 m/s): the ratio of the speed lost to that is 1 within 5 % at every offset ``f``.

Measured (both engines alike to the digits shown): n_grid 24: 0.983 / 0.966 / 0.972 at ``f`` = 0 / 0.5 / 0.8, n_grid
32: 0.980 / 0.966 / 0.971; without the hold's friction (the code before) 0.983 / 0.665 / 0.373 and 0.980 / 0.626 /
0.354, the block still sliding at 0.74 / 0.85 m/s (n_grid 24, 0.2 s) when the held one is near its stop.
Catch: the hold given no friction (what the box hold did before) fails at ``f`` = 0.5 and 0.8.

Since round 35 the engines lay the grid with the plane on a node wherever the grid contact acts
(``gasp_core.mpm.grid_origin.ground_on_node``), so every ``f`` reads as 0 (0.983 at n_grid 24 with or without the
hold's friction). The hold's friction stays as the defence where a plane is off the nodes (a second ground, which the
grid is not laid on): with the grid left where the domain put it the hold alone still gives 0.966 / 0.972 at ``f`` =
0.5 / 0.8, and the catch breaks both (the grid where the domain put it and the hold without friction).

Since round 36 the node layer above the plane takes the ground's rule where the points touch it (``touch_contact``,
docs/contact.md "Round 36"), a second defence there: with the grid where the domain put it and the hold without
friction the block reads 0.995 / 0.989 at ``f`` = 0.5 / 0.8 (both engines), so the catch turns that layer off too
(the rule before round 36), where the hold's friction alone gives 0.966 / 0.972 and its absence 0.665 / 0.373.
"""
from __future__ import annotations

import numpy as np
import pytest

from gasp_testing import needs_package

MU, G, V0, FRAMES = 0.5, 9.81, 1.0, 3
OFFSETS = (0.0, 0.5, 0.8)


def coulomb_ratio(engine: str, offset: float, n_grid: int = 24) -> float:
    """The sand block of the module docstring on a ground ``offset`` cells above a node layer (``n_grid`` cells over
    the unit domain), after ``FRAMES`` frames of 1/30 s: its mass centre's horizontal speed lost over ``mu (g t +
    v_z)`` (dimensionless; 1 is Coulomb's)."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    from gasp_core.testing.helpers import box_points
    dx = 1.0 / n_grid
    height = (4 + offset) * dx
    x, p_vol = box_points([0.2, 0.4, 0.0], [0.4, 0.6, 0.1], dx / 2)
    x[:, 2] += height + dx / 8 - x[:, 2].min()                    # the lowest points an eighth of a cell up
    s = SimSetup(x=x, v=np.tile([V0, 0.0, 0.0], (len(x), 1)), p_vol=p_vol, body_id=0,
                 materials=[Material("sand", E=3.5e5, nu=0.3, rho=1600.0, friction_angle=30.0)],
                 gravity=[0, 0, -G], domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=n_grid, frame_dt=1 / 30,
                 boundaries=[Boundary("ground", height=height, friction=MU)],
                 options={"contact": "grid", **({"threads": 1} if engine == "taichi_mpm" else {})})
    e = build_engine(engines()[engine], s)
    try:
        for _ in range(FRAMES):
            e.step_frame()
        v = np.asarray(e.velocities(), np.float64).mean(0)       # equal masses: the mass centre's velocity
    finally:
        e.close()
    return float((V0 - v[0]) / (MU * (G * FRAMES / 30 + v[2])))


def _off(monkeypatch, engine: str) -> None:
    """A broken engine: the box hold puts points on the floor without its friction (the code before)."""
    if engine == "taichi_mpm":   # its hold reads the floor's friction the engine hands the solver
        import gasp_taichi_mpm.engine as te
        monkeypatch.setattr(te, "passive_floor_friction", lambda setup, contact="grid": 0.0)
    else:   # its box hold reads it when the frame's launches are recorded (gasp_warp_mpm.colliders)
        import gasp_core.mpm.points as points
        monkeypatch.setattr(points, "passive_floor_friction", lambda setup, contact="grid": 0.0)


CASES = [pytest.param("warp_mpm", 24, OFFSETS[1:], id="warp_mpm-24"),
         pytest.param("warp_mpm", 32, OFFSETS, id="warp_mpm-32", marks=pytest.mark.slow),
         pytest.param("taichi_mpm", 24, OFFSETS, id="taichi_mpm-24", marks=pytest.mark.slow),
         pytest.param("taichi_mpm", 32, OFFSETS, id="taichi_mpm-32", marks=pytest.mark.slow)]


@pytest.mark.parametrize("engine, n_grid, offsets", CASES)
def test_a_sand_block_held_on_the_ground_slows_by_coulombs_friction_wherever_the_plane_lies(engine, n_grid, offsets):
    needs_package(f"gasp_{engine}")
    ratios = {f: coulomb_ratio(engine, f, n_grid) for f in offsets}
    assert all(0.95 <= r <= 1.05 for r in ratios.values()), ratios


def _unaligned(monkeypatch) -> None:
    """The grid where the domain put it, the plane off its nodes (before round 35)."""
    import gasp_core.mpm.grid_engine as ge
    monkeypatch.setattr(ge, "ground_on_node", lambda setup: setup)


@pytest.mark.parametrize("engine", [pytest.param("warp_mpm"), pytest.param("taichi_mpm", marks=pytest.mark.slow)])
def test_the_check_catches_a_ground_hold_without_friction(engine, monkeypatch):
    needs_package(f"gasp_{engine}")
    from test_ground_touch import touch
    _unaligned(monkeypatch)
    touch(monkeypatch, engine, None)   # and the touched layer off (round 36: it alone gives 0.995 / 0.989 here)
    held = {f: coulomb_ratio(engine, f) for f in OFFSETS[1:]}
    assert all(0.95 <= r <= 1.05 for r in held.values()), held   # the hold's own friction, off the nodes
    _off(monkeypatch, engine)
    ratios = {f: coulomb_ratio(engine, f) for f in OFFSETS[1:]}
    assert all(r < 0.95 for r in ratios.values()), ratios
