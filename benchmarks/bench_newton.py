"""Newton's implicit MPM against taichi_mpm on the sand guitar, end to end, in one run.

``examples/guitar_sand.toml`` (273,598 simulated points) is run with ``gasp simulate`` once per engine, the
engines interleaved (newton, taichi_mpm, newton, ... for ``--repeats``), each at its own default options,
at each ``--n-grid``. Figures per run: the wall clock of the whole command (reading, preparing, building,
every frame, writing) and the final pile's centroid height (mean z of the Gaussian means, m) and RMS
horizontal radius about that centroid (m). Ratios: taichi_mpm wall / newton wall, and newton's pile
figures relative to taichi_mpm's (the must-show of issue 20: >= 3x faster; height and radius within 10 %).

Usage::

    python benchmarks/bench_newton.py                           # n_grid 64, 40 frames
    python benchmarks/bench_newton.py --n-grid 64,96 --frames 40 --repeats 1

Writes ``benchmarks/results/bench_newton.json`` (atomically, after every run).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().parent / "results"
SCENE = ROOT / "examples" / "guitar_sand.toml"


def pile(out: Path) -> dict:
    """Centroid height and RMS horizontal radius of the last frame's Gaussian means, metres."""
    from gasp_core.gs.io import read_gaussians
    last = sorted(out.glob("*/frame_*.ply"))[-1]
    x = read_gaussians(last).means.astype(np.float64)
    c = x.mean(axis=0)
    r = np.sqrt(np.mean(np.sum((x[:, :2] - c[:2]) ** 2, axis=1)))
    return {"frame_file": last.name, "centroid_z": float(c[2]), "radius": float(r)}


def run(engine: str, n_grid: int, frames: int, work: Path) -> dict:
    text = re.sub(r"n_grid = \d+", f"n_grid = {n_grid}", SCENE.read_text())
    scene = work / f"guitar_{n_grid}.toml"
    scene.write_text(text.replace('file = "data/', f'file = "{SCENE.parent}/data/'))
    out = work / f"{engine}_{n_grid}"
    t0 = time.perf_counter()
    proc = subprocess.run(["gasp", "simulate", str(scene), "--engine", engine, "--frames", str(frames), "-o", str(out),
                           "--overwrite", "-q"], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode:
        return {"engine": engine, "n_grid": n_grid, "error": proc.stderr[-2000:]}
    rec = json.loads((out / "run.json").read_text())
    return {"engine": engine, "n_grid": n_grid, "frames": frames, "wall_s": wall, "build_s": rec["build_s"],
            "engine_stats": {k: rec["engine_stats"].get(k) for k in ("n_substeps", "compile_s", "unconverged_steps",
                                                                     "max_iterations_used")},
            **pile(out)}


def bounce(out: Path) -> dict:
    """The dropped body's bounce from a ``gasp simulate`` output folder (e.g. ``examples/donut_jelly.toml``).

    ``z_k``: centroid height of the Gaussian means in frame ``k``; ``z_rest``: mean of the last 5 frames.
    Restitution ``e = sqrt((z_peak - z_rest) / (z_0 - z_rest))``, ``z_peak`` the highest centroid after its
    first minimum (energy ratio of the first bounce, read at frame resolution). Penetration: the lowest
    Gaussian mean below the ground over all frames, in grid cells (``run.json`` dx and ground height).
    """
    from gasp_core.gs.io import read_gaussians
    rec = json.loads((out / "run.json").read_text())
    ground = next(b["height"] for b in rec["boundaries"] if b["kind"] == "ground")
    zs, lows = [], []
    for f in sorted(out.glob("*/frame_*.ply")):
        x = read_gaussians(f).means.astype(np.float64)
        zs.append(float(x[:, 2].mean()))
        lows.append(float(x[:, 2].min()))
    z = np.array(zs)
    rest = float(z[-5:].mean())
    k_min = int(np.argmax(np.diff(z) > 0)) if np.any(np.diff(z) > 0) else len(z) - 1
    peak = float(z[k_min:].max())
    e = float(np.sqrt(max(peak - rest, 0.0) / (z[0] - rest))) if z[0] > rest else float("nan")
    return {"engine": rec["engine"], "frames": len(z) - 1, "restitution": e, "z0": float(z[0]), "z_min": float(z.min()),
            "z_peak_after_impact": peak, "z_rest": rest, "first_min_frame": k_min,
            "max_penetration_dx": max(0.0, (ground - min(lows)) / rec["domain"]["dx"]),
            "centroid_z": zs}


def summary(rows: list[dict]) -> list[dict]:
    out = []
    for g in sorted({r["n_grid"] for r in rows if "wall_s" in r}):
        by = {e: [r for r in rows if r["n_grid"] == g and r["engine"] == e and "wall_s" in r] for e in ("newton", "taichi_mpm")}
        if not all(by.values()):
            continue
        n, t = by["newton"][-1], by["taichi_mpm"][-1]
        out.append({"n_grid": g, "speedup_taichi_over_newton": min(r["wall_s"] for r in by["taichi_mpm"])
                    / min(r["wall_s"] for r in by["newton"]),
                    "centroid_z_rel": n["centroid_z"] / t["centroid_z"] - 1, "radius_rel": n["radius"] / t["radius"] - 1})
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-grid", default="64")
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--out", default=str(RESULTS / "bench_newton.json"))
    ap.add_argument("--bounce", nargs="+", metavar="DIR", help="only print the bounce figures of these gasp simulate "
                    "output folders (e.g. examples/donut_jelly.toml on each engine)")
    a = ap.parse_args()
    if a.bounce:
        for d in a.bounce:
            print(json.dumps(bounce(Path(d))))
        return
    rows: list[dict] = []
    with tempfile.TemporaryDirectory() as tmp:
        for g in [int(v) for v in a.n_grid.split(",")]:
            for _ in range(a.repeats):
                for engine in ("newton", "taichi_mpm"):
                    rows.append(run(engine, g, a.frames, Path(tmp)))
                    print(json.dumps(rows[-1]), flush=True)
                    doc = {"machine": os.uname().nodename, "cpus": os.cpu_count(), "rows": rows, "summary": summary(rows)}
                    dst = Path(a.out)
                    dst.parent.mkdir(parents=True, exist_ok=True)
                    tmpf = dst.with_suffix(".tmp")
                    tmpf.write_text(json.dumps(doc, indent=1))
                    os.replace(tmpf, dst)
    print(json.dumps(summary(rows), indent=1))


if __name__ == "__main__":
    sys.exit(main())
