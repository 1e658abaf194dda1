"""Round 92 (issue 67 items 2 and 4, a round body in a concave rigid body; ``docs/rigid.md`` "Round 92"): a rigid ball
rolling in a spherical hollow cut into a heavy rigid block, against the pendulum's period of its own inertia.

Round 91 took a round body's contact normal with another rigid body from the two bodies' support tables (the
separating axis, ``gasp_core.mpm.rigid_support.round_normal``). A table is the body's hull, so for a ball inside a
hollow it says nothing; ``rigid_support.ROUND_DEEP`` then keeps the touching nodes' normal. Round 91 tested that rule
on NumPy alone. This runs it: ``tests/test_roll_collider.py``'s bowl (radius ``BOWL_R`` 0.25 m, the ball's ``BALL_R``
0.05 m released at rest 20 degrees up), but the bowl is a rigid body: a block 0.56 x 0.56 x 0.2 m, ten times the
ball's density, with the sphere cut out of its top, lying on a ground of friction 1. The block is about 800 times the
ball's mass, so it is held to a fraction of a millimetre, and the ball's centre is read relative to the block's.

Judged as the collider's bowl: the time between the centre's first two passes under the hollow's centre against the
closed form of the ball's own inertia (``test_roll_collider.bowl_half_period``), within ``test_rolling.TOL`` (5 %)
two-sided. The family: n_grid 32 and 48 (the collider bowl's 32), the ball's and the hollow's Gaussians sampled on
their spheres ("fibonacci") or scan-like ("scan", :func:`hollow_block`), the pair's mu 0.5 (rolls) and 0 (slides:
the swing of a point mass, ``k`` 0).

``--shape cylinder``: ``roll_family88``'s solid cylinder (R 5 cm, 15 cm long) in a trough of radius 25 cm along its
axis instead (:func:`trough_gaussians`), the same family.

``python benchmarks/studies/roll_bowl92.py --engine warp_mpm --out benchmarks/results/roll_bowl92_warp.json``
(refused if the file exists); ``--hollow-rule 0``: the touching nodes' normal in the hollow (round 91's, the broken
variant).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import roll_family88 as RF  # noqa: E402
import test_roll_collider as rc  # noqa: E402
import test_rolling as rl  # noqa: E402

#: The block's bounds (m) and its density over the ball's.
BLOCK_LO, BLOCK_HI, DENSITY_RATIO = np.array([0.02, 0.02, 0.0]), np.array([0.58, 0.58, 0.2]), 10.0
#: Round 95: the seed of the scan-like sampling of the hollow's or trough's Gaussians.
SCAN_SEED = 1


def family() -> list[tuple[int, str, float, str]]:
    """``(n_grid, sampling, mu, hollow)``: the ball's Gaussians and the hollow's sampled alike."""
    return [(n, s, mu, s) for n in (32, 48) for s in ("fibonacci", "scan") for mu in (rl.ROLL_MU, 0.0)]


def hollow_block(s: float, hollow: str, shape: str = "ball") -> np.ndarray:
    """The block's points (m), spacing ``s``: its fill (a lattice, cut half a spacing outside the hollow's sphere)
    and, unless ``hollow`` is "fill", the hollow's own Gaussians on its sphere (below the block's top) at the ball's
    areal density: on a Fibonacci sphere ("fibonacci") or scan-like, at random and jittered by a quarter of their
    spacing along the normal ("scan"). The fill alone is a staircase: its bottom terraces are
    ``sqrt(2 BOWL_R s)`` (7 cm at n_grid 32) wide. ``shape`` "cylinder": a trough instead, the hollow a cylinder of
    radius ``BOWL_R`` along y (its Gaussians on a grid of the same spacing, or scan-like)."""
    from gasp_core.testing.helpers import box_points
    x, _ = box_points(BLOCK_LO, BLOCK_HI, s)
    axes = [0, 1, 2] if shape == "ball" else [0, 2]
    x = x[np.linalg.norm((x - rc.BOWL_C)[:, axes], axis=1) >= rc.BOWL_R + s / 2]
    if hollow == "fill":
        return x
    if shape == "cylinder":
        return np.concatenate([trough_gaussians(hollow), x])
    n = int(round(rl.N_SHELL * (rc.BOWL_R / 0.1) ** 2))
    if hollow == "scan":
        shell = RF.scan_sphere(rc.BOWL_C, rc.BOWL_R, n, seed=SCAN_SEED)
    else:
        shell = rc.BOWL_C + rc.BOWL_R * rl.fibonacci_sphere(n)
    inside = np.all((shell > BLOCK_LO) & (shell < BLOCK_HI), axis=1)
    return np.concatenate([shell[inside], x])


def trough_gaussians(hollow: str) -> np.ndarray:
    """The trough's Gaussians (m): on its cylinder (radius ``BOWL_R`` about the line through ``BOWL_C`` along y,
    inside the block) at the ball's areal spacing, on a grid ("fibonacci") or at random, jittered a quarter spacing
    along the normal ("scan")."""
    sp = math.sqrt(4.0 * math.pi / rl.N_SHELL) * 0.1
    n_phi, n_y = int(2 * math.pi * rc.BOWL_R / sp), int((BLOCK_HI[1] - BLOCK_LO[1]) / sp)
    if hollow == "scan":
        rng = np.random.default_rng(SCAN_SEED)
        phi = rng.uniform(0.0, 2 * math.pi, n_phi * n_y)
        y = rng.uniform(BLOCK_LO[1], BLOCK_HI[1], n_phi * n_y)
        r = rc.BOWL_R + rng.uniform(-sp / 4, sp / 4, n_phi * n_y)
    else:
        P, Y = np.meshgrid((np.arange(n_phi) + 0.5) * 2 * math.pi / n_phi,
                           BLOCK_LO[1] + (np.arange(n_y) + 0.5) * (BLOCK_HI[1] - BLOCK_LO[1]) / n_y, indexing="ij")
        phi, y, r = P.ravel(), Y.ravel(), np.full(P.size, rc.BOWL_R)
    g = np.stack([rc.BOWL_C[0] + r * np.cos(phi), y, rc.BOWL_C[2] + r * np.sin(phi)], axis=1)
    return g[np.all((g > BLOCK_LO) & (g < BLOCK_HI), axis=1)]


def setup(n_grid: int, sampling: str, mu: float, hollow: str = "fibonacci", shape: str = "ball"):
    """``(SimSetup, k)``: body 0 the ball (its Gaussians first), body 1 the block with its hollow
    (:func:`hollow_block`); ``shape`` "cylinder": ``roll_family88``'s solid cylinder (15 cm long, along y) in a
    trough."""
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    dx = rc.BOX / n_grid
    x, vol, n_render = RF.body(shape, rc.BALL_R, n_grid, sampling)
    k = RF.inertia_share(x, vol, rc.BALL_R)
    t0 = math.radians(rc.THETA0)
    centre = rc.BOWL_C + (rc.BOWL_R - rc.BALL_R) * np.array([math.sin(t0), 0.0, -math.cos(t0)])
    x = x - (vol[:, None] * x).sum(0) / vol.sum() + centre
    xs = hollow_block(dx / 2, hollow, shape)
    pvs = (dx / 2) ** 3
    mats = [Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0 * r, friction=mu)
            for r in (1.0, DENSITY_RATIO)]
    lo = np.array([0.0, 0.0, -3 * dx])
    s = SimSetup(x=np.concatenate([x, xs]), v=0.0, p_vol=np.r_[vol, np.full(len(xs), pvs)],
                 body_id=np.r_[np.zeros(len(x), int), np.ones(len(xs), int)], materials=mats,
                 gravity=np.array([0.0, 0.0, -rl.G]), domain_lo=lo, domain_hi=lo + rc.BOX, n_grid=n_grid,
                 frame_dt=1.0 / rc.FPS, boundaries=[Boundary("ground", height=0.0, friction=1.0)])
    s.n_render = n_render
    return s, k


def figures(engine: str, s) -> dict:
    """``half`` (s: between the ball's centre's first two passes under the hollow's centre, relative to the block,
    linear between frames), ``block`` (the block's largest point speed over the run, m/s) and ``out`` (m: the largest
    departure of the ball's centre from the sphere it should roll on, ``BOWL_R - BALL_R`` about the hollow's centre;
    positive: farther out, the ball sunk into the block's wall)."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    b, m = np.asarray(s.body_id), np.asarray(s.p_mass, np.float64)
    mb, ms = m[b == 0], m[b == 1]
    x0 = np.asarray(s.x, np.float64)
    hollow0 = rc.BOWL_C - (ms[:, None] * x0[b == 1]).sum(0) / ms.sum()
    e = build_engine(get_engine(engine), s)
    cx, dist, block = [], [], 0.0
    for _ in range(round(rc.BOWL_T * rc.FPS)):
        e.step_frame()
        X, V = e.positions().astype(np.float64), e.velocities().astype(np.float64)
        c = (mb[:, None] * X[b == 0]).sum(0) / mb.sum()
        hollow = (ms[:, None] * X[b == 1]).sum(0) / ms.sum() + hollow0
        cx.append(c[0] - hollow[0])
        dist.append(np.linalg.norm((c - hollow)[[0, 2]]))   # across y: a trough's axis
        block = max(block, float(np.abs(V[b == 1]).max()))
    e.close()
    c, t = np.array(cx), np.arange(1, len(cx) + 1) / rc.FPS
    cross = [t[i] + (t[i + 1] - t[i]) * c[i] / (c[i] - c[i + 1]) for i in range(len(c) - 1)
             if c[i] != 0.0 and np.sign(c[i]) != np.sign(c[i + 1])]
    d = np.array(dist) - (rc.BOWL_R - rc.BALL_R)
    return {"half": cross[1] - cross[0] if len(cross) >= 2 else math.inf, "block": block,
            "out": float(d[np.argmax(np.abs(d))])}


def row(engine: str, n_grid: int, sampling: str, mu: float, hollow: str = "fibonacci", shape: str = "ball") -> dict:
    s, k = setup(n_grid, sampling, mu, hollow, shape)
    t0 = time.time()
    fig = figures(engine, s)
    want = rc.bowl_half_period(k if mu > 0 else 0.0)
    err = fig["half"] / want - 1.0
    return {"engine": engine, "shape": shape, "n_grid": n_grid, "sampling": sampling, "hollow": hollow, "mu": mu, "k": k, **fig,
            "want": want,
            "err": err, "problem": None if abs(err) <= rl.TOL else f"half period {100 * err:+.2f} %",
            "wall_s": time.time() - t0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--shape", default="ball", help="ball (in a spherical hollow) or cylinder (in a trough)")
    ap.add_argument("--hollow-rule", type=int, default=1,
                    help="gasp_core.mpm.hollow.HOLLOW (0: the touching nodes' normal in a hollow, round 91's, the "
                         "broken variant)")
    ap.add_argument("--only", default=None, help="n_grid,sampling,mu,hollow: one case (hollow: fibonacci, scan or "
                                                 "fill, the fill alone: a staircase)")
    ap.add_argument("--seed", type=int, default=SCAN_SEED, help="round 95: the seed of the hollow's or trough's scan-like "
                                                                 "Gaussians (SCAN_SEED)")
    ap.add_argument("--out", default=None, help="a new JSON file for the rows (refused if it exists)")
    a = ap.parse_args(argv)
    globals()["SCAN_SEED"] = a.seed
    import gasp_core.mpm.hollow as hw
    hw.HOLLOW = a.hollow_rule
    out = RF.new_out(ap, a.out)
    o = None if a.only is None else a.only.split(",")
    cases = family() if o is None else [(int(o[0]), o[1], float(o[2]), o[3] if len(o) > 3 else "fibonacci")]
    rows = []
    for case in cases:
        rows.append(row(a.engine, *case, shape=a.shape))
        r = rows[-1]
        print(f"{a.engine} {a.shape} n_grid {r['n_grid']} {r['sampling']} in {r['hollow']} mu {r['mu']}: half period "
              f"{r['half']:.4f} s "
              f"(want {r['want']:.4f}, {100 * r['err']:+.2f} %), block {r['block']:.4f} m/s, off the sphere "
              f"{1e3 * r['out']:+.2f} mm; {r['problem'] or 'ok'} ({r['wall_s']:.0f} s)", flush=True)
    RF.write_rows(out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
