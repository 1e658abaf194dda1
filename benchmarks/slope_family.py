"""A rigid block on a slope over other shapes, sizes and grids than tests/test_rigid_slope.py's, on both MPM engines
(issue 67): a plank (8 x 4 x 1.5 cells, n_grid 32), a cube (4 cells, n_grid 24), a slab (10 x 10 x 2, n_grid 40), each
at 30 deg / mu 0.3 and 45 deg / mu 0.6 (slides: a against g (sin - mu cos)) and 15 deg / mu 0.4 (sticks), judged by the
test's own two-sided check. Prints one line a case; ``python benchmarks/slope_family.py | tee
benchmarks/results/slope_family.txt``."""
import math, sys
import numpy as np
sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1] / "tests"))
import test_rigid_slope as rs
from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing.helpers import box_points, make_setup

def setup_for(cells, n_grid):
    def build(theta, mu):
        dx = rs.SIDE / n_grid
        side = np.array(cells, float) * dx
        lo = np.array([4.3 * dx, rs.SIDE / 2 - side[1] / 2 + 0.2 * dx, rs.GROUND])
        x, p_vol = box_points(lo, lo + side, dx / 2)
        t = math.radians(theta)
        s = make_setup(x, p_vol, Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0),
                       gravity=(rs.G * math.sin(t), 0.0, -rs.G * math.cos(t)), lo=np.zeros(3), hi=np.full(3, rs.SIDE),
                       n_grid=n_grid, frame_dt=1.0 / rs.FPS, boundaries=[Boundary("ground", height=rs.GROUND, friction=mu)])
        s.n_render = 0
        return s
    return build

for name, cells, ng in (("plank 8x4x1.5", (8, 4, 1.5), 32), ("cube 4x4x4", (4, 4, 4), 24), ("slab 10x10x2", (10, 10, 2), 40)):
    rs.block_setup = setup_for(cells, ng)
    for eng in ("taichi_mpm", "warp_mpm"):
        for theta, mu in ((30, 0.3), (45, 0.6), (15, 0.4)):
            fig = rs.measure(eng, theta, mu)
            a0 = rs.closed_form(theta, mu)
            what = f"a {fig:.4f} vs {a0:.4f} ({100*(fig/a0-1):+.2f} %)" if a0 > 0 else f"moved {fig:.3f} mm"
            print(f"{name:14s} n_grid {ng} {eng:10s} {theta} deg mu {mu}: {what}; {'ok' if rs.check(theta, mu, fig) is None else 'FAIL'}", flush=True)
