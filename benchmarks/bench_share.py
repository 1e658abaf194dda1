"""What sharing and view-dependent colour cost: the ``gasp view --export`` page and SH-3 shading per frame.

* Export: page size (MB, MB per frame) and wall time for a run folder (``--run``; default: a 14-frame
  donut run made here with taichi_mpm, n_grid 24, threads 1, as the tests' ``donut_run``); what the page's
  compression moves (:func:`gasp_core.render.export.codec_errors`, over the sequence box's longest side);
  and, where playwright and Chromium are installed, the page opened from disk in headless Chromium
  (software WebGL): seconds to decode, and how many distinct frames its Play button showed.
  The README donut's figure: ``gasp simulate examples/donut_jelly.toml -o out/donut`` (any engine), then
  ``python benchmarks/bench_share.py --run out/donut --no-sh --out bench_share_donut_readme``.
* SH: seconds per frame of :meth:`Splats.seen_from` (SH degree 3, the real ``tests/data/pc_short.ply``
  tiled to 45,600 Gaussians, about the donut's count) beside the ``cpu`` renderer's time on the same
  splats at 640x480, measured interleaved (median of ``--repeats``).

Writes ``benchmarks/results/bench_share.md`` and ``.json`` (``--out`` names others). Run: ``python benchmarks/bench_share.py``
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
from gasp_core.render.export import export_page, pack_run
from gasp_core.render.registry import get_renderer
from gasp_core.render.run import load_run, make_view
from gasp_core.gs.splat_numpy import splats_from_gaussians

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
    meta, _ = pack_run(run, errors=True)
    out = {"frames": n, "gaussians": meta["n"], "moving": meta["n_moving"], "page_MB": round(mb, 2),
           "MB_per_frame": round(mb / n, 3), "export_s": round(wall, 2), "box_m": round(meta["size"], 4),
           "errors": {k: float(f"{v:.3g}") for k, v in meta["errors"].items()}}
    out["browser"] = play_in_chromium(page, n)
    return out


def play_in_chromium(page: Path, n: int) -> dict | str:
    """Open ``page`` from disk in headless Chromium, press Play from frame 0 and record the frames shown."""
    import shutil
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        return "skipped: playwright is not installed"
    exe = next((p for p in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if p), None)
    if exe is None:
        return "skipped: no Chromium"
    args = ["--headless", "--no-sandbox", "--disable-gpu", "--use-gl=swiftshader", "--enable-unsafe-swiftshader"]
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=args)
        tab = browser.new_page(viewport={"width": 800, "height": 600})
        t0 = time.perf_counter()
        tab.goto(page.resolve().as_uri())
        tab.wait_for_function("window.gasp && window.gasp.ready || window.gaspError", timeout=600_000)
        ready = time.perf_counter() - t0
        error = tab.evaluate("window.gaspError || ''")
        tab.evaluate("window.gasp.show(0)")
        tab.click("#play")
        seen, t1 = set(), time.perf_counter()
        while len(seen) < n and time.perf_counter() - t1 < 600:
            seen.add(tab.evaluate("window.gasp.frame()"))
            time.sleep(0.02)
        played = time.perf_counter() - t1
        browser.close()
    return {"ready_s": round(ready, 1), "error": error, "frames_played": len(seen), "play_s": round(played, 1)}


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
    ap.add_argument("--no-sh", action="store_true", help="leave out the SH-colour figure")
    ap.add_argument("--label", default=None, help="how the results name the run (default: its path)")
    ap.add_argument("--out", default="bench_share", help="results' name in benchmarks/results (default bench_share)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        run = args.run or donut_run(tmp)
        res = {"export": bench_export(run, tmp), "sh": None if args.no_sh else bench_sh(args.repeats),
               "run": args.label or str(args.run or "a 14-frame donut run (tests' donut_run)"),
               "machine": {"cpus": os.cpu_count(), "platform": platform.platform(), "load_avg": os.getloadavg()}}
    OUT.mkdir(exist_ok=True)
    (OUT / f"{args.out}.json").write_text(json.dumps(res, indent=1))
    e, s, b = res["export"], res["sh"], res["export"]["browser"]
    err = e["errors"]
    text = ("# Sharing and SH colour (`python benchmarks/bench_share.py`)\n\n"
            f"Export page of {res['run']}: {e['frames']} frames of {e['gaussians']:,} Gaussians ({e['moving']:,} "
            f"moving), {e['page_MB']} MB ({e['MB_per_frame']} MB/frame), written in {e['export_s']} s.\n\n"
            f"What the compression moves, largest over every Gaussian and frame, in units of the sequence box's "
            f"longest side ({e['box_m']} m): centre {err['centre']:.2g}, shape (entry of the covariance's square "
            f"root) {err['shape']:.2g}; rotation {err['rotation_deg']:.2g} degrees; scale {100 * err['scale_rel']:.2g} %.\n\n"
            + (f"Headless Chromium (software WebGL), from disk: decoded in {b['ready_s']} s, Play showed "
               f"{b['frames_played']} of {e['frames']} frames in {b['play_s']} s{'; error ' + b['error'] if b['error'] else ''}.\n\n"
               if isinstance(b, dict) else f"Chromium: {b}.\n\n"))
    if s:
        text += (f"SH degree {s['sh_degree']} colour for {s['gaussians']:,} Gaussians: {s['shade_s']} s per frame beside "
                 f"{s['render_s']} s of `cpu` rendering at 640x480 (ratio {s['shade_over_render']}; median of "
                 f"{args.repeats}, interleaved).\n\n")
    (OUT / f"{args.out}.md").write_text(text + f"Machine: {res['machine']}\n")
    print((OUT / f"{args.out}.md").read_text())


if __name__ == "__main__":
    main()
