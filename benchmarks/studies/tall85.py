"""Round 85 (issue 67 item 3, ``docs/contact.md`` "Round 85: the tall block topples"): the tall jelly block of
round 84 (10 x 10 x 15 cm, E 1e5, nu 0.3, rho 1000) on a slope, by a continuum solver apart from the MPM engines and
by the engines themselves, to ask whether it should hold where Coulomb and the rigid tipping rule say it holds
(``tan theta < mu`` and ``tan theta < w / h`` = 0.667, 33.7 degrees).

``--fem``: ``cube_fem.py``'s explicit hexahedra (the engines' fixed corotated law), relaxed to rest in their own
weight by ``Block.relax`` (gravity ramped over 0.5 s, kinetic damping, 1.5 s held), then run 1 s: the turn at the
end of the relaxation (degrees, the least-squares rigid fit of the nodes' motion; negative: downhill) and the turn
and the centroid's travel after the 1 s. Where no stable rest exists it topples during the relaxation.
``--mpm``: each engine's block started settled (the scene key ``settle``): the turn at the start, the centroid's
travel in 1 s from 0.1 s (mm, ``tests/test_elastic_slope.py``'s stick figure) and the turn at the end.

    python benchmarks/studies/tall85.py --fem --out benchmarks/results/tall85_fem.json
    python benchmarks/studies/tall85.py --mpm --out benchmarks/results/tall85_mpm.json
    python benchmarks/studies/tall85.py --mpm --contact particle --torque-reach 0 \
        --out benchmarks/results/tall85_reach0.json
    python benchmarks/studies/tall85.py --mpm --contact particle --no-balance \
        --out benchmarks/results/tall85_nobalance.json

``--torque-reach 0`` runs the particle contact without its balance's torque take-back (``TORQUE_REACH``: the
balance cancels a body's net contact torque up to ``J TORQUE_REACH h``), ``--no-balance`` without the balance.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve()
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parents[2] / "tests"))

TALL = (0.1, 0.1, 0.15)
#: (theta, mu): the two slopes and the frictions at ``tan / mu`` 0.95 and 0.82 on 25 degrees (the family's ratios on
#: 30 degrees), 0.82 on 30 degrees, and a ground that never slips (mu 10).
FEM_CASES = [(25.0, 10.0, (4, 6, 8)), (25.0, 0.49, (4, 6)), (27.5, 10.0, (6,)), (30.0, 10.0, (4, 6, 8)),
             (30.0, 0.7, (4, 6))]
MPM_CASES = [(25.0, 0.49), (25.0, 0.57), (30.0, 0.7)]


def fem_row(theta: float, mu: float, n: int) -> dict:
    from cube_fem import Block
    t0 = time.time()
    b = Block(TALL, n, 1.0e5, 0.3, 1000.0, theta, mu, beta=2e-4, law="corotated")
    b.relax()
    settled, c0 = b.tilt(), b.centroid()
    b.v[:] = 0.0
    for _ in range(math.ceil(1.0 / b.dt)):
        b.step()
    return {"solver": "fem", "theta": theta, "mu": mu, "n": n, "turn_settled_deg": round(settled, 3),
            "travel_mm": round(1000 * float(np.linalg.norm(b.centroid() - c0)), 3), "turn_end_deg": round(b.tilt(), 3),
            "wall_s": round(time.time() - t0)}


def mpm_row(engine: str, theta: float, mu: float, contact: str, n_grid: int, balance: bool = True) -> dict:
    from slopes import turn_deg
    from test_elastic_slope import FPS, SETTLE_T, STICK_T, block_setup

    from gasp_core.seam.plugins import get_engine
    from gasp_core.seam.runner import EngineRun, RunStats
    s = block_setup(theta, mu, contact, TALL, n_grid)
    if not balance:
        s.options = {**s.options, "contact_balance": False}
    x0 = np.asarray(s.x, float)
    stats, xs = RunStats(), []
    t0 = time.time()
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always", UserWarning)
        with EngineRun(get_engine(engine), s, stats, settle=True) as run:
            xs = [np.asarray(rec.x, float) for rec in run.frames(round((SETTLE_T + STICK_T) * FPS))]
    c = [x.mean(axis=0) for x in xs]
    k = round(SETTLE_T * FPS) - 1
    from gasp_core.mpm.contact import TORQUE_REACH
    return {"solver": engine, "contact": contact, "n_grid": n_grid, "theta": theta, "mu": mu, "balance": balance,
            "torque_reach": TORQUE_REACH,
            "turn_settled_deg": round(turn_deg(x0, xs[0]), 3),
            "travel_mm": round(1000 * float(np.linalg.norm(c[-1] - c[k])), 3),
            "turn_end_deg": round(turn_deg(x0, xs[-1]), 3), "settle": stats.settle,
            "warnings": [str(x.message)[:100] for x in w if "settle" in str(x.message)],
            "wall_s": round(time.time() - t0)}


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--fem", action="store_true")
    p.add_argument("--mpm", action="store_true")
    p.add_argument("--engine", nargs="+", default=["warp_mpm"])
    p.add_argument("--grid", nargs="+", type=int, default=[24, 32, 48])
    p.add_argument("--contact", nargs="+", default=["particle", "grid"])
    p.add_argument("--no-balance", action="store_true", help="the engine option contact_balance = false")
    p.add_argument("--torque-reach", type=float, help="gasp_core.mpm.contact.TORQUE_REACH for this run (the balance's "
                   "torque take-back; 0: none), set before the engines load")
    p.add_argument("--out", help="write the rows to this JSON file (refused if it exists)")
    a = p.parse_args(argv)
    if a.out and Path(a.out).exists():
        sys.exit(f"tall85.py: {a.out} exists; give a new file")
    if a.torque_reach is not None:
        import gasp_core.mpm.contact as contact_module
        contact_module.TORQUE_REACH = a.torque_reach
    rows = []
    if a.fem:
        for theta, mu, ns in FEM_CASES:
            for n in ns:
                rows.append(fem_row(theta, mu, n))
                print(json.dumps(rows[-1]), flush=True)
    if a.mpm:
        for engine in a.engine:
            for theta, mu in MPM_CASES:
                for contact in a.contact:
                    for n_grid in a.grid:
                        rows.append(mpm_row(engine, theta, mu, contact, n_grid, balance=not a.no_balance))
                        print(json.dumps({k: v for k, v in rows[-1].items() if k != "settle"}), flush=True)
    if a.out:
        Path(a.out).write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
