"""Round 64 (``docs/performance.md`` "Round 64: the grid update over the touched box"): what warp_mpm's grid update
costs per substep on the CPU over the whole grid (``grid_box.GRID_BOX`` False) and over the touched hull (True), in
one process, with the points' hash of both (they must be the same).

Per scene and setting: the substeps' seconds per kernel (each recorded launch timed alone with a synchronise,
``benchmarks/rigid_pairs_cost.py``'s ``warp_timed``, through ``field_box_cost.py``'s ``Watch``), the grid update's ms a
substep, the box passes' (``field_box``, ``box_reset``), all kernels' seconds, the hull's share of the grid at the end.
Scenes: ``cup`` (``examples/cup_drop.toml`` at 20 m/s, n_grid 96, 47 fragments), ``jelly_on_ground`` (one 6 cm jelly
block thrown onto a ground, ``scenes_rigid3._setup``, n_grid 64: one body, the grid update's own box),
``jelly_on_jelly`` (``field_box_cost.py``'s, n_grid 48: two fields, the field passes' box).

    python benchmarks/studies/grid_box_cost.py [--scenes cup,jelly_on_ground,jelly_on_jelly] [--frames 6]
    python benchmarks/studies/grid_box_cost.py --only jelly_on_ground --frames 20   # one untimed run (farm-bench --vs)

Results: ``benchmarks/results/grid_box_cost.json`` and ``.md``.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "benchmarks" / "studies"))
import field_box_cost as F  # noqa: E402

PASSES = ("grid_update", "field_box", "box_reset")
FIELD_SCENES = F.setup_of   # field_box_cost's scenes


def setup_of(scene: str):
    from gasp_core.testing import scenes_rigid3 as S
    if scene == "jelly_on_ground":
        return S._setup([([-0.03, -0.03, 0.03], [0.03, 0.03, 0.09])], ("elastic",), [0.5, 0.0, -0.5], 64, 0.5, [None])
    return FIELD_SCENES(scene)


def grid_share(eng) -> float:
    """The grid update's hull over the grid's nodes (1 on a tree without it)."""
    if getattr(eng, "grid_box", None) is None:
        return 1.0
    b = eng.grid_box.numpy()
    lo, hi = np.minimum(b[:3], b[6:9]), np.maximum(b[3:6], b[9:12])
    return float(np.prod(np.maximum(hi - lo + 1, 0))) / eng.n_grid ** 3


def run_scene(scene: str, frames: int, profile: bool) -> dict:
    F.setup_of, F.box_share = setup_of, grid_share   # field_box_cost's run with this study's scenes and hull
    return F.run_scene(scene, frames, profile)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default="cup,jelly_on_ground,jelly_on_jelly")
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--only", default=None, help="one untimed run of this scene (a tree with or without the box)")
    a = ap.parse_args()
    if a.only:
        r = run_scene(a.only, a.frames, False)
        print(json.dumps({k: v for k, v in r.items() if k != "kernels_s"}))
        return
    from gasp_warp_mpm import grid_box
    rows = []
    for scene in a.scenes.split(","):
        for setting in (False, True):
            grid_box.GRID_BOX = setting
            r = run_scene(scene, a.frames, True)
            n = max(r["substeps"], 1)
            ms = {p: 1e3 * sum(v for k, v in r["kernels_s"].items() if k.endswith("__" + p)) / n for p in PASSES}
            r.update(scene=scene, setting="box" if setting else "whole grid", pass_ms=ms)
            rows.append(r)
            print(scene, r["setting"], {k: round(v, 3) for k, v in ms.items()}, r["hash"], flush=True)
    lines = ["# grid_box_cost: warp_mpm CPU, the grid update's ms a substep, whole grid against the touched hull", "",
             "| scene | n_grid | substeps | setting | hull share | " + " | ".join(PASSES)
             + " | kernels ms a substep | points |", "|---" * (8 + len(PASSES)) + "|"]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['n_grid']} | {r['substeps']} | {r['setting']} | {r['box']:.3f} | "
                     + " | ".join(f"{r['pass_ms'][p]:.3f}" for p in PASSES)
                     + f" | {1e3 * sum(r['kernels_s'].values()) / max(r['substeps'], 1):.2f} | {r['hash']} |")
    out = ROOT / "benchmarks" / "results" / "grid_box_cost"
    out.with_suffix(".json").write_text(json.dumps(rows, indent=1))
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
