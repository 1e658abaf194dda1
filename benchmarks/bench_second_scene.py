"""One compile per install? (issue 54 item 7): the time from the start of ``gasp simulate`` to its frame 1, for a
second, different example after a first one has warmed the kernel caches, on each MLS-MPM engine.

For each engine, with kernel caches of its own (empty at the start: ``TI_OFFLINE_CACHE_FILE_PATH`` and
``WARP_CACHE_PATH`` in a temporary folder): example A (the README donut) runs 1 frame twice (cold, then cached), then
examples B (the wooden donut: a rigid body, same size) and C (the kitchen: sand, another point count and grid) run
1 frame each. Each run is a fresh process; the figure is when frame 1's file is written, from the start of the
command (its modification time), beside the whole command's time (which adds the process's exit) and frame 1's own
time from its ``run.json``. The issue's target: B's and C's frame 1 within 5 s of the start.

Beside the times, the figure that decides "one compile per install" without a clock: the files each run adds to the
engine's kernel cache (Warp: its compiled modules; Taichi: its cached kernels). On warp_mpm the first run compiles
every kernel of the plugin (``gasp_warp_mpm/warmup.py``), so B and C add none. The warp_mpm runs after the first
are repeated :data:`REPEATS` times (each still a fresh process, nothing left to compile) and the median given, since
this shared machine's times wander by a second from run to run; on taichi_mpm only the first run of a scene is the
"second scene" (its kernels are compiled for the scene's sizes, so a repeat would find them cached).
Python writes its bytecode as on a user's machine (``PYTHONDONTWRITEBYTECODE`` is dropped from the runs' environment:
pip writes it at install, and this sandbox's setting would compile GASP's modules from source in every run).

    python benchmarks/bench_second_scene.py            # writes benchmarks/results/second_scene.{json,md}
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
RUNS = [("A (README donut, cold caches)", "donut_jelly"), ("A again (its own cache)", "donut_jelly"),
        ("B (wooden donut: rigid, same size)", "donut_wood"), ("C (kitchen: sand, 6,736 points)", "kitchen_spinach")]
#: Runs of each warp_mpm scene after the cold one (median reported).
REPEATS = 5


def cache_entries(cache: Path) -> int:
    """Files in a kernel cache folder and its folders (Taichi's cached kernels, Warp's compiled modules)."""
    return sum(1 for p in cache.rglob("*") if p.is_file())


def run(engine: str, example: str, work: Path, env: dict) -> dict:
    text = (EXAMPLES / f"{example}.toml").read_text().replace('name = "taichi_mpm"', f'name = "{engine}"')
    text = text.replace('"data/', f'"{EXAMPLES / "data"}/')
    scene = work / f"{engine}_{example}_{time.monotonic_ns()}.toml"
    scene.write_text(text)
    out = work / scene.stem
    t0, start = time.perf_counter(), time.time()
    subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(out),
                    "--frames", "1", "-q"], check=True, capture_output=True, env=env)
    wall = time.perf_counter() - t0
    rec = json.loads((out / "run.json").read_text())
    written = max(f.stat().st_mtime for f in out.glob("*/frame_0001*"))   # the last object's frame 1 file
    return {"frame1_at_s": written - start, "wall_s": wall, "frame1_s": rec["frames"][1]["wall_s"],
            "prepare_s": rec.get("prepare_s", 0.0), "build_s": rec.get("build_s", 0.0)}


def median_run(engine: str, example: str, work: Path, env: dict, cache: Path, times: int) -> dict:
    """``times`` runs: the median of each figure, the first run's frame 1 time, the cache entries they added and the
    load average (1 min) before them."""
    before, load = cache_entries(cache), round(os.getloadavg()[0], 2)
    rs = [run(engine, example, work, env) for _ in range(times)]
    out = {k: round(float(np.median([r[k] for r in rs])), 2) for k in rs[0]}
    return {**out, "first_frame1_at_s": round(rs[0]["frame1_at_s"], 2), "runs": times,
            "added_to_cache": cache_entries(cache) - before, "load_1min": load}


def main() -> None:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for engine in ("taichi_mpm", "warp_mpm"):
            cache = Path(tmp) / f"cache_{engine}"
            env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
            env.update(TI_OFFLINE_CACHE_FILE_PATH=str(cache / "taichi"), WARP_CACHE_PATH=str(cache / "warp"))
            for i, (label, example) in enumerate(RUNS):
                times = REPEATS if engine == "warp_mpm" and i > 0 else 1
                r = median_run(engine, example, Path(tmp), env, cache, times)
                rows.append({"engine": engine, "run": label, **r})
                print(engine, label, r, flush=True)
    res = ROOT / "benchmarks" / "results"
    (res / "second_scene.json").write_text(json.dumps(rows, indent=2))
    md = ["| engine | run | frame 1 written (s from the start) | first run's | whole command (s) | frame 1 (s) "
          "| prepare (s) | build (s) | runs | added to the kernel cache | load (1 min) |", "|---" * 11 + "|"]
    md += [f"| {r['engine']} | {r['run']} | {r['frame1_at_s']} | {r['first_frame1_at_s']} | {r['wall_s']} "
           f"| {r['frame1_s']} | {r['prepare_s']} | {r['build_s']} | {r['runs']} | {r['added_to_cache']} "
           f"| {r['load_1min']} |" for r in rows]
    (res / "second_scene.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
