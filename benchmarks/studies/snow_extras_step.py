"""Snow's step from its state beside colliders (round 59; docs/fracture.md "Round 59: snow's step beside colliders,
forces and impulses").

The snow ball of ``benchmarks/energy_ledger_plastic.py`` thrown down at 5 m/s (``snow_ball_fast``, n_grid 32), in
three scenes: alone (the ground), with a static box collider in a far corner of the box (it never touches the ball),
and landing on a box collider 4 cm thick whose top is 5 cm over the ground, the ball lifted 6 cm (it meets the
collider, not the ground; a collider within a cell of the ground acts as the ground's own node layer); each
with the state's clock (round 59: where there are colliders too) and with the rule of before (the setup's step where
there are colliders, forces or impulses). Per run: the ledger's untraced end and worst (% of ``E0``), the largest total
energy over ``E0`` (``gain``), the substeps of frames 1-3.

Usage: ``python benchmarks/studies/snow_extras_step.py [--engine taichi_mpm] [--out benchmarks/results]``
(``snow_extras_step.json``; a few minutes on 2 cores).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))

import energy_ledger_plastic as elp   # noqa: E402

from gasp_core.colliders.sdf import box_collider   # noqa: E402
from gasp_core.mpm import grid_tables, state_step   # noqa: E402

BODY, N_GRID = "snow_ball_fast", 32


def scenes():
    """name -> (the colliders added to the body's scene, the body's lift, m)."""
    return {"alone": ([], 0.0),
            "far collider": ([box_collider((0.03, 0.03, 0.03), 0.01, position=(0.2, 0.2, 0.4))], 0.0),
            "lands on a collider": ([box_collider((0.25, 0.25, 0.02), 0.005, position=(0.0, 0.0, 0.03),
                                                  friction=0.5)], 0.06)}


def run(engine: str, cols: list, lift: float, before: bool) -> dict:
    make, applies = elp.scene, state_step.applies

    def scene(*a, **k):
        s = make(*a, **k)
        s.colliders = list(cols)
        s.x = s.x + np.array([0.0, 0.0, lift])
        return s
    elp.scene = scene
    if before:
        state_step.applies = lambda s, o: applies(s, o) and not grid_tables.grid_tables(s).any
    try:
        r = elp.run(BODY, engine, N_GRID)
    finally:
        elp.scene, state_step.applies = make, applies
    return {"untraced_end_pc": 100 * r["untraced_end"] / r["E0"], "untraced_worst_pc": 100 * r["untraced_worst"] / r["E0"],
            "gain_pc": 100 * r["gain"], "substeps": r["frames"], "seconds": round(r["seconds"], 1)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="taichi_mpm")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument("--scenes", nargs="*", default=None, help="only these (names of scenes())")
    a = ap.parse_args(argv)
    rows = []
    for name, (cols, lift) in scenes().items():
        if a.scenes is not None and name not in a.scenes:
            continue
        for before in ((False,) if not cols else (False, True)):
            row = {"scene": name, "clock": "before (setup's step)" if before else "state", "engine": a.engine,
                   **run(a.engine, cols, lift, before)}
            rows.append(row)
            print(json.dumps(row), flush=True)
    a.out.mkdir(parents=True, exist_ok=True)
    path = a.out / "snow_extras_step.json"
    old = json.loads(path.read_text()) if path.exists() else []
    done = {(r["scene"], r["clock"], r["engine"]) for r in rows}
    keep = [r for r in old if (r["scene"], r["clock"], r["engine"]) not in done]
    path.write_text(json.dumps(keep + rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
