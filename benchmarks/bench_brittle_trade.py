"""The brittle ball's pieces against the grid, in units of U (issue 52 item 6, docs/speed_accuracy.md's rule):
how the piece count, the largest piece's share of the mass and the broken share of the points change with ``n_grid``.

The ball of ``tests/test_brittle.py`` (radius 0.1 m, E 200 kPa, nu 0.25, rho 300, f_t 10 kPa, G_f 10 J/m^2 (15 before round 31's band ``dx``: the same softening), points
at dx / 2) lands on the ground (friction 0.5) at sqrt(2 g 1 m) = 4.43 m/s in a 1 m box; 15 frames of 0.01 s. The
reference is the finest grid; U of each figure is its difference between the reference and its twin (the next
coarser grid), as the speed/accuracy rule measures U; each setting's error is given in U.

    python benchmarks/bench_brittle_trade.py [--engine warp_mpm] [--grids 32,40,48,64]
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from gasp_core.run.pieces import tracker_for
from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import engines
from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing.helpers import make_setup, sphere_points

ROOT = Path(__file__).resolve().parents[1]


def ball(engine: str, n_grid: int) -> dict:
    dx = 1.0 / n_grid
    ground = 0.1 + 3 * dx
    x, pv = sphere_points((0.5, 0.5, ground + 0.1 + dx / 4), 0.1, dx / 2)
    m = Material("brittle", E=2e5, nu=0.25, rho=300.0, tensile_strength=1e4, fracture_energy=10.0)
    s = make_setup(x, pv, m, v=np.array([0.0, 0.0, -np.sqrt(2 * 9.81 * 1.0)]), n_grid=n_grid, frame_dt=0.01,
                   boundaries=[Boundary("ground", height=ground, friction=0.5), Boundary("walls")],
                   options={"precision": "f32", **({"threads": 1} if engine == "taichi_mpm" else {})})
    t0 = time.process_time()
    e = build_engine(engines()[engine], s)
    try:
        for _ in range(15):
            e.step_frame()
        row = tracker_for(s).row(e.positions(), e.damage())[0]
        d = np.asarray(e.damage())
    finally:
        e.close()
    mass = np.asarray(row["piece_mass"], float)
    return {"n_grid": n_grid, "points": len(x), "cpu_s": round(time.process_time() - t0, 2),
            "pieces": int(row["pieces"]), "largest_share": float(mass[0] / (mass.sum() + row["debris_mass"])),
            "broken_share": float((d > 0.99).mean())}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--grids", default="32,40,48,64")
    a = ap.parse_args()
    grids = [int(g) for g in a.grids.split(",")]
    rows = [ball(a.engine, n) for n in grids]
    ref, twin = rows[-1], rows[-2]
    figures = ("pieces", "largest_share", "broken_share")
    U = {f: abs(ref[f] - twin[f]) for f in figures}       # 0: the figure is the same on both grids
    for r in rows:
        for f in figures:
            r[f"{f}_U"] = abs(r[f] - ref[f]) / U[f] if U[f] else None
    out = ROOT / "benchmarks" / "results" / f"brittle_trade_{a.engine}"
    out.with_suffix(".json").write_text(json.dumps({"rows": rows, "U": U}, indent=2))
    md = [f"{a.engine}:", "", "| n_grid | points | CPU s | pieces | largest piece's mass share | broken share of points |",
          "|---|---|---|---|---|---|"]
    def u(r, f):
        return "U = 0" if r[f"{f}_U"] is None else f"{r[f'{f}_U']:.2g} U"
    md += [f"| {r['n_grid']} | {r['points']:,} | {r['cpu_s']} | {r['pieces']} ({u(r, 'pieces')}) | "
           f"{r['largest_share']:.3f} ({u(r, 'largest_share')}) | {r['broken_share']:.3f} ({u(r, 'broken_share')}) |"
           for r in rows]
    md.append(f"\nU (reference n_grid {ref['n_grid']} against its twin {twin['n_grid']}): pieces {U['pieces']:g}, "
              f"largest share {U['largest_share']:.3f}, broken share {U['broken_share']:.3f}")
    out.with_suffix(".md").write_text("\n".join(md) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
