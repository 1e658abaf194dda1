"""Round 64 (issues 65/66/67; ``docs/performance.md`` "Round 64: the field passes over the touched box"): what the
two-field contact's node passes cost per substep on warp_mpm's CPU, over the whole grid (``field_nodes.FIELD_BOX``
False, round 63's passes) and over the field box (True), in one process, and what the recolouring's contact graph
costs a frame against round 61's loop (``tests/test_field_box.py``'s ``graph_before``, the reference).

Per scene and setting: the substeps' seconds per kernel (each recorded launch timed alone with a synchronise,
``benchmarks/rigid_pairs_cost.py``'s ``warp_timed``; on the CPU the kernels run in turn), the field passes' ms a
substep (``field_shared``, ``field_clear``, ``field_old``, ``gap_clear``, ``flow_apply``, and the box's own
``field_box``, ``box_reset``), the box's share of the grid at the end, and a hash of the points (the two settings
must give the same). Scenes: ``cup`` (``examples/cup_drop.toml`` at 20 m/s, n_grid 96, 47 fragments), ``heap``
(``scenes_rigid3.heap_setup``: 48 rigid blocks, n_grid 48), ``jelly_on_jelly`` and ``block_on_jelly`` (two bodies,
``tests/test_soft_on_rigid_rest.py``'s boxes, n_grid 48; round 69: ``block_on_jelly_96``, the same at n_grid 96, for
the rigid collider's node passes over the box, ``rigid_collider.rc_nodes``). The graph: the heap's frames' points, each graph built by
both and compared.

    python benchmarks/studies/field_box_cost.py [--scenes cup,heap,jelly_on_jelly,block_on_jelly] [--frames 6]
    python benchmarks/studies/field_box_cost.py --only jelly_on_jelly --frames 20   # one run, untimed inside

The second form (no profile, no writing; for a whole-process timing of two trees) runs on a tree without the box
too. Results: ``benchmarks/results/field_box_cost.json`` and ``.md``.
"""
from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
PASSES = ("field_shared", "field_clear", "field_old", "gap_clear", "flow_apply", "field_box", "box_reset")
JELLY = ([-0.10, -0.08, 0.0], [0.18, 0.08, 0.04])


def pair_setup(models, n_grid: int):
    """Two boxes of ``tests/test_soft_on_rigid_rest.py`` (a 6 cm block on a 28 x 16 x 4 cm jelly, E 1e5 Pa)."""
    from gasp_core.testing import scenes_rigid3 as S
    s = S._setup([([-0.03, -0.03, 0.04], [0.03, 0.03, 0.07]), JELLY], models, [0.0, 0.0, 0.0], n_grid, 0.0,
                 [None, None])
    s.materials = [dataclasses.replace(m, E=1.0e5) for m in s.materials]
    return s


def setup_of(scene: str):
    from gasp_core.testing.scenes_rigid3 import heap_setup
    return {"heap": lambda: heap_setup(48, 4, 3),
            "jelly_on_jelly": lambda: pair_setup(("elastic", "elastic"), 48),
            "block_on_jelly": lambda: pair_setup(("rigid", "elastic"), 48),
            "block_on_jelly_96": lambda: pair_setup(("rigid", "elastic"), 96)}[scene]()


def box_share(eng) -> float:
    """The field box's hull over the grid's nodes (1 without the box)."""
    b = eng.field_box.numpy() if hasattr(eng, "field_box") else None
    if b is None:
        return 1.0
    lo, hi = np.minimum(b[:3], b[6:9]), np.maximum(b[3:6], b[9:12])
    return float(np.prod(np.maximum(hi - lo + 1, 0))) / eng.n_grid ** 3


class Watch:
    """warp_mpm's engine class patched while a run lasts: each substep counted (and with ``profile`` each recorded
    launch timed alone, ``rigid_pairs_cost.warp_timed``), the field box's share and the grid kept at ``close``."""

    def __init__(self, profile: bool):
        from gasp_warp_mpm.engine import WarpMPMEngine
        from rigid_pairs_cost import warp_timed
        self.cls, self.table, self.seen = WarpMPMEngine, defaultdict(float), {"substeps": 0}
        self.real = (WarpMPMEngine._substep, WarpMPMEngine.close)
        if profile:
            warp_timed(WarpMPMEngine, self.table)
        timed, close, seen = WarpMPMEngine._substep, WarpMPMEngine.close, self.seen

        def substep(eng, s, capturing=False):
            seen["substeps"] += 1
            return timed(eng, s, capturing)

        def closing(eng):
            if getattr(eng, "_launches", None):
                seen.update(box=box_share(eng), n_grid=eng.n_grid)
            return close(eng)
        WarpMPMEngine._substep, WarpMPMEngine.close = substep, closing

    def done(self) -> dict:
        self.cls._substep, self.cls.close = self.real
        return {"kernels_s": dict(self.table), "substeps": self.seen["substeps"], "box": self.seen.get("box", 1.0),
                "n_grid": self.seen.get("n_grid", 0)}


def run_scene(scene: str, frames: int, profile: bool) -> dict:
    """One run of ``scene`` (the current ``FIELD_BOX``): wall seconds of the frames (after a first one that compiles;
    the cup's every frame, its break at frame 0 included), the kernels' seconds (``profile``), the substeps timed,
    the box's share at the end, the points' hash."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    if scene == "cup":
        import cup_drop
        watch = Watch(profile)
        try:
            with tempfile.TemporaryDirectory() as tmp:
                res = cup_drop.run("warp_mpm", 20.0, frames, Path(tmp) / "cup")
        finally:
            out = watch.done()
        x = np.round(np.asarray(res["xs"][-1], float), 9)
        return {**out, "wall_s": res["wall_s"], "hash": hashlib.sha256(x.tobytes()).hexdigest()[:8]}
    eng = build_engine(get_engine("warp_mpm"), setup_of(scene))
    eng.step_frame()
    watch = Watch(profile)
    try:
        t0 = time.perf_counter()
        for _ in range(frames):
            eng.step_frame()
        wall = time.perf_counter() - t0
        x = eng.positions().copy()
        eng.close()
    finally:
        out = watch.done()
    return {**out, "wall_s": wall, "hash": hashlib.sha256(x.tobytes()).hexdigest()[:8]}


def pass_ms(r: dict, substeps: int) -> dict:
    """The field passes' ms a substep (``substeps`` the run's; from the kernels' names)."""
    out = {}
    for name in PASSES:
        s = sum(v for k, v in r["kernels_s"].items() if k.endswith("__" + name))
        if s:
            out[name] = 1e3 * s / max(substeps, 1)
    return out


def graph_cost(frames: int) -> dict:
    """The heap's recolouring graph on ``frames`` frames of its run: ms a frame, round 61's loop against round 64's,
    and whether every graph was the same."""
    from types import SimpleNamespace
    from gasp_core.mpm import colouring
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    sys.path.insert(0, str(ROOT / "tests"))   # here: the other runs import the engines of PYTHONPATH's tree
    from test_field_box import graph_before
    s = setup_of("heap")
    eng = build_engine(get_engine("warp_mpm"), s)
    t_new = t_old = 0.0
    same = True
    for _ in range(frames):
        eng.step_frame()
        view = SimpleNamespace(x=np.asarray(eng.positions(), float), v=np.asarray(eng.velocities(), float),
                               p_vol=s.p_vol, body_id=s.body_id, materials=s.materials, dx=float(s.dx),
                               frame_dt=s.frame_dt, gravity=s.gravity, n_material=None)
        t0 = time.perf_counter()
        new = colouring.contact_graph(view)
        t1 = time.perf_counter()
        old = graph_before(view)
        t_old += time.perf_counter() - t1
        t_new += t1 - t0
        same = same and new == old
    eng.close()
    return {"frames": frames, "round61_ms": 1e3 * t_old / frames, "round64_ms": 1e3 * t_new / frames, "same": same}


def markdown(rows: list, graph: dict | None) -> str:
    lines = ["# field_box_cost: warp_mpm CPU, the field passes' ms a substep, whole grid against the field box", "",
             "| scene | n_grid | substeps | setting | box share | " + " | ".join(PASSES) + " | passes | kernels s |"
             " points |", "|---" * (8 + len(PASSES)) + "|"]
    for r in rows:
        ms = r["pass_ms"]
        lines.append(f"| {r['scene']} | {r['n_grid']} | {r['substeps']} | {r['setting']} | {r['box']:.3f} | "
                     + " | ".join(f"{ms[p]:.3f}" if p in ms else "-" for p in PASSES)
                     + f" | {sum(ms.values()):.3f} | {sum(r['kernels_s'].values()):.2f} | {r['hash']} |")
    if graph:
        lines += ["", f"Recolouring graph, heap ({graph['frames']} frames): round 61 {graph['round61_ms']:.1f} ms a "
                  f"frame, round 64 {graph['round64_ms']:.1f} ms; the same graphs: {graph['same']}"]
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default="cup,heap,jelly_on_jelly,block_on_jelly")
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--only", default=None, help="one untimed run of this scene (a tree with or without the box)")
    a = ap.parse_args()
    if a.only:
        r = run_scene(a.only, a.frames, False)
        print(json.dumps({k: v for k, v in r.items() if k != "kernels_s"}))
        return
    from gasp_warp_mpm import field_nodes
    rows = []
    for scene in a.scenes.split(","):
        for setting in (False, True):
            field_nodes.FIELD_BOX = setting
            r = run_scene(scene, a.frames, True)
            r.update(scene=scene, setting="box" if setting else "whole grid", pass_ms=pass_ms(r, r["substeps"]))
            rows.append(r)
            print(scene, r["setting"], {k: round(v, 3) for k, v in r["pass_ms"].items()}, r["hash"], flush=True)
    graph = graph_cost(a.frames) if "heap" in a.scenes else None
    out = ROOT / "benchmarks" / "results" / "field_box_cost"
    out.with_suffix(".json").write_text(json.dumps({"rows": rows, "graph": graph}, indent=1))
    out.with_suffix(".md").write_text(markdown(rows, graph))
    print(markdown(rows, graph))


if __name__ == "__main__":
    main()
