"""Render time per frame at 640x480: the donut (45,624 Gaussians) and the guitar tiled 3x (~272k).

Writes ``benchmarks/results/bench_render.md`` and ``.json``. Each figure is the median of
``--repeats`` renders after one warm-up (the warm-up holds numba's compile or cache load).
The NumPy path is timed on the donut only (it takes about a minute a frame).

Run: ``python benchmarks/bench_render.py``
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from gasp_core.gs.io import read_gaussians
from gasp_core.render.registry import get_renderer
from gasp_core.render.run import make_view
from gasp_core.gs.splat_numpy import Splats, project, splats_from_gaussians

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results"


def scenes():
    donut = splats_from_gaussians(read_gaussians(ROOT / "examples/data/donut_v3dg.ply"))
    guitar = splats_from_gaussians(read_gaussians(ROOT / "examples/data/guitar.compressed.ply"))
    size = np.ptp(np.percentile(guitar.means, [1, 99], axis=0), axis=0)
    tiles = []
    for k in range(3):          # three guitars side by side along x
        off = np.array([k * 1.1 * size[0], 0.0, 0.0])
        tiles.append(Splats(guitar.means + off, guitar.covs, guitar.rgb, guitar.opacities))
    return {"donut": donut, "guitar x3": Splats.concat(tiles)}


def time_one(renderer, s, view, repeats):
    renderer(s, view.camera, view.background)           # warm-up
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        c0 = time.process_time()
        renderer(s, view.camera, view.background)
        ts.append((time.perf_counter() - t0, time.process_time() - c0))
    ts = np.array(ts)
    return float(np.median(ts[:, 0])), float(np.median(ts[:, 1]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-numpy", action="store_true")
    args = ap.parse_args()
    rows = []
    for name, s in scenes().items():
        lo, hi = np.percentile(s.means, 0.1, axis=0), np.percentile(s.means, 99.9, axis=0)
        view = make_view(lo, hi, None, 640, 480)
        p = project(s, view.camera)
        pairs = int(((p["x1"] - p["x0"]).astype(np.int64) * (p["y1"] - p["y0"])).sum())
        for rname in ("cpu", "numpy"):
            if rname == "numpy" and (args.no_numpy or name != "donut"):
                continue
            wall, cpu = time_one(get_renderer(rname), s, view, 1 if rname == "numpy" else args.repeats)
            rows.append({"scene": name, "gaussians": s.n, "renderer": rname, "footprint_pairs": pairs,
                         "s_per_frame": wall, "cpu_s_per_frame": cpu})
            print(rows[-1], flush=True)
    meta = {"machine": platform.machine(), "cpus": os.cpu_count(), "load_avg_end": os.getloadavg(),
            "resolution": "640x480"}
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "bench_render.json").write_text(json.dumps({"meta": meta, "rows": rows}, indent=2))
    lines = ["# Render time per frame, 640x480 (`python benchmarks/bench_render.py`)", "",
             f"{meta['cpus']} logical CPUs, {meta['machine']}; load average at the end: "
             f"{', '.join(f'{x:.1f}' for x in meta['load_avg_end'])}. Median of repeats after a warm-up; "
             "`CPU s` is process CPU time (all threads), less sensitive to other load than wall time. "
             "`pairs`: (Gaussian, pixel) pairs inside the footprints before the transmittance cut.", "",
             "| scene | Gaussians | renderer | pairs | wall s/frame | CPU s/frame |", "|---|---:|---|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['gaussians']:,} | {r['renderer']} | {r['footprint_pairs']:,} | "
                     f"{r['s_per_frame']:.2f} | {r['cpu_s_per_frame']:.2f} |")
    (OUT / "bench_render.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
