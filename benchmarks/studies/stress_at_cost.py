"""Round 68 (issue 66 item 6; docs/fracture.md "Round 68: the midpoint stress"): the cost of the engine option
``stress_at = "mid"`` against "start", engine alone (no ledger): the README jelly donut of
``benchmarks/energy_ledger_family.py`` thrown at 4.43 m/s, n_grid 48, cfl 0.8, one warm-up frame, then the wall and
CPU seconds a frame over ``frames`` frames; "start", "mid", "start", "mid" in one process (the pair twice, for the
machine's noise).

Run: ``python benchmarks/studies/stress_at_cost.py ENGINE [FRAMES] [AT,AT,...]`` (prints one JSON line a run); round
69: ``AT`` may be ``trapezoid:P``, warp_mpm's ``stress_at = "trapezoid"`` with ``P`` passes a substep (default the
pair order above).
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv: list[str]) -> int:
    from energy_ledger_family import scene
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    engine = argv[0] if argv else "taichi_mpm"
    frames = int(argv[1]) if len(argv) > 1 else 3
    order = argv[2].split(",") if len(argv) > 2 else ["start", "mid", "start", "mid"]
    for at in order:
        s = scene("donut", engine, 48, 4.43, 0.8)
        s.options["stress_at"], _, passes = at.partition(":")
        if passes:
            s.options["stress_passes"] = int(passes)
        e = build_engine(engines()[engine], s)
        try:
            e.step_frame()   # compile, warm
            t0, c0 = time.perf_counter(), time.process_time()
            for _ in range(frames):
                e.step_frame()
            wall, cpu = (time.perf_counter() - t0) / frames, (time.process_time() - c0) / frames
            print(json.dumps({"engine": engine, "stress_at": at, "substeps": e.n_substeps,
                              "wall_s_frame": round(wall, 3), "cpu_s_frame": round(cpu, 3)}), flush=True)
        finally:
            e.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
