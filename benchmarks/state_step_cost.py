"""Snow's step from its state (round 57, ``gasp_core.mpm.state_step``; docs/fracture.md "Round 57: snow's step from its
state"): per frame, the substeps each engine takes, the largest local Courant number ``(c(h) + |v|) dt / dx`` over the
points and substeps (``c(h) = sqrt(h (lambda + 2 mu) / rho)``, ``h = exp(xi (1 - Jp))`` each point's hardening) and
the smallest ``Jp``, with the step from the state and with round 56's step chosen once from the materials' constants
(``fixed``: the state's step switched off); and the wall time a frame of ``step_frame`` takes in each (3 frames after
a first one that compiles). The bodies are ``energy_ledger_plastic.py``'s snow block and snow ball thrown down at 2 m/s.

Run: ``python benchmarks/state_step_cost.py`` (``--engines``, ``--bodies``, ``--grids``); writes
``benchmarks/results/state_step_cost.{json,md}``. About 10 min on 2 cores.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from energy_ledger import steps_of   # noqa: E402
from energy_ledger_plastic import scene   # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "state_step_cost"
FRAMES = 3


def build(body: str, n_grid: int, engine: str, mode: str):
    """The engine on ``body`` (``mode`` "state" or "fixed": the state's step switched off for this build)."""
    import gasp_core.mpm.state_step as state_step
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    applies = state_step.applies
    if mode == "fixed":
        state_step.applies = lambda setup, opts: False
    try:
        return build_engine(engines()[engine], scene(body, n_grid))
    finally:
        state_step.applies = applies


def courant(body: str, n_grid: int, engine: str, mode: str) -> list[dict]:
    """Per frame: substeps, the largest local Courant number, the smallest ``Jp`` (module notes)."""
    e = build(body, n_grid, engine, mode)
    m = e.setup.materials[0]
    c0, dx, steps, out = math.sqrt((m.lam + 2 * m.mu) / m.rho), e.setup.dx, steps_of(e), []
    try:
        for _ in range(FRAMES):
            e.clock.begin()
            worst, done = 0.0, False
            while not done:
                dt = float(e.dt)
                steps.substep()
                p = steps.points()
                h = np.exp(m.hardening * (1.0 - p["Jp"]))
                worst = max(worst, float(((c0 * np.sqrt(h) + np.linalg.norm(p["v"], axis=1)) * dt / dx).max()))
                done = e.clock.after()
            out.append({"substeps": e.clock.frames[-1], "courant": worst, "jp_min": float(p["Jp"].min())})
    finally:
        e.close()
    return out


def seconds_a_frame(body: str, n_grid: int, engine: str, mode: str) -> float:
    """Wall time of a ``step_frame`` (s), the mean of :data:`FRAMES` after a first one."""
    e = build(body, n_grid, engine, mode)
    try:
        e.step_frame()
        t0 = time.perf_counter()
        for _ in range(FRAMES):
            e.step_frame()
        return (time.perf_counter() - t0) / FRAMES
    finally:
        e.close()


def report(runs: list[dict]) -> list[str]:
    lines = ["# Snow's step from its state (`benchmarks/state_step_cost.py`)", "",
             "Per run (3 frames of 1/30 s): the substeps of each frame, the largest local Courant number `(c(h) + "
             "|v|) dt / dx` of each frame, the smallest `Jp` at its end; `s/frame`: wall time of `step_frame` (2 "
             "cores, shared). `fixed`: round 56's step, chosen once from the materials' constants.", "",
             "| body | engine | n_grid | step | substeps a frame | largest Courant a frame | Jp min | s/frame |",
             "|---|---|---|---|---|---|---|---|"]
    for r in sorted(runs, key=lambda r: (r["body"], r["n_grid"], r["engine"], r["mode"])):
        f = r["frames"]
        lines.append(f"| {r['body']} | {r['engine']} | {r['n_grid']} | {r['mode']} | "
                     f"{', '.join(str(q['substeps']) for q in f)} | "
                     f"{', '.join('%.3f' % q['courant'] for q in f)} | "
                     f"{f[-1]['jp_min']:.3f} | {r['s_per_frame']:.3f} |")
    return lines + [""]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", default="taichi_mpm,warp_mpm")
    ap.add_argument("--bodies", default="snow_block,snow_ball")
    ap.add_argument("--grids", default="32,48")
    a = ap.parse_args(argv)
    path = OUT.with_suffix(".json")
    for body in a.bodies.split(","):
        for ng in (int(g) for g in a.grids.split(",")):
            for engine in a.engines.split(","):
                for mode in ("state", "fixed"):
                    r = {"body": body, "n_grid": ng, "engine": engine, "mode": mode,
                         "frames": courant(body, ng, engine, mode),
                         "s_per_frame": seconds_a_frame(body, ng, engine, mode)}
                    print(json.dumps(r), flush=True)
                    runs = json.loads(path.read_text())["runs"] if path.exists() else []
                    runs = [q for q in runs if [q[k] for k in ("body", "n_grid", "engine", "mode")] !=
                            [r[k] for k in ("body", "n_grid", "engine", "mode")]] + [r]
                    path.write_text(json.dumps({"runs": runs}, indent=0))
                    OUT.with_suffix(".md").write_text("\n".join(report(runs)) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
