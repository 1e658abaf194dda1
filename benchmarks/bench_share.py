"""What sharing and view-dependent colour cost: the ``gasp view --export`` page and SH-3 shading per frame.

* Export: page size (MB, MB per frame) and wall time for a run folder (``--run``; default: a 14-frame
  donut run made here with taichi_mpm, n_grid 24, threads 1, as the tests' ``donut_run``).
* SH: seconds per frame of :meth:`Splats.seen_from` (SH degree 3, the real ``tests/data/pc_short.ply``
  tiled to 45,600 Gaussians, about the donut's count) beside the ``cpu`` renderer's time on the same
  splats at 640x480, measured interleaved (median of ``--repeats``).

Writes ``benchmarks/results/bench_share.md`` and ``.json``. Run: ``python benchmarks/bench_share.py``
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

from gasp_core.gs.io import read_gaussians
from gasp_core.render.export import export_page
from gasp_core.render.registry import get_renderer
from gasp_core.render.run import load_run, make_view
from gasp_core.render.splat_numpy import splats_from_gaussians

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results"


def donut_run(tmp: Path) -> Path:
    import sys
    sys.path.insert(0, str(ROOT / "tests"))
    from gasp_testing import DONUT, scene_text
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    toml = tmp / "scene.toml"
    toml.write_text(scene_text(DONUT, n_frames=14, n_grid=24, engine_options="{ threads = 1 }",
                               extra_object="fill = false"))
    simulate_scene(load_scene(toml), tmp / "run", quiet=True)
    return tmp / "run"


def bench_export(run: Path, tmp: Path) -> dict:
    t0 = time.perf_counter()
    page = export_page(run, tmp / "page.html", overwrite=True)
    wall = time.perf_counter() - t0
    n = load_run(run).n_frames
    mb = page.stat().st_size / 1e6
    return {"frames": n, "page_MB": round(mb, 2), "MB_per_frame": round(mb / n, 3), "export_s": round(wall, 2)}


def bench_sh(repeats: int) -> dict:
    g = read_gaussians(ROOT / "tests" / "data" / "pc_short.ply")
    g = g.subset(np.tile(np.arange(g.n), 456))
    g.means = g.means + np.random.default_rng(0).normal(0, 0.3, g.means.shape)
    s = splats_from_gaussians(g)
    view = make_view(s.means.min(0), s.means.max(0), None, 640, 480)
    r = get_renderer("cpu")
    r(s.seen_from(view.camera.position), view.camera, view.background)          # warm-up (numba)
    shade, render = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        lit = s.seen_from(view.camera.position)
        t1 = time.perf_counter()
        r(lit, view.camera, view.background)
        t2 = time.perf_counter()
        shade.append(t1 - t0)
        render.append(t2 - t1)
    return {"gaussians": g.n, "sh_degree": g.sh_degree, "shade_s": round(float(np.median(shade)), 4),
            "render_s": round(float(np.median(render)), 4),
            "shade_over_render": round(float(np.median(shade) / np.median(render)), 3)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, default=None, help="run folder to export (default: make a 14-frame donut run)")
    ap.add_argument("--repeats", type=int, default=5, help="timed repeats per figure (default 5)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        run = args.run or donut_run(tmp)
        res = {"export": bench_export(run, tmp), "sh": bench_sh(args.repeats),
               "machine": {"cpus": os.cpu_count(), "platform": platform.platform()}}
    OUT.mkdir(exist_ok=True)
    (OUT / "bench_share.json").write_text(json.dumps(res, indent=1))
    e, s = res["export"], res["sh"]
    (OUT / "bench_share.md").write_text(
        "# Sharing and SH colour (`python benchmarks/bench_share.py`)\n\n"
        f"Export page: {e['frames']} frames, {e['page_MB']} MB ({e['MB_per_frame']} MB/frame), {e['export_s']} s.\n\n"
        f"SH degree {s['sh_degree']} colour for {s['gaussians']:,} Gaussians: {s['shade_s']} s per frame beside "
        f"{s['render_s']} s of `cpu` rendering at 640x480 (ratio {s['shade_over_render']}; median of "
        f"{args.repeats}, interleaved).\n\nMachine: {res['machine']}\n")
    print((OUT / "bench_share.md").read_text())


if __name__ == "__main__":
    main()
