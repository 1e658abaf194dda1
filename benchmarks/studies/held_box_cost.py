"""Round 65 (``docs/performance.md`` "Round 65: the held boxes and viscous bodies over the touched box"): what
warp_mpm's whole-grid sweeps cost per substep on the CPU in the scenes round 64 left on the whole grid
(``grid_box.whole_grid_reasons``):
a tension specimen held by a ``fixed_region`` and pulled by a set box impulse (``benchmarks/tension_family.py``'s
``build``: brittle, f64, so the broken faces' marks and the brittle held rule's face nodes run), an elastic bar held
the same way, and two viscous bodies (``tests/test_viscous_bodies.py``'s ``two_bodies``, the implicit step), at the
n_grid the tests use and at twice it; each over the whole grid (``grid_box.HELD_BOX`` and ``VISC_BOX`` False) and
over the box (True).

Per scene and setting: each recorded launch timed alone (the process's CPU seconds, ``time.process_time``, around it
and a synchronise: warp's CPU kernels run on the calling thread, so the other jobs' load counts less than in wall
time; the viscous step's solve as one
entry, ``visc_solve``), the grid update's, the held passes' (``mirror_held``, ``hold_set_faces``, ``clear_cut``,
``mark_cut``) and all kernels' ms a substep, the box's share of the grid at the end and the points' hash (the two
settings must give the same); each the median of ``--repeat`` runs, interleaved.

    python benchmarks/studies/held_box_cost.py [--scenes bar24,bar48,bone24,elastic24,visc24,visc48] [--frames N]
    python benchmarks/studies/held_box_cost.py --only bar48 --frames 20   # one untimed run (farm-bench --vs)

Results: ``benchmarks/results/held_box_cost.json`` and ``.md`` (``held_box_cost_main.*`` with ``--tag main``: main's
tree on PYTHONPATH, ``--settings 0``, main's whole-grid kernels).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "tests"))
#: Frames timed a scene (``--frames`` 0): about 40 substeps each (the tension scenes take 1 a frame at n_grid 24, 2 at
#: 48; the viscous ones 8 and 15).
FRAMES = {"bar24": 40, "bone24": 40, "elastic24": 40, "bar48": 20, "visc24": 5, "visc48": 3}
PASSES = ("grid_update", "mirror_held", "hold_set_faces", "clear_cut", "mark_cut", "held_box", "field_box",
          "box_reset", "visc_solve")


def setup_of(scene: str):
    """The scene's setup (module notes): ``bar``/``bone``/``elastic`` then ``visc`` with the n_grid at the end."""
    name, n = scene.rstrip("0123456789"), int(scene[len(scene.rstrip("0123456789")):])
    if name in ("bar", "bone", "elastic"):
        import tension_family as tf
        from gasp_core.seam.setup import Material
        sp = tf.FAMILY[1] if name != "bone" else next(s for s in tf.FAMILY if s.gauge_l > 0)
        s = tf.build(sp, n, "warp_mpm")[0]
        if name == "elastic":
            s.materials = [Material("jelly", E=m.E, nu=m.nu, rho=m.rho) for m in s.materials]
        return s
    from test_viscous_bodies import two_bodies
    return two_bodies(n, n // 6, n // 6, "cpu")[0]


def box_share(eng) -> float:
    """The grid update's hull over the grid's nodes."""
    b = eng.grid_box.numpy()
    lo, hi = np.minimum(b[:3], b[6:9]), np.maximum(b[3:6], b[9:12])
    return float(np.prod(np.maximum(hi - lo + 1, 0))) / eng.n_grid ** 3


def timed(eng, table: dict) -> None:
    """``eng._substep`` replaced: each recorded launch (and the viscous solve) timed alone into ``table``."""
    import warp as wp

    def tick(key, fn):   # the process's CPU seconds (warp's CPU kernels run on this thread): less the others' load
        t0 = time.process_time()
        fn()
        wp.synchronize_device(eng.device)
        table[key] += time.process_time() - t0

    def substep(s: int, capturing: bool = False) -> None:
        table["substeps"] += 1
        for cmd in eng._pre:
            tick(cmd.kernel.key, cmd.launch)
        for i, cmd in enumerate(eng._launches):
            tick(cmd.kernel.key, cmd.launch)
            if i == 0 and eng.visc is not None:
                tick("visc_solve", lambda: eng.visc.solve(capturing))
        for cmd in (eng._passive_at[s], eng._tick):
            if cmd is not None:
                tick(cmd.kernel.key, cmd.launch)
    eng._substep = substep


def run_scene(scene: str, frames: int, profile: bool) -> dict:
    """One run of ``scene`` (the current switch): a first frame (compiles), then ``frames`` frames timed."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    eng = build_engine(get_engine("warp_mpm"), setup_of(scene))
    eng.step_frame()
    table = defaultdict(float)
    if profile:
        timed(eng, table)
    t0 = time.perf_counter()
    for _ in range(frames):
        eng.step_frame()
    wall = time.perf_counter() - t0
    x = eng.positions().copy()
    share, ng = box_share(eng), eng.n_grid
    eng.close()
    n = max(table.pop("substeps", 0), 1)
    ms = {p: 1e3 * sum(v for k, v in table.items() if k == p or k.endswith("__" + p)) / n for p in PASSES}
    return {"scene": scene, "n_grid": ng, "substeps": n, "wall_s": wall, "box": share, "pass_ms": ms,
            "kernels_ms": 1e3 * sum(table.values()) / n, "hash": hashlib.sha256(x.tobytes()).hexdigest()[:8],
            "kernels_s": dict(table)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default="bar24,bar48,bone24,elastic24,visc24,visc48")
    ap.add_argument("--frames", type=int, default=0, help="frames timed (0: the scene's FRAMES)")
    ap.add_argument("--settings", default="0,1", help="HELD_BOX settings to run (0 whole grid, 1 the box)")
    ap.add_argument("--tag", default="", help="results' name suffix (e.g. main: run on main's tree, --settings 0)")
    ap.add_argument("--repeat", type=int, default=3, help="runs of each scene and setting (their medians)")
    ap.add_argument("--only", default=None, help="one untimed run of this scene")
    a = ap.parse_args()
    if a.only:
        r = run_scene(a.only, a.frames or FRAMES.get(a.only, 10), False)
        print(json.dumps({k: v for k, v in r.items() if k != "kernels_s"}))
        return
    from gasp_warp_mpm import grid_box
    settings = [bool(int(c)) for c in a.settings.split(",")]
    runs = defaultdict(list)   # (scene, setting): the repeats, interleaved (the machine's drift on each alike)
    for _ in range(a.repeat):
        for scene in a.scenes.split(","):
            for setting in settings:
                if hasattr(grid_box, "HELD_BOX"):
                    grid_box.HELD_BOX = grid_box.VISC_BOX = setting
                runs[scene, setting].append(run_scene(scene, a.frames or FRAMES.get(scene, 10), True))
    rows = []
    for (scene, setting), rs in runs.items():
        r = dict(rs[0], setting="box" if setting else "whole grid", repeats=len(rs))
        r["pass_ms"] = {p: float(np.median([x["pass_ms"][p] for x in rs])) for p in PASSES}
        r["kernels_ms"] = float(np.median([x["kernels_ms"] for x in rs]))
        assert len({x["hash"] for x in rs}) == 1
        rows.append(r)
        print(scene, r["setting"], {k: round(v, 3) for k, v in r["pass_ms"].items() if v},
              round(r["kernels_ms"], 2), round(r["box"], 3), r["hash"], flush=True)
    import gasp_warp_mpm
    lines = [f"# held_box_cost: warp_mpm CPU, ms a substep (medians of {a.repeat}), whole grid against the box", "",
             f"gasp_warp_mpm: {Path(gasp_warp_mpm.__file__).parent}", "",
             "| scene | n_grid | substeps | setting | box share | " + " | ".join(PASSES)
             + " | kernels ms a substep | points |", "|---" * (8 + len(PASSES)) + "|"]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['n_grid']} | {r['substeps']} | {r['setting']} | {r['box']:.3f} | "
                     + " | ".join(f"{r['pass_ms'][p]:.3f}" for p in PASSES)
                     + f" | {r['kernels_ms']:.2f} | {r['hash']} |")
    out = ROOT / "benchmarks" / "results" / ("held_box_cost" + (f"_{a.tag}" if a.tag else ""))
    out.with_suffix(".json").write_text(json.dumps(rows, indent=1))
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
