"""Per-substep cost of the contact's balance (issue 38) on the README donut (`examples/donut_jelly.toml`): the
engine stepped directly, 2 frames of warm-up (kernels compiled), then ``FRAMES`` frames timed, with
``contact_balance`` true and false, alternating, in one run; the ratio is the balance's cost.

Run: ``python benchmarks/bench_balance_cost.py [--engines taichi_mpm warp_mpm] [--frames 6] [--rounds 2]``; the table
goes to stdout and ``benchmarks/results/balance_cost.md`` (with the load average before each measurement).
"""
from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def per_substep_ms(engine: str, balance: bool, frames: int) -> tuple[float, int]:
    """Milliseconds per substep over ``frames`` frames after 2 warm-up frames, and the substeps per frame."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    scene = load_scene(ROOT / "examples" / "donut_jelly.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ps = prepare_scene(scene)
        setup = ps.setup.replace(options={**ps.setup.options, "contact_balance": balance})
        e = build_engine(engines()[engine], setup)
    for _ in range(2):
        e.step_frame()
    t0 = time.perf_counter()
    for _ in range(frames):
        e.step_frame()
    wall = time.perf_counter() - t0
    n = int(e.stats()["n_substeps"])
    e.close()
    return 1e3 * wall / (frames * n), n


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--engines", nargs="+", default=["taichi_mpm", "warp_mpm"])
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--rounds", type=int, default=2)
    a = ap.parse_args()
    rows = ["| engine | round | ms per substep, balance | without | ratio | substeps a frame | load avg |",
            "|---|---|---|---|---|---|---|"]
    for engine in a.engines:
        for r in range(a.rounds):
            load = os.getloadavg()[0]
            on, n = per_substep_ms(engine, True, a.frames)
            off, _ = per_substep_ms(engine, False, a.frames)
            rows.append(f"| {engine} | {r + 1} | {on:.2f} | {off:.2f} | {on / off:.3f} | {n} | {load:.1f} |")
            print(rows[-1], flush=True)
    text = "\n".join(rows)
    out = ROOT / "benchmarks" / "results" / "balance_cost.md"
    out.write_text(f"`python benchmarks/bench_balance_cost.py --frames {a.frames} --rounds {a.rounds}` (README donut, "
                   "frames 3 onward, before it rests)\n\n" + text + "\n")
    print(text)


if __name__ == "__main__":
    main()
