"""Issue 38: the surface contact (``contact = "surface"``, ``gasp_core.toolkit.level_set``) against the particle
contact on the issue's ball, over several drops (the roll is chaotic in the drop height, so one drop decides
nothing): 600 flat Gaussians on a 5 cm sphere with their fill (``benchmarks/contact_mustshow.py``), jelly
(nu 0.3, rho 300), ground friction 0.5, n_grid 16, 40 frames, in process on one engine.

Figures per contact, ball (Fibonacci or jittered +-3 mm) and E: the Gaussians' centroid's largest horizontal
travel (mm) per drop, its mean and maximum, and the lowest vertex at frame 40 (mm above the ground; negative:
below).

Run: ``python benchmarks/contact_surface.py [--engine warp_mpm] [--E 2e4 1e6]``; the table goes to stdout and
``benchmarks/results/contact_surface.md``.
"""
from __future__ import annotations

import argparse
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

import contact_mustshow as cm

DROPS = (0.05, 0.055, 0.06, 0.065, 0.07)


def one(engine: str, contact: str, jitter: float, drop: float, E: float, n_grid: int = 16, frames: int = 40):
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.build import build_engine
    d = Path(tempfile.mkdtemp())
    ply = cm.ball(d / "ball.ply", jitter)
    text = (cm.scene(ply, engine, contact).replace("E = 2.0e4", f"E = {E:g}").replace("n_grid = 16", f"n_grid = {n_grid}")
            .replace(f"position = [0.0, 0.0, {cm.RADIUS + cm.DROP}]", f"position = [0.0, 0.0, {cm.RADIUS + drop}]"))
    (d / "s.toml").write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ps = prepare_scene(load_scene(d / "s.toml"))
        e = build_engine(ps.info, ps.setup)
    n = ps.setup.n_render
    c0 = e.positions()[:n:3].mean(axis=0)
    travel = 0.0
    try:
        for _ in range(frames):
            e.step_frame()
            x = e.positions()[:n]
            c = x[::3].mean(axis=0) - c0
            travel = max(travel, float(np.hypot(c[0], c[1])))
    except Exception as exc:   # an engine that diverges: the row says so
        return {"error": f"{type(exc).__name__} at frame {e.frame}"}
    finally:
        e.close()
    return {"travel_mm": 1e3 * travel, "zmin_mm": 1e3 * float(x[:, 2].min())}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--contacts", nargs="+", default=["particle", "surface"])
    ap.add_argument("--E", nargs="+", type=float, default=[2e4, 1e6])
    ap.add_argument("--n-grid", type=int, default=16)
    a = ap.parse_args()
    rows = [f"| E (Pa) | contact | ball | travel per drop {', '.join(f'{d * 100:g}' for d in DROPS)} cm (mm) | mean | max | "
            "lowest vertex at frame 40 (mm, per drop) |", "|---|---|---|---|---|---|---|"]
    t0 = time.perf_counter()
    for E in a.E:
        for contact in a.contacts:
            for jitter in (0.0, cm.JITTER):
                r = [one(a.engine, contact, jitter, d, E, a.n_grid) for d in DROPS]
                tr = [f["travel_mm"] for f in r if "error" not in f]
                errs = [f["error"] for f in r if "error" in f]
                cells = ", ".join(f"{f['travel_mm']:.1f}" if "error" not in f else f["error"] for f in r)
                zs = ", ".join(f"{f['zmin_mm']:.1f}" for f in r if "error" not in f)
                rows.append(f"| {E:g} | {contact} | {'jittered' if jitter else 'Fibonacci'} | {cells} | "
                            f"{np.mean(tr) if tr else float('nan'):.1f} | {max(tr) if tr else float('nan'):.1f} | {zs} |")
                print(rows[-1], flush=True)
    text = "\n".join(rows)
    res = Path(__file__).parent / "results"
    res.mkdir(exist_ok=True)
    (res / "contact_surface.md").write_text(
        f"`python benchmarks/contact_surface.py --engine {a.engine} --n-grid {a.n_grid}` (jitter +-{cm.JITTER * 1e3:g} mm, "
        f"{time.perf_counter() - t0:.0f} s wall, 2-core machine shared with other work)\n\n{text}\n")
    print(text)


if __name__ == "__main__":
    main()
