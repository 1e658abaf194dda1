"""The pieces family's ball laid out in Grady's cells as a run lays it, on the MLS-MPM engines (issue 66, "Pieces": the
pieces of 5 % or more never decrease with speed; ``docs/fracture.md`` "Round 102: Grady's cells in the engines").

For each engine, ``n_grid`` and landing speed (1, 2, 4, 7, 10 m/s): ``gasp_core.run.grady_cells.laid`` (the landing
probed on the engine, as a run does; ``--no-probe``: Grady's cells alone) on
``gasp_core.testing.scenes_pieces.shape_setup``, then ``counted_run`` over ``--frames`` frames: per frame the run's
pieces (``tracker``, ``tracker_1``, ``tracker_5``), the frames-only counts (``frames_1``, ``frames_kept_1``), the
crumbs, the split's record and the wall time.

    python benchmarks/cells_family.py --out benchmarks/results/cells102_family.json [--engines taichi_mpm,warp_mpm]
        [--grids 28,32,48] [--frames 30] [--shape ball|ball:R|cube:A]

Refuses an ``--out`` that exists. About 10 s a run at n_grid 28-32 and 20-40 s at 48 (2 cores).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings

from gasp_core.run.grady_cells import laid
from gasp_core.seam.plugins import engines
from gasp_core.testing.scenes_pieces import SPEEDS, counted_run, shape_setup

KEYS = ("tracker", "tracker_1", "tracker_5", "frames_1", "frames_kept_1", "debris")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", default="taichi_mpm,warp_mpm")
    ap.add_argument("--grids", default="28,32,48")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--no-probe", action="store_true", help="Grady's cells alone (round 102's), no probe")
    ap.add_argument("--shape", default="ball", help="ball (R 0.1 m), ball:R or cube:A (m): round 101's neighbours")
    ap.add_argument("--out", required=True, help="a new JSON file (refused if it exists)")
    a = ap.parse_args(argv)
    if os.path.exists(a.out):
        raise SystemExit(f"--out {a.out} exists; give a new file")
    rows = []
    for name in a.engines.split(","):
        for g in (int(s) for s in a.grids.split(",")):
            for v in SPEEDS:
                t0 = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")   # cells laid larger than Grady's on a coarse grid: in the record
                    s, split = laid(shape_setup(a.shape, v, g), info=None if a.no_probe else engines()[name])
                r = counted_run(name, s, a.frames)
                rows.append({"engine": name, "shape": a.shape, "n_grid": g, "speed": v, "split": split,
                             **{k: r[k] for k in KEYS}, "wall_s": round(time.perf_counter() - t0, 1)})
                print(name, g, v, "pieces of 5 % at frame 12 and last:", r["tracker_5"][min(12, a.frames)],
                      r["tracker_5"][-1], flush=True)
    with open(a.out, "x") as f:
        json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
