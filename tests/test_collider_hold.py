"""The colliders' hold on the grid contact's points (docs/colliders.md "The hold"; warp_mpm's
``colliders.build_collider_hold``, taichi_mpm's ``Colliders.hold_point``).

Known answer: a sand block (the grid contact) thrown at 2 m/s, without gravity, at a wall one grid cell thick (a box
collider, frictionless) stops at the wall's near face: its leading points end within :data:`TOL` cells of it and
none beyond the far face. Before the hold the grid rule alone let the whole block through (600 of 600 points beyond
the far face, the front 6.1 cells past the near one, on both engines): inside a wall thinner than the stencil the
nodes' outward normals point through the far face, so the rule saw the incoming sand as separating; a wall three
cells thick was entered 0.64 cells deep. The kitchen's spinach passed the pan's wall so (docs/colliders.md)."""
from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from gasp_core.colliders.sdf import SDF_SPACING, box_collider
from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import engines
from gasp_core.seam.setup import Material
from gasp_core.testing.helpers import box_points, make_setup

ENGINES = [e for e, mod in (("taichi_mpm", "gasp_taichi_mpm"), ("warp_mpm", "gasp_warp_mpm"))
           if importlib.util.find_spec(mod) is not None]
if not ENGINES:
    pytest.skip("no grid engine installed", allow_module_level=True)

N_GRID = 32
DX = 1.0 / N_GRID
WALL = 0.6
#: How far (cells) the block's front may end from the wall's near face, either side.
TOL = 0.1


def thrown_at_wall(engine: str, thick: float = 1.0) -> tuple[float, int]:
    """The sand block's front over the wall's near face at the end (cells) and its points beyond the far face."""
    x, p_vol = box_points((0.40, 0.42, 0.42), (0.50, 0.58, 0.58), DX / 2)
    s = make_setup(x, p_vol, Material("sand", E=3.5e5, nu=0.3, rho=1600.0, friction_angle=30.0), n_grid=N_GRID,
                   frame_dt=0.01, gravity=(0.0, 0.0, 0.0), v=(2.0, 0.0, 0.0))
    half = np.array([thick * DX / 2, 0.3, 0.3])
    s.colliders = [box_collider(half, SDF_SPACING * DX, name="wall", friction=0.0,
                                position=(WALL + half[0], 0.5, 0.5))]
    eng = build_engine(engines()[engine], s)
    for _ in range(15):   # 0.15 s: 0.3 m of free flight, the wall 0.1 m ahead
        eng.step_frame()
    xs = eng.positions()
    eng.close()
    return float((xs[:, 0].max() - WALL) / DX), int((xs[:, 0] > WALL + 2 * half[0]).sum())


@pytest.mark.parametrize("engine", ENGINES)
def test_sand_thrown_at_a_thin_wall_stops_at_its_face(engine):
    front, through = thrown_at_wall(engine)
    assert through == 0, f"{engine}: {through} sand points passed a wall one cell thick"
    assert abs(front) < TOL, f"{engine}: the block's front ends {front:+.3f} cells from the wall's face"


@pytest.mark.parametrize("engine", ENGINES)
def test_the_check_fails_without_the_hold(engine, monkeypatch):
    """The engine with its hold switched off (the grid rule alone, as before) fails the check above."""
    if engine == "warp_mpm":
        from gasp_warp_mpm import engine as wm
        monkeypatch.setattr(wm, "hold_launches", lambda *a: [])
    else:
        from gasp_taichi_mpm.colliders import Colliders
        allocate = Colliders.allocate_hold
        monkeypatch.setattr(Colliders, "allocate_hold",   # the colliders' hold off, the ground's and walls' kept
                            lambda self, hold, box_hold=None: allocate(self, None, box_hold))
    front, through = thrown_at_wall(engine)
    assert through > 0 or abs(front) >= TOL, f"{engine}: without the hold the check still passes"
