"""Friction between bodies (issue 53 item 3, ``docs/contact.md`` "Friction between bodies"): a 6 x 6 x 3 cm block
thrown at 0.4, 0.6 and 0.8 m/s along a 40 x 16 x 3 cm jelly slab (E 2e5 Pa, rho 1000, on the ground), or along the
ground itself; the effective coefficient ``v0^2 / (2 g travel)`` of its mass centre after 0.2 s.

Cases: ``jelly`` (the slab's jelly: a block that keeps its shape; on the slab the two soft bodies' friction 0.5, so
Coulomb's answer is 0.5) and ``sand`` (friction angle 30 deg, tan 0.577; a sand block spreads as it slides, so its
answer is the same block on the ground of friction 0.577), each ``slab`` or ``ground``, at ``--n-grid`` cells over
0.48 m. The setups are built here from ``SimSetup`` alone, so the script runs on a checkout before round 22 too:

    python benchmarks/bench_body_friction.py --engines warp_mpm --n-grid 32,64
    PYTHONPATH=BASE:BASE/plugins/warp_mpm python benchmarks/bench_body_friction.py --engines warp_mpm --label base

Writes ``benchmarks/results/body_friction.json`` (or ``--out``), one JSON line per case.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
SPEEDS, SIDE, FRAMES, FRAME_DT = (0.4, 0.6, 0.8), 0.48, 60, 1.0 / 300.0


def setup(block: str, on: str, v0: float, n_grid: int):
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    from gasp_core.testing.helpers import box_points
    jelly = Material("jelly", E=2e5, nu=0.3, rho=1000.0)
    sand = Material("sand", E=3.5e5, nu=0.3, rho=1600.0, friction_angle=30.0)
    dx = SIDE / n_grid
    lo = np.array([-0.12, -SIDE / 2, -3 * dx])
    base = 0.03 if on == "slab" else 0.0
    xs, vs = box_points([-0.03, -0.03, base], [0.03, 0.03, base + 0.03], dx / 2)
    xb, vb = box_points([-0.08, -0.08, 0.0], [0.32, 0.08, 0.03], dx / 2) if on == "slab" else (np.zeros((0, 3)), 0.0)
    v = np.zeros((len(xs) + len(xb), 3))
    v[:len(xs), 0] = v0
    mats = [jelly if block == "jelly" else sand] + ([jelly] if on == "slab" else [])
    mu = 0.5 if on == "slab" else math.tan(math.radians(30.0))
    return SimSetup(x=np.concatenate([xs, xb]), v=v, p_vol=np.concatenate([np.full(len(xs), vs), np.full(len(xb), vb)]),
                    body_id=np.concatenate([np.zeros(len(xs), int), np.ones(len(xb), int)]), materials=mats,
                    gravity=np.array([0.0, 0.0, -9.81]), domain_lo=lo, domain_hi=lo + SIDE, n_grid=n_grid,
                    frame_dt=FRAME_DT, boundaries=[Boundary("ground", height=0.0, friction=mu)], options={})


def mu_eff(engine: str, block: str, on: str, n_grid: int) -> list[float]:
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.kit import run_trace
    out = []
    for v0 in SPEEDS:
        s = setup(block, on, v0, n_grid)
        tr = run_trace(get_engine(engine), s, FRAMES)
        sel = np.asarray(s.body_id) == 0
        m = s.p_mass[sel]
        travel = float(m @ tr.x[-1][sel, 0] - m @ tr.x[0][sel, 0]) / float(m.sum())
        out.append(v0 ** 2 / (2.0 * 9.81 * travel))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", type=lambda s: s.split(","), default=["warp_mpm", "taichi_mpm"])
    ap.add_argument("--n-grid", type=lambda s: [int(v) for v in s.split(",")], default=[32, 64])
    ap.add_argument("--cases", type=lambda s: s.split(","),
                    default=["jelly/slab", "jelly/ground", "sand/slab", "sand/ground"], help="block/on, a comma list")
    ap.add_argument("--label", default="this checkout")
    ap.add_argument("--out", type=Path, default=HERE / "results" / "body_friction.json")
    args = ap.parse_args(argv)
    for engine in args.engines:
        for n_grid in args.n_grid:
            for case in args.cases:
                block, on = case.split("/")
                t0 = time.perf_counter()
                mus = mu_eff(engine, block, on, n_grid)
                rec = {"label": args.label, "engine": engine, "block": block, "on": on, "n_grid": n_grid,
                       "speeds": list(SPEEDS), "mu_eff": [round(m, 4) for m in mus],
                       "seconds": round(time.perf_counter() - t0, 1), "load": round(os.getloadavg()[0], 2)}
                print(json.dumps(rec), flush=True)
                with open(args.out, "a") as fh:
                    fh.write(json.dumps(rec) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
