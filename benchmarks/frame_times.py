"""Wall time a frame and the positions' sha1 of a bundled example on taichi_mpm's CPU schedule (round 39: the passive
G2P's cost measured beside a base checkout). Run it from two checkouts, each with its own code first on the path::

    PYTHONPATH=<tree>:<tree>/plugins/taichi_mpm python benchmarks/frame_times.py donut_shatter --frames 4 --threads 2

Prints a line a frame (frame, wall s, sha1 of the positions) and writes ``benchmarks/results/frame_times_<example>.json``
(``--out``)."""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("example")
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.runner import RunStats, run_engine
    scene = load_scene(ROOT / "examples" / f"{a.example}.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = prepare_scene(scene, "taichi_mpm", options={**scene.engine.options, "threads": a.threads})
    rows = []
    for rec in run_engine(prep.info, prep.setup, a.frames, RunStats()):
        sha = hashlib.sha1(np.ascontiguousarray(rec.x).tobytes()).hexdigest()[:12]
        rows.append({"frame": rec.frame, "wall_s": rec.wall_s, "sha1": sha})
        print(rec.frame, f"{rec.wall_s:.2f}", sha, flush=True)
    out = a.out or ROOT / "benchmarks" / "results" / f"frame_times_{a.example}.json"
    doc = {"example": a.example, "threads": a.threads, "load_before": os.getloadavg()[0], "frames": rows,
           "code": str(Path(__file__).resolve().parents[1])}
    out.write_text(json.dumps(doc, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
