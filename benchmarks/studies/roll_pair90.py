"""Round 90 (issue 67 items 1-2, "body on body"; ``docs/rigid.md`` "Round 90: a round body on another rigid body"):
``roll_family88.py``'s rigid balls and solid cylinders (radii, grids, the ways their Gaussians sample them) set on a
rigid slab instead of the ground, judged by ``test_rolling``'s two-sided check (5 %) against the closed forms of each
body's own inertia.

The scene is ``ball_slope_rigid.py``'s (round 65): a rigid slab 32 x 24 x 3 cm lies on a ground of friction 1 (above
``tan 20 deg``: it stays) in a 0.48 m box, gravity tilted 20 degrees about y; the body (hardwood, E 1e10 Pa, rho 700,
``model = "rigid"``) starts at rest on it, the pair's friction ``mu`` (both bodies' ``friction``). The pair meets through
the rigid pair law (``gasp_core.mpm.rigid_friction.pair_contact``: the nodes' contact, the support tables' flatness and
contact plane). Since round 90 a round body's table is its exact shape's and the contact is taken on its surface
(``gasp_core.mpm.rigid_pairs.ROUND_PAIR``; ``--round-pair 0``: round 65's tables of its points and the midway plane).
The grid: n_grid 24, 32 and 48 in the 0.48 m box (the cells of ``roll_family88``'s 30, 40 and 60 in its 0.6 m box).
The body's motion is read relative to the slab's (the ground holds the slab to a few mm/s).
``python benchmarks/studies/roll_pair90.py --engine warp_mpm --out benchmarks/results/roll_pair90_warp.json``
(refused if the file exists).
"""
from __future__ import annotations

import argparse
import itertools
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import roll_family88 as RF  # noqa: E402
import test_rolling as rl  # noqa: E402

SIDE, FPS = 0.48, 60
RADII, GRIDS = (0.05, 0.1), (24, 32, 48)
SAMPLED_AT = ((0.05, 48),)


def family() -> list[tuple[float, int, str]]:
    """``(radius m, n_grid, sampling)``: every radius and grid on the test's sampling, the others on the 5 cm body at
    n_grid 48."""
    return [(r, n, "fibonacci") for r in RADII for n in GRIDS] + [(r, n, s) for r, n in SAMPLED_AT
                                                                      for s in RF.SAMPLINGS if s != "fibonacci"]


def setup(shape: str, radius: float, n_grid: int, sampling: str, mu: float, slab: str = "lattice", seed: int = 1):
    """``(SimSetup, k, n_render)``: body 0 the round body (its Gaussians first), body 1 the slab: a lattice at
    ``dx / 2``, and with ``slab`` "scan" (round 93) Gaussians on its top face as a scanned table's (:func:`scan_top`,
    its draw ``seed``)."""
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    from gasp_core.testing.helpers import box_points
    dx = SIDE / n_grid
    x, vol, n_render = RF.body(shape, radius, round(n_grid * 0.6 / SIDE), sampling)
    k = RF.inertia_share(x, vol, radius)
    x = x - (vol[:, None] * x).sum(0) / vol.sum() + np.array([-0.06, 0.0, 0.03 + radius])
    xs, pvs = box_points([-0.12, -0.12, 0.0], [0.20, 0.12, 0.03], dx / 2)
    if slab == "scan":
        xs = np.concatenate([scan_top(dx, seed), xs])
    th = np.radians(rl.THETA)
    mats = [Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0, friction=mu) for _ in range(2)]
    lo = np.array([-0.20, -SIDE / 2, -3 * dx])
    s = SimSetup(x=np.concatenate([x, xs]), v=0.0, p_vol=np.r_[vol, np.full(len(xs), pvs)],
                 body_id=np.r_[np.zeros(len(x), int), np.ones(len(xs), int)], materials=mats,
                 gravity=rl.G * np.array([np.sin(th), 0.0, -np.cos(th)]), domain_lo=lo, domain_hi=lo + SIDE,
                 n_grid=n_grid, frame_dt=1.0 / FPS, boundaries=[Boundary("ground", height=0.0, friction=1.0)])
    s.n_render = n_render
    return s, k, n_render


def scan_top(dx: float, seed: int = 1) -> np.ndarray:
    """Round 93: Gaussians on the slab's top face (z 0.03 m) as a scan leaves them (m): a grid of ``dx / 4``, each
    moved at random by up to half its spacing across the face and a quarter along its normal."""
    rng = np.random.default_rng(seed)
    sp = dx / 4
    g = np.stack(np.meshgrid(np.arange(-0.12 + sp / 2, 0.20, sp), np.arange(-0.12 + sp / 2, 0.12, sp),
                             indexing="ij"), axis=-1).reshape(-1, 2)
    g = np.clip(g + rng.uniform(-sp / 2, sp / 2, g.shape), [-0.12, -0.12], [0.20, 0.12])
    return np.c_[g, 0.03 + rng.uniform(-sp / 4, sp / 4, len(g))]


def figures(engine: str, s, radius: float) -> dict:
    """``a`` (m/s^2: a parabola fitted to the body's centre along x, relative to the slab's, from
    ``test_rolling.FIT_FROM`` s), ``wR`` (its spin about y times ``radius`` at ``test_rolling.T``), ``v`` (its speed
    along x relative to the slab's then), ``slab`` (the slab's largest point speed over the run, m/s: the ground
    holds it to a few mm/s, its creep taken out by the relative measure) and ``sink`` (round 91: how far the body's
    centre came down towards the slab's over the run, m; the pair's contact normal from its nodes let the 10 cm
    cylinder sink 1.7 mm)."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    b, m = np.asarray(s.body_id), np.asarray(s.p_mass, np.float64)
    mb, ms = m[b == 0], m[b == 1]
    e = build_engine(get_engine(engine), s)
    cs, vs, ws, slab = [], [], [], 0.0
    for _ in range(round(rl.T * FPS)):
        e.step_frame()
        X, V = e.positions().astype(np.float64), e.velocities().astype(np.float64)
        xb, vb = X[b == 0], V[b == 0]
        c, vc = (mb[:, None] * xb).sum(0) / mb.sum(), (mb[:, None] * vb).sum(0) / mb.sum()
        cs_, vs_ = (ms[:, None] * X[b == 1]).sum(0) / ms.sum(), (ms[:, None] * V[b == 1]).sum(0) / ms.sum()
        r = xb - c
        L = (mb[:, None] * np.cross(r, vb - vc)).sum(0)
        inertia = np.eye(3) * (mb * (r * r).sum(1)).sum() - np.einsum("n,ni,nj->ij", mb, r, r)
        cs.append(c - cs_)   # the slab lies flat on the ground (it does not turn): z is across its face
        vs.append(vc - vs_)
        ws.append(np.linalg.solve(inertia, L))
        slab = max(slab, float(np.abs(V[b == 1]).max()))
    e.close()
    c, t = np.array(cs), np.arange(1, len(cs) + 1) / FPS
    sel = t >= rl.FIT_FROM
    return {"a": 2.0 * float(np.polyfit(t[sel], c[sel, 0], 2)[0]), "wR": float(ws[-1][1]) * radius,
            "v": float(vs[-1][0]), "slab": slab, "sink": float(c[0, 2] - c[:, 2].min())}


def row(engine: str, shape: str, radius: float, n_grid: int, sampling: str, mu: float, slab: str = "lattice",
        seed: int = 1) -> dict:
    s, k, n_render = setup(shape, radius, n_grid, sampling, mu, slab, seed)
    t0 = time.time()
    fig = figures(engine, s, radius)
    return {**RF.record(engine, shape, radius, n_grid, sampling, n_render, mu, k, fig, time.time() - t0),
            "slab": fig["slab"], "sink": fig["sink"], "slab_sampling": slab, "seed": seed}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--shapes", default="ball,cylinder", help="ball, cylinder or both (comma-separated)")
    ap.add_argument("--round-pair", type=int, default=1, help="gasp_core.mpm.rigid_pairs.ROUND_PAIR (0: round 65's "
                                                                 "tables and midway plane, the broken variant)")
    ap.add_argument("--round-normal", type=int, default=1, help="gasp_core.mpm.rigid_pairs.ROUND_NORMAL (0: the "
                                                                   "nodes' normal, round 90's, the broken variant)")
    ap.add_argument("--slab", default="lattice", help="lattice, or scan (round 93: Gaussians on its top face)")
    ap.add_argument("--seeds", default="1", help="round 99: the scan slab's draws (comma-separated; 1 the tests')")
    ap.add_argument("--cases", default="all", help="all (the family), or test (round 99: the scanned slab's test "
                                                  "case alone, R 0.05 m, n_grid 32, fibonacci)")
    ap.add_argument("--out", default=None, help="a new JSON file for the rows (refused if it exists)")
    a = ap.parse_args(argv)
    import gasp_core.mpm.rigid_pairs as rp
    rp.ROUND_PAIR = a.round_pair
    rp.ROUND_NORMAL = a.round_normal
    out = RF.new_out(ap, a.out)
    rows = []
    for shape in a.shapes.split(","):
        cases = family() if a.cases == "all" else [(0.05, 32, "fibonacci")]
        for (radius, n_grid, sampling), seed in itertools.product(cases, (int(k) for k in a.seeds.split(","))):
            for mu in RF.MUS:
                rows.append(row(a.engine, shape, radius, n_grid, sampling, mu, a.slab, seed))
                print(RF.report(rows[-1]), f"(slab {rows[-1]['slab']:.4f} m/s, sink {rows[-1]['sink'] * 1e3:.2f} mm, seed {seed})",
                      flush=True)
    RF.write_rows(out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
