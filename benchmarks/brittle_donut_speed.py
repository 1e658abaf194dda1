"""The landing speed at which the brittle README donut comes apart at the brittle defaults (issue 66, "What a user
sees"; docs/fracture.md "Round 44: the speed at which the default donut comes apart").

``benchmarks/brittle_readme_donut.py``'s thrown-down donut (``examples/donut_jelly.toml`` made ``brittle``, every key
at the schema's defaults, the default contact) landing at each of ``--speeds`` (m/s; 4.43 is the 1 m drop), counted
after ``--frames`` frames from the frames alone (its :func:`counted`: pieces of 1 % or more, the mass in them, crumbs,
the share broken through, swell). ``--elastic``: the same donut as ``jelly`` (the same E, nu, rho) landing at each
speed, sampled every 1/600 s over 0.1 s: its largest principal Cauchy stress (Hencky's, from each point's ``F``) and
the 99th percentile over the points, over the brittle default ``tensile_strength``: the tension an uncracked body
would carry, the load the crack band meets.

Run: ``python benchmarks/brittle_donut_speed.py`` (``--engines``, ``--grids``, ``--speeds``, ``--frames``,
``--elastic``); writes ``benchmarks/results/brittle_donut_speed.{json,md}``. About 15-60 s a run on 2 cores.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import brittle_readme_donut as bd   # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "brittle_donut_speed"
ELASTIC_DT, ELASTIC_FRAMES = 1 / 600, 60


def at_speed(setup, v: float):
    """``setup`` with its material points thrown down at ``v`` (m/s) instead of the scene's 4.43."""
    mat = setup.p_vol > 0
    setup.v[mat] = setup.v[mat] / np.abs(setup.v[mat, 2]).max() * v
    return setup


def peak_tension(engine: str, n_grid: int, v: float) -> dict:
    """The jelly donut's largest principal Cauchy stress (Pa) over the run and its largest 99th percentile over the
    points, from each point's ``F`` (Hencky: ``tau = 2 mu e + lam tr(e)``, ``sigma = tau / J``)."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    from gasp_core.seam.setup import Material
    m = Material("jelly", E=bd.brittle("new").E, nu=bd.brittle("new").nu, rho=bd.brittle("new").rho)
    s = at_speed(bd.donut_setup(engine, n_grid, m), v)
    s.frame_dt = ELASTIC_DT
    lam, mu = m.E * m.nu / ((1 + m.nu) * (1 - 2 * m.nu)), m.E / (2 * (1 + m.nu))
    e = build_engine(engines()[engine], s)
    top, p99 = 0.0, 0.0
    try:
        for _ in range(ELASTIC_FRAMES):
            e.step_frame()
            F = np.asarray(e.get_state()["F"], np.float64).reshape(-1, 3, 3)
            sv = np.linalg.svd(F, compute_uv=False)
            eps = np.log(sv)
            sigma = (2 * mu * eps + lam * eps.sum(1, keepdims=True)).max(1) / sv.prod(1)
            top, p99 = max(top, float(sigma.max())), max(p99, float(np.percentile(sigma, 99)))
    finally:
        e.close()
    return {"peak_Pa": top, "p99_Pa": p99}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", default="taichi_mpm,warp_mpm")
    ap.add_argument("--grids", default="48,64")
    ap.add_argument("--speeds", default="4.43,5.0,6.0")
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--elastic", action="store_true", help="also the jelly donut's peak tension at each speed")
    a = ap.parse_args(argv)
    ft = bd.brittle("new").tensile_strength
    rows = []
    for engine in a.engines.split(","):
        for n_grid in (int(g) for g in a.grids.split(",")):
            for v in (float(s) for s in a.speeds.split(",")):
                r = {"engine": engine, "n_grid": n_grid, "speed": v, "drop_m": v * v / (2 * 9.81),
                     **bd.counted(engine, at_speed(bd.donut_setup(engine, n_grid, bd.brittle("new")), v), a.frames)}
                if a.elastic:
                    r.update(peak_tension(engine, n_grid, v))
                rows.append(r)
                print(json.dumps(r), flush=True)
    OUT.with_suffix(".json").write_text(json.dumps({"frames": a.frames, "tensile_strength": ft, "rows": rows},
                                                   indent=1))
    lines = ["# The speed at which the brittle README donut comes apart (`benchmarks/brittle_donut_speed.py`)", "",
             f"Brittle defaults, the default contact, {a.frames} frames; pieces from the frames alone. Elastic: the "
             f"jelly donut's peak principal stress over f_t = {ft:g} Pa (largest; largest 99th percentile).", "",
             "| engine | n_grid | speed (m/s) | drop (m) | pieces >= 1 % | largest | in them | crumbs | broken "
             "through | swell | elastic peak / f_t | 99th pct / f_t |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['engine']} | {r['n_grid']} | {r['speed']:.2f} | {r['drop_m']:.2f} | {r['pieces_1']} | "
              f"{r['largest']:.3f} | {r['in_pieces']:.3f} | {r['crumbs']:.3f} | {r['broken_through']:.3f} | "
              f"{r['swell']:.2f} | " + (f"{r['peak_Pa'] / ft:.2f} | {r['p99_Pa'] / ft:.2f} |" if 'peak_Pa' in r
                                         else "- | - |") for r in rows]
    OUT.with_suffix(".md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
