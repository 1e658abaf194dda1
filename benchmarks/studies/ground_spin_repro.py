"""Repro of issue 17 item 1: a jelly ball dropped on a frictional ground drifts / spins."""
import sys, math, argparse, time
import numpy as np
from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import engines
from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing.helpers import sphere_points, make_setup

ap = argparse.ArgumentParser()
ap.add_argument("--engine", default="warp_mpm")
ap.add_argument("--mu", type=float, default=0.5)
ap.add_argument("--frames", type=int, default=40)
ap.add_argument("--n_grid", type=int, default=16)
ap.add_argument("--drop", type=float, default=0.05)
ap.add_argument("--off", type=float, nargs=2, default=[0.3, 0.2])  # centre offset from a node, dx
ap.add_argument("--cfl", type=float, default=None)
ap.add_argument("--ppc", type=float, default=2.0)  # points per dx
ap.add_argument("--prec", default="f32")
ap.add_argument("--E", type=float, default=2e4)
args = ap.parse_args()

SIDE = 0.3; ng = args.n_grid; dx = SIDE / ng
LO = np.array([-SIDE / 2, -SIDE / 2, -3 * (0.3 / 16)])
R = 0.05
c = np.array([LO[0] + round(-LO[0] / dx) * dx + args.off[0] * dx, LO[1] + round(-LO[1] / dx) * dx + args.off[1] * dx, R + args.drop])
x, pv = sphere_points(c, R, dx / args.ppc)
opts = {"precision": args.prec}
if args.engine == "taichi_mpm": opts["threads"] = 1
if args.cfl: opts["cfl"] = args.cfl
setup = make_setup(x, pv, Material("jelly", E=args.E, nu=0.3, rho=300.0), lo=LO, hi=LO + SIDE, n_grid=ng,
                   boundaries=[Boundary("ground", height=0.0, friction=args.mu)], options=opts)
eng = build_engine(engines()[args.engine], setup)
m = setup.p_mass / setup.p_mass.sum()
x0 = setup.x.copy(); c0 = m @ x0
def kabsch(a, b):  # rotation taking a (centred) to b (centred)
    H = (a * m[:, None]).T @ b
    U, S, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T))
    Rm = Vt.T @ np.diag([1, 1, d]) @ U.T
    return math.degrees(math.acos(max(-1, min(1, (np.trace(Rm) - 1) / 2))))
t0 = time.time()
rows = []
for f in range(1, args.frames + 1):
    eng.step_frame()
    xp = np.asarray(eng.positions(), np.float64)
    cc = m @ xp
    ang = kabsch(x0 - c0, xp - cc)
    rows.append((f, *(1e3 * (cc - c0)), ang))
    if f % 5 == 0 or f == args.frames:
        print(f"f{f:3d} dx {1e3*(cc-c0)[0]:+8.3f} dy {1e3*(cc-c0)[1]:+8.3f} dz {1e3*(cc-c0)[2]:+8.2f} mm  spin {ang:7.3f} deg", flush=True)
print("n_points", len(x), "time", round(time.time() - t0, 1), file=sys.stderr)
eng.close()
