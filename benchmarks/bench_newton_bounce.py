"""Why Newton's implicit MPM does not bounce a stiff body (issue 40, item 3): its bounce against its step.

An elastic cube (10 cm, jelly E, nu 0.3, rho 1000, no damping) dropped 5 cm onto a ground (friction 0.5), n_grid 16
on a 0.4 m box (2 points a cell side), 12 frames of 1/30 s, run in this process on newton at fixed steps per frame
(``n_substeps``) and on taichi_mpm (explicit, its own step) for reference. Figures per run: CPU seconds, the step,
``omega dt`` with ``omega = pi c / H`` (the cube's first compression mode, ``c = sqrt(E / rho)``, ``H`` its height),
the restitution from the free flights and by frame differences (:func:`gasp_studies.accuracy.events`), and the
centroid's highest point after the impact against its start (mm over the ground).

Newton's collider is a velocity-level (inelastic) contact: whatever bounce there is comes from the elastic energy the
body stores while it is stopped, and a backward-Euler step damps a mode of ``omega dt`` per step by
``1 / sqrt(1 + (omega dt)^2)``.

Run: ``python benchmarks/bench_newton_bounce.py [--runs newton:1e5:1,taichi_mpm:1e7:auto,...]`` (writes
``benchmarks/results/newton_bounce.{json,md}``).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results"
N_GRID, BOX, SIDE, DROP, GROUND, RHO = 16, 0.4, 0.1, 0.05, 0.1, 1000.0
FRAMES = 12
RUNS = ("taichi_mpm:1e5:auto", "taichi_mpm:1e7:auto", "newton:1e5:1", "newton:1e5:4", "newton:1e5:16",
        "newton:1e5:64", "newton:1e5:256", "newton:1e7:4", "newton:1e7:16", "newton:1e7:64", "newton:1e7:256")


def cube_setup(E: float, engine: str, steps: str):
    """The dropped cube (module docstring) as a ``SimSetup``."""
    from gasp_core.seam import Boundary, Material, SimSetup
    dx = BOX / N_GRID
    h = dx / 2
    g = np.arange(-SIDE / 2 + h / 2, SIDE / 2, h)
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3) + [BOX / 2, BOX / 2, GROUND + DROP + SIDE / 2]
    opts = {} if engine == "newton" else {"threads": 1}
    if steps != "auto":
        opts["n_substeps"] = int(steps)
    return SimSetup(x=x, v=np.zeros(3), p_vol=h ** 3, body_id=0,
                    materials=[Material("jelly", E=E, nu=0.3, rho=RHO, model="elastic")],
                    gravity=np.array([0.0, 0.0, -9.81]), domain_lo=np.zeros(3), domain_hi=np.full(3, BOX),
                    n_grid=N_GRID, boundaries=[Boundary("ground", height=GROUND, friction=0.5)], options=opts)


def run(spec: str) -> dict:
    """One run ``engine:E:steps``: its figures (module docstring)."""
    from gasp_core.seam import build_engine, get_engine
    from gasp_studies.accuracy import Track, events
    engine, E, steps = spec.split(":")
    s = cube_setup(float(E), engine, steps)
    cpu0 = time.process_time()
    e = build_engine(get_engine(engine), s)
    means = [s.x.copy()]
    for _ in range(FRAMES):
        e.step_frame()
        means.append(e.positions().astype(np.float64))
    cpu = time.process_time() - cpu0
    dx = BOX / N_GRID
    ev = events(Track(np.array(means), np.array([0, len(s.x)]), ["cube"], 1 / 30, GROUND, dx), 0, 0.5 * dx)
    cz = np.array(means).mean(axis=1)[:, 2] - GROUND
    n = int(e.n_substeps)
    dt = (1 / 30) / n
    hit = int(np.argmin(cz[:6]))
    return {"engine": engine, "E": float(E), "steps": n, "dt_s": dt, "cpu_s": cpu, "load_avg_1min": os.getloadavg()[0],
            "omega_dt": float(np.pi * np.sqrt(float(E) / RHO) / SIDE * dt),
            "restitution_flights": ev["restitution_ballistic"], "restitution_frames": ev["restitution"],
            "apex_after_mm": float(1e3 * cz[hit:].max()), "start_mm": float(1e3 * cz[0]),
            "centroid_mm": (1e3 * cz).round(2).tolist()}


def markdown(rows: list[dict]) -> list[str]:
    lines = ["# Newton's bounce against its step (benchmarks/bench_newton_bounce.py, issue 40 item 3)", "",
             f"A 10 cm elastic cube (jelly, nu 0.3, rho 1000, no damping) dropped 5 cm, n_grid {N_GRID} on a {BOX} m box, "
             f"{FRAMES} frames; `omega = pi sqrt(E / rho) / H` (its first compression mode). Centroid over the ground: "
             f"{rows[0]['start_mm']:.1f} mm at the start, 50 mm at rest.", "",
             "| engine | E (Pa) | steps/frame | dt (ms) | omega dt | restitution (free flights) | restitution (frame "
             "differences) | apex after the impact (mm) | CPU s | load |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    lines += [f"| {r['engine']} | {r['E']:g} | {r['steps']} | {1e3 * r['dt_s']:.3f} | {r['omega_dt']:.2f} | "
              f"{r['restitution_flights']:.3f} | {r['restitution_frames']:.3f} | {r['apex_after_mm']:.1f} | "
              f"{r['cpu_s']:.1f} | {r['load_avg_1min']:.1f} |" for r in rows]
    return lines + ["", "Restitution from the free flights is NaN where the cube does not leave the ground for two "
                    "frames.", ""]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=lambda s: s.split(","), default=list(RUNS), help="engine:E:steps, comma-separated")
    args = ap.parse_args(argv)
    rows = []
    for spec in args.runs:
        print(f"[newton_bounce] {spec} ...", flush=True)
        rows.append(run(spec))
        print(f"[newton_bounce]   {json.dumps({k: v for k, v in rows[-1].items() if k != 'centroid_mm'})}", flush=True)
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "newton_bounce.json").write_text(json.dumps({"args": vars(args), "runs": rows}, indent=1))
    lines = markdown(rows)
    (RESULTS / "newton_bounce.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
