"""Round 103: the cost of Grady's cells on warp_mpm, their node passes over the grid update's box against the whole
grid (``gasp_warp_mpm.cells.CELL_BOX``; ``docs/performance.md`` "Round 103: Grady's cells over the touched box").

For each ``n_grid``: the pieces family's ball (``gasp_core.testing.scenes_pieces.ball_setup``) landing at 7 m/s, laid
out in cells as a run lays it (``gasp_core.run.grady_cells.laid``), run ``--frames`` frames on warp_mpm with the cells'
passes over the box and over the whole grid, and the same ball with no cells (the cost the cells add), in turn,
``--pairs`` times, in one process (each setting's kernels compiled by a first run that is not timed). Writes the wall
times (s, the frames only), their medians and the ratios box / whole and box / no cells to ``--out`` (JSON) and a
table beside it (``.md``).

    python benchmarks/cell_box.py --out benchmarks/results/cell_box103.json [--grids 32,48,64] [--frames 30]
        [--pairs 3]

Refuses an ``--out`` that exists. About 5 min at the defaults (2 cores).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
import warnings

MODES = ("box", "whole", "no_cells")


def timed(n_grid: int, mode: str, frames: int) -> float:
    """Wall seconds of ``frames`` frames of the ball at 7 m/s on warp_mpm in ``mode`` (:data:`MODES`)."""
    from gasp_core.run.grady_cells import laid
    from gasp_core.seam import build_engine, get_engine
    from gasp_core.testing.scenes_pieces import ball_setup
    from gasp_warp_mpm import cells
    cells.CELL_BOX = mode != "whole"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s = ball_setup(7.0, n_grid) if mode == "no_cells" else laid(ball_setup(7.0, n_grid))[0]
    eng = build_engine(get_engine("warp_mpm"), s)
    try:
        t0 = time.perf_counter()
        for _ in range(frames):
            eng.step_frame()
        return time.perf_counter() - t0
    finally:
        eng.close()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grids", default="32,48,64")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--pairs", type=int, default=3)
    ap.add_argument("--out", required=True, help="a new JSON file (refused if it exists)")
    a = ap.parse_args(argv)
    if os.path.exists(a.out):
        raise SystemExit(f"--out {a.out} exists; give a new file")
    rows = []
    for g in (int(s) for s in a.grids.split(",")):
        for m in MODES:
            timed(g, m, 1)   # compile
        walls = {m: [] for m in MODES}
        for _ in range(a.pairs):
            for m in MODES:
                walls[m].append(round(timed(g, m, a.frames), 3))
        med = {m: statistics.median(w) for m, w in walls.items()}
        rows.append({"n_grid": g, "frames": a.frames, "walls": walls, "median": med,
                     "box_over_whole": round(med["box"] / med["whole"], 3),
                     "box_over_no_cells": round(med["box"] / med["no_cells"], 3),
                     "whole_over_no_cells": round(med["whole"] / med["no_cells"], 3)})
        print(rows[-1], flush=True)
    with open(a.out, "x") as f:
        json.dump({"load": os.getloadavg(), "rows": rows}, f, indent=1)
    md = ["| n_grid | box s | whole grid s | no cells s | box / whole | box / no cells | whole / no cells |",
          "|---|---|---|---|---|---|---|"]
    md += [f"| {r['n_grid']} | {r['median']['box']:.2f} | {r['median']['whole']:.2f} | {r['median']['no_cells']:.2f} "
           f"| {r['box_over_whole']} | {r['box_over_no_cells']} | {r['whole_over_no_cells']} |" for r in rows]
    with open(os.path.splitext(a.out)[0] + ".md", "x") as f:
        f.write(f"warp_mpm, the ball at 7 m/s, {a.frames} frames, medians of {a.pairs} (`benchmarks/cell_box.py`)\n\n"
                + "\n".join(md) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
