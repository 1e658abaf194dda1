"""Round 85 (issue 67, a neighbour of item 1's rigid block on a slope; ``docs/rigid.md`` "Round 85: tipping"): a rigid
tall block on a slope stands while its weight's line falls inside its base and tips over its downhill edge once it
falls outside: the statics of a rigid body, ``tan theta = w / h`` (w its width along the slope, h its height).

The scene is ``tests/test_elastic_slope.py``'s ground with gravity tilted by ``theta``, friction ``MU`` 0.9 (above
``tan theta`` in every case, so nothing slides), and a hardwood block (E 1e10, rho 700, ``model = "rigid"``) set down
on it: 10 x 10 x 20 cm (tips at 26.57 degrees) and 10 x 10 x 15 cm (33.69). Two-sided, ``MARGIN`` degrees either side
of the closed form: below, it stands (turned under ``STAND_DEG`` and moved under 1 mm in 1 s); above, it tips
(turned past ``TIP_DEG`` at some frame of the second).

Before round 85 the rigid route held the tipping moment twice: the slide brake held the friction's moment up to
``J a`` (``a`` the patch's half-width) on top of what the normal impulses, leaning to the downhill edge, already
held. The blocks stood 3 degrees past their angle on every grid but one (five of six cases), creeping 1.3-2.6 mm
down the slope instead. ``gasp_core.mpm.rigid_friction.TIP_SHARED`` counts the normal impulses' moment as part of the
hold. Its catch: with the switch off (the rule before, in a fresh process) the 15 cm block at 3 degrees past its
angle stands.
"""
from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from slopes import engine_param, turn_deg
from test_elastic_slope import FPS, block_setup

from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import get_engine

MU = 0.9
#: Degrees either side of ``atan(w / h)`` the family is run at.
MARGIN = 3.0
#: Stands: turned under this (degrees) at the end; tips: turned past ``TIP_DEG`` at some frame.
STAND_DEG, TIP_DEG = 2.0, 20.0
STAND_MM = 1.0
BLOCKS = {"tall20": (0.1, 0.1, 0.2), "tall15": (0.1, 0.1, 0.15)}
#: Measured misses, strict xfails: (block, n_grid, side) -> the figure. Round 85's one, the 20 cm block on n_grid 32
#: 3 degrees below its angle (it crept 1.35 mm in 1 s), stands since round 86 (0.38 mm, turned 0.08 degree; warp_mpm):
#: the balance no longer takes back the torque of its flat base (``gasp_core.mpm.take_back``). It still tips from 1
#: degree below its angle (the penalty's pivot half a spacing inside the face; docs/rigid.md "Round 85: tipping").
MISSES: dict = {}


def critical(side) -> float:
    """The slope (degrees) past which a rigid block of ``side`` (m) tips: ``atan(w / h)``."""
    return math.degrees(math.atan(side[0] / side[2]))


def tip_figures(engine: str, side, theta: float, n_grid: int, frames: int = FPS) -> tuple[float, float, float]:
    """The rigid block of ``side`` on ``theta`` degrees: its largest turn over the frames (degrees, either way), its
    turn and its centroid's travel (mm) at the last frame."""
    s = block_setup(theta, MU, "particle", side, n_grid)
    s.materials = [dataclasses.replace(m, model="rigid", E=1.0e10, rho=700.0) for m in s.materials]
    x0 = np.asarray(s.x, float)
    most, turn = 0.0, 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        e = build_engine(get_engine(engine), s)
        try:
            for _ in range(frames):
                e.step_frame()
                x = np.asarray(e.positions(), float)
                turn = turn_deg(x0, x)
                most = max(most, abs(turn))
        finally:
            e.close()
    return most, turn, 1000.0 * float(np.linalg.norm(x.mean(axis=0) - x0.mean(axis=0)))


def problem(where: str, figures) -> str | None:
    """None when the block did what the statics say ``where`` ("below" or "above" its angle), else what it did."""
    most, turn, travel = figures
    if where == "below":
        ok = abs(turn) < STAND_DEG and most < STAND_DEG and travel < STAND_MM
        return None if ok else f"should stand: turned {turn:.2f} deg (most {most:.1f}), moved {travel:.2f} mm"
    return None if most > TIP_DEG else f"should tip: turned at most {most:.2f} deg, moved {travel:.2f} mm"


def _cases():
    for name in BLOCKS:
        for n_grid in (24, 32, 48):
            for where in ("below", "above"):
                why = MISSES.get((name, n_grid, where))
                miss = [pytest.mark.xfail(strict=True, reason=why)] if why else []
                for engine in ("warp_mpm", "taichi_mpm"):
                    slow = [pytest.mark.slow] if (engine, n_grid) != ("warp_mpm", 24) else []
                    yield pytest.param(engine, name, n_grid, where, marks=[*engine_param(engine).marks, *miss, *slow],
                                       id=f"{engine}-{name}-{n_grid}-{where}")


@pytest.mark.parametrize("engine,name,n_grid,where", list(_cases()))
def test_a_rigid_tall_block_tips_where_its_weight_leaves_its_base(engine, name, n_grid, where):
    side = BLOCKS[name]
    theta = critical(side) + (MARGIN if where == "above" else -MARGIN)
    assert problem(where, tip_figures(engine, side, theta, n_grid)) is None


CATCH = """
import sys
sys.path.insert(0, {tests!r})
import gasp_core.mpm.rigid_friction as rf
rf.TIP_SHARED = False
from test_rigid_tip import BLOCKS, MARGIN, critical, problem, tip_figures
side = BLOCKS["tall15"]
print(problem("above", tip_figures({engine!r}, side, critical(side) + MARGIN, 24)))
"""


@pytest.mark.parametrize("engine", [engine_param("warp_mpm"), engine_param("taichi_mpm", marks=[pytest.mark.slow])])
def test_the_tip_check_catches_the_rule_that_holds_the_moment_twice(engine):
    """The rule before round 85 (``TIP_SHARED`` off, set before the engines compile, so in a fresh process): the 15 cm
    block 3 degrees past its angle stands, and the check says so."""
    code = CATCH.format(tests=str(Path(__file__).resolve().parent), engine=engine)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1].startswith("should tip"), out.stdout[-500:]
