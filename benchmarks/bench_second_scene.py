"""One compile per install? (issue 54 item 7): the time from the start of ``gasp simulate`` to its frame 1, for a
second, different example after a first one has warmed the kernel caches, on each MLS-MPM engine.

For each engine, with kernel caches of its own (empty at the start: ``TI_OFFLINE_CACHE_FILE_PATH`` and
``WARP_CACHE_PATH`` in a temporary folder): example A (the README donut) runs 1 frame twice (cold, then cached), then
examples B (the wooden donut: a rigid body, same size) and C (the kitchen: sand, another point count and grid) run
1 frame each. Each run is a fresh process; the figure is the wall time of the whole command (prepare, build,
frame 1, writing) and frame 1's own time from its ``run.json``. The issue's target: B and C within 5 s of the start.

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

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
RUNS = [("A (README donut, cold caches)", "donut_jelly"), ("A again (its own cache)", "donut_jelly"),
        ("B (wooden donut: rigid, same size)", "donut_wood"), ("C (kitchen: sand, 6,904 points)", "kitchen_spinach")]


def run(engine: str, example: str, work: Path, env: dict) -> dict:
    text = (EXAMPLES / f"{example}.toml").read_text().replace('name = "taichi_mpm"', f'name = "{engine}"')
    text = text.replace('"data/', f'"{EXAMPLES / "data"}/')
    scene = work / f"{engine}_{example}_{time.monotonic_ns()}.toml"
    scene.write_text(text)
    out = work / scene.stem
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(out),
                    "--frames", "1", "-q"], check=True, capture_output=True, env=env)
    wall = time.perf_counter() - t0
    rec = json.loads((out / "run.json").read_text())
    return {"wall_s": round(wall, 2), "frame1_s": round(rec["frames"][1]["wall_s"], 2),
            "prepare_s": round(rec.get("prepare_s", 0.0), 2), "build_s": round(rec.get("build_s", 0.0), 2)}


def main() -> None:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for engine in ("taichi_mpm", "warp_mpm"):
            cache = Path(tmp) / f"cache_{engine}"
            env = {**os.environ, "TI_OFFLINE_CACHE_FILE_PATH": str(cache / "taichi"), "WARP_CACHE_PATH": str(cache / "warp")}
            for label, example in RUNS:
                r = run(engine, example, Path(tmp), env)
                rows.append({"engine": engine, "run": label, **r})
                print(engine, label, r, flush=True)
    res = ROOT / "benchmarks" / "results"
    (res / "second_scene.json").write_text(json.dumps(rows, indent=2))
    md = ["| engine | run | whole command (s) | frame 1 (s) | prepare (s) | build (s) |", "|---|---|---|---|---|---|"]
    md += [f"| {r['engine']} | {r['run']} | {r['wall_s']} | {r['frame1_s']} | {r['prepare_s']} | {r['build_s']} |"
           for r in rows]
    (res / "second_scene.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
