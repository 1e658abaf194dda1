"""A sand body's default domain holds its collapse on the ground (``gasp_core.prepare.runout``, issue 53: the sand
column against the jelly ball, made as a user makes it, ran out of the default domain at frame 8 on both grid
engines).

Known answers: Lube et al. 2004's axisymmetric runout law (``r_inf / r_i - 1 = 1.24 a`` below ``a`` = 1.7,
``1.6 a^(1/2)`` above); the column of ``benchmarks/sand_ball_pipeline.py`` (flat Gaussians on a 6 x 6 x 15 cm box,
10 mm apart, sand at 30 deg, beside the 5 cm jelly ball, no ``[domain]`` lo/hi) runs 12 frames through ``gasp simulate`` where it ran out of the
grid at frame 8 before, and its domain holds the law's runout with its margin."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from gasp_testing import ROOT

sys.path.insert(0, str(ROOT / "benchmarks"))
import sand_ball_pipeline as sb  # noqa: E402

from gasp_core.prepare.runout import RUNOUT_SAFETY, column_runout, runout_reach, widen  # noqa: E402
from gasp_core.seam.setup import Material  # noqa: E402


def test_the_runout_follows_lubes_law():
    assert math.isclose(column_runout(0.1, 0.1), 0.1 * 2.24)            # a = 1: r_i (1 + 1.24)
    assert math.isclose(column_runout(0.4, 0.1), 0.1 * (1 + 1.6 * 2))   # a = 4: r_i (1 + 1.6 sqrt(4))
    a_lo, a_hi = column_runout(0.1699, 0.1), column_runout(0.1701, 0.1)
    assert abs(a_hi / a_lo - 1) < 0.01, "the two branches meet within 1 % at a = 1.7"


def test_only_sand_on_a_ground_spreads_and_a_domain_that_holds_it_is_kept():
    box = np.array([[x, y, z] for x in (0, 0.06) for y in (0, 0.06) for z in (0, 0.15)], float)
    sand, jelly = Material("sand", E=3.5e5, friction_angle=30.0), Material("jelly", E=1e5)
    reach = runout_reach([box], [sand], 0.0)
    r = RUNOUT_SAFETY * column_runout(0.15, math.sqrt(0.06 * 0.06 * 0.15 / (math.pi * 0.15)))
    assert np.allclose(reach[:, :2].min(axis=0), 0.03 - r) and np.allclose(reach[:, 2], 0.0)
    assert len(runout_reach([box], [jelly], 0.0)) == 0 and len(runout_reach([box], [sand], None)) == 0
    lo, hi = np.array([-1.0, -1.0, 0.0]), np.array([1.0, 1.0, 2.0])
    assert widen(lo, hi, reach, 32, 3.0) == (lo, hi)
    lo2, hi2 = widen(lo / 20, hi / 20, reach, 32, 3.0)
    side = hi2[0] - lo2[0]
    assert lo2[2] == 0.0 and np.allclose(hi2 - lo2, side)
    assert np.all(lo2[:2] <= reach[:, :2].min(axis=0) - 3 * side / 32 + 1e-12)


@pytest.mark.skipif(not any(__import__("importlib").util.find_spec(m) for m in ("gasp_warp_mpm",)),
                    reason="warp_mpm not installed")
def test_the_users_sand_column_stays_in_its_default_domain(tmp_path):
    path = sb.scene(tmp_path, 0.01, "warp_mpm", 12, ball=True)
    out = tmp_path / "out"
    p = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(path), "-o", str(out), "-q"],
                       capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0, p.stderr[-600:]
    assert len(list((out / "sand").glob("frame_*.ply"))) == 13


@pytest.mark.skipif(not any(__import__("importlib").util.find_spec(m) for m in ("gasp_warp_mpm",)),
                    reason="warp_mpm not installed")
def test_the_users_passive_sand_gaussians_slide_on_the_ball(tmp_path):
    """The same column run to its end (60 frames) with the free column: its Gaussians are passive (``surface =
    "auto"`` on sand) and read their body's own velocity field (the two-field contact's offset, both engines'
    passive G2P), so none stays on the ball's steep side and the pile against the ball is 1.65 times the free pile's
    (warp_mpm; taichi_mpm 1.53). Read from the whole grid's velocity, as before, they stuck to the ball: a wedge
    3.96 times the free pile, 2 % of them on its steep side. The issue's 20 % is not met (docs/contact.md);
    ``PILE_LIMIT`` holds today's figure with room and fails the sticking read."""
    PILE_LIMIT = 2.0
    runs = {}
    for ball in (True, False):
        out = tmp_path / f"out_{int(ball)}"
        seconds, err = sb.simulate(sb.scene(tmp_path, 0.01, "warp_mpm", 60, ball), out)
        assert err is None, err
        runs[ball] = out
    f = sb.figures(runs[True], runs[False])
    assert f["steep"] <= 0.01, f
    assert 1.0 <= f["pile"] <= PILE_LIMIT, f
