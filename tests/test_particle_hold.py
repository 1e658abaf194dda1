"""Round 97 (issue 66 item 6, ``docs/fracture.md`` "Round 97: the extremes' neighbours"): no point under the ground or
past a wall on the particle contact, over the neighbours of ``tests/test_brittle_extremes_family.py``.

That test throws a brittle box and ball down at 4.43, 20 and 50 m/s on n_grid 64 and reads the domain's faces.
``benchmarks/studies/extremes97.py`` throws them down, into the +x wall and at 45 degrees, at 20 and 50 m/s, on n_grid
32 and 48, and reads the walls' planes (3 dx inside the faces). Before this round the particle contact's penalty
let points past the planes on 12 of its 24 runs (up to 2.77 mm, 0.22 dx, past a wall and 1.93 mm under the ground,
warp_mpm), the grid contact on none: its points were held on the planes after G2P (``box_hold``), the particle
contact's were not. The hold now takes both (``gasp_core.mpm.box_hold``), but for a point that started behind a plane,
which the penalty keeps at its starting depth.

Checks: the worst runs before (default tier, warp_mpm; taichi_mpm slow), the particle contact's family on both
engines (slow), the catch (``PARTICLE_HOLD`` off fails the worst runs), a point started under the ground kept at
its depth, and the codes (NumPy).
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from slopes import engine_param

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))

import extremes97 as X  # noqa: E402

from gasp_core.mpm import box_hold as BH  # noqa: E402

#: The runs the particle contact failed worst before round 97 (n_grid, direction, shape, speed m/s): 2.77 mm past a
#: wall and 1.93 mm under the ground; 2.57 mm past a wall; 1.86 mm past a wall from a throw down (warp_mpm).
WORST = [(48, "side", "ball", 50.0), (32, "side", "ball", 20.0), (48, "down", "ball", 50.0)]


def failure(engine: str, n_grid: int, direction: str, shape: str, speed: float) -> str | None:
    """None where the run (``extremes97.row``, the particle contact) ends, gains no energy and keeps every point on
    the ground's side of its plane and inside the walls' planes at every frame, else what it broke."""
    r = X.row(engine, shape, speed, direction, n_grid, "auto", "old")
    v = X.verdict(r)
    return None if v == "ok" else v


@pytest.mark.parametrize("engine", [engine_param("warp_mpm"), engine_param("taichi_mpm", marks=[pytest.mark.slow])])
@pytest.mark.parametrize("case", WORST, ids=["-".join(map(str, c)) for c in WORST])
def test_no_point_passes_the_ground_or_a_wall_on_the_particle_contact(engine, case):
    bad = failure(engine, *case)
    assert bad is None, f"{engine} {case}: {bad}"


@pytest.mark.slow
@pytest.mark.parametrize("engine", [engine_param("warp_mpm"), engine_param("taichi_mpm")])
def test_the_particle_contact_family(engine):
    """Every particle-contact run of ``extremes97`` (24 an engine)."""
    bad = {(n, d, sh, sp): f for n in X.GRIDS for d in X.DIRECTIONS for sh in X.SHAPES for sp in X.SPEEDS
           if (f := failure(engine, n, d, sh, sp)) is not None}
    assert not bad, f"{engine}: {bad}"


@pytest.mark.parametrize("engine", [engine_param("warp_mpm"), engine_param("taichi_mpm", marks=[pytest.mark.slow])])
def test_the_check_catches_the_rule_before(engine, monkeypatch):
    """``PARTICLE_HOLD`` off (the particle contact's points left to the penalty) fails each of :data:`WORST`."""
    monkeypatch.setattr(BH, "PARTICLE_HOLD", False)
    missed = [case for case in WORST if failure(engine, *case) is None]
    assert not missed, f"{engine}: the check misses the rule before on {missed}"


def _sunk_block():
    """A jelly block resting on the ground (z = 0) on the particle contact, its lowest layer of points started
    ``SUNK`` below the ground's plane (a capture's vertices through its ground)."""
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    from gasp_core.testing.helpers import box_points
    dx = 1.0 / 16
    x, p_vol = box_points([0.4, 0.4, 0.0], [0.6, 0.6, 0.1], dx / 2)
    low = x[:, 2] < x[:, 2].min() + 1e-9
    x[low, 2] -= SUNK
    return SimSetup(x=x, v=0.0, p_vol=p_vol, body_id=0, materials=[Material("jelly", E=1e5, nu=0.3, rho=1000.0)],
                    gravity=[0, 0, -9.81], domain_lo=np.array([0.0, 0.0, -0.25]), domain_hi=np.array([1.0, 1.0, 0.75]),
                    n_grid=16, frame_dt=1 / 30, boundaries=[Boundary("ground", height=0.0, friction=0.5)],
                    options={"contact": "particle"}), low


SUNK = 0.02   # m, about a third of a cell: the lowest layer's centres 3.3 mm below the plane


def _sunk_moves(engine: str) -> tuple[float, float]:
    """``(z0, z)``: the sunk layer's mean height at the start and after 3 frames (m)."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    s, low = _sunk_block()
    e = build_engine(engines()[engine], s)
    try:
        for _ in range(3):
            e.step_frame()
        z = np.asarray(e.positions(), np.float64)[low, 2]
    finally:
        e.close()
    assert np.all(np.isfinite(z))
    return float(s.x[low, 2].mean()), float(z.mean())


@pytest.mark.parametrize("engine", [engine_param("warp_mpm"), engine_param("taichi_mpm", marks=[pytest.mark.slow])])
def test_a_point_started_under_the_ground_keeps_its_depth(engine):
    """The hold leaves a point that started behind the ground to the penalty, which keeps it at its starting depth:
    the sunk layer (3.3 mm under the plane) stays within a millimetre of where it started."""
    z0, z = _sunk_moves(engine)
    assert z0 < -0.003 and abs(z - z0) < 1e-3, (z0, z)


@pytest.mark.parametrize("engine", [engine_param("warp_mpm"), engine_param("taichi_mpm", marks=[pytest.mark.slow])])
def test_the_depth_check_catches_a_hold_on_every_point(engine, monkeypatch):
    """Every point of the particle contact held (code ``GRID`` for the block): the sunk layer is lifted onto the
    plane, 3.3 mm, and the check above fails."""
    every = lambda setup, contact: np.full(len(setup.materials), BH.GRID, np.int32)   # noqa: E731
    monkeypatch.setattr(BH, "box_hold_codes", every)
    if engine == "taichi_mpm":
        monkeypatch.setattr("gasp_taichi_mpm.engine.box_hold_codes", every)
    z0, z = _sunk_moves(engine)
    assert abs(z - z0) >= 1e-3, (z0, z)


def test_the_codes():
    """NumPy: the grid contact's deformable bodies are held (1), the particle contact's in a scene with a ground or
    walls held but for the points that started behind a plane (2), rigid bodies and a scene without planes not (0);
    ``PARTICLE_HOLD`` off leaves the particle contact's unheld."""
    import dataclasses
    from gasp_core.seam.setup import Material
    s, _ = _sunk_block()
    two = dataclasses.replace(s, body_id=np.r_[np.zeros(len(s.x) // 2, int), np.ones(len(s.x) - len(s.x) // 2, int)],
                              materials=[s.materials[0], Material("jelly", model="rigid", E=1e10, nu=0.3, rho=700.0)])
    assert BH.box_hold_codes(two, "grid").tolist() == [BH.GRID, BH.NONE]
    assert BH.box_hold_codes(two, "particle").tolist() == [BH.PARTICLE, BH.NONE]
    assert BH.box_hold_codes(dataclasses.replace(two, boundaries=[]), "particle").tolist() == [BH.NONE, BH.NONE]
    old = BH.PARTICLE_HOLD
    try:
        BH.PARTICLE_HOLD = False
        assert BH.box_hold_codes(two, "particle").tolist() == [BH.NONE, BH.NONE]
    finally:
        BH.PARTICLE_HOLD = old
