"""The pieces of a brittle ball landing at 1, 2, 4, 7 and 10 m/s (issue 66, item 4 "Pieces as a user counts them"),
at n_grid 28 and 32, counted two ways on every frame: by the run's tracker (:class:`gasp_core.run.pieces.PieceTracker`:
the geometry and the damage together, cut links kept, crumbs under 0.1 % of the mass apart) and from the frames alone
(:class:`gasp_core.testing.pieces_count.FramePieces`: rest neighbours within their rest distance plus 1 dx, parts of
1 % of the mass or more, no damage read). The ball: :func:`gasp_core.testing.scenes_pieces.ball_setup` (radius 0.1 m,
E 200 kPa, f_t 10 kPa, G_f 15 J/m^2, frames of 0.01 s), 20 frames.

Per engine, grid and speed: the per-frame counts (``pieces``, ``debris``, ``pieces_1pct``, ``frames_1pct``,
``pieces_5pct``), the largest |tracker - frames| over the test's window (frames 0-12, ``tests/test_pieces_family.py``)
and over all 20 frames, and whether the count (crumbs apart) ever decreased.

Run: ``python benchmarks/pieces_family.py --engine warp_mpm`` (and ``--engine taichi_mpm``), one engine per process;
each engine's rows are added to ``benchmarks/results/pieces_family.json``.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from gasp_core.testing.scenes_pieces import SPEEDS, ball_setup, counted_run

OUT = Path(__file__).resolve().parent / "results" / "pieces_family.json"
GRIDS = (28, 32)
N_FRAMES = 20
WINDOW = 12     # tests/test_pieces_family.py's frames


def case(engine: str, n_grid: int, speed: float) -> dict:
    t0 = time.perf_counter()
    r = counted_run(engine, ball_setup(speed, n_grid), N_FRAMES)
    diff = [abs(a - b) for a, b in zip(r["tracker_1"], r["frames_1"])]
    seq = r["tracker"]
    return {"engine": engine, "n_grid": n_grid, "speed": speed, "pieces": seq, "debris": r["debris"],
            "pieces_1pct": r["tracker_1"], "frames_1pct": r["frames_1"], "pieces_5pct": r["tracker_5"],
            "max_diff_window": max(diff[:WINDOW + 1]), "max_diff_all": max(diff),
            "decreased": any(b < a for a, b in zip(seq, seq[1:])), "wall_s": round(time.perf_counter() - t0, 2)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="warp_mpm", choices=("warp_mpm", "taichi_mpm"))
    args = ap.parse_args()
    rows = [case(args.engine, g, v) for g in GRIDS for v in SPEEDS]
    old = json.loads(OUT.read_text()) if OUT.is_file() else {"cases": []}
    kept = [c for c in old["cases"] if c["engine"] != args.engine]
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(json.dumps({"n_frames": N_FRAMES, "window": WINDOW, "cases": kept + rows}, indent=1) + "\n")
    for c in rows:
        print(f"{c['engine']:10s} n_grid {c['n_grid']} {c['speed']:4.1f} m/s: pieces at frame {WINDOW} "
              f"{c['pieces'][WINDOW]} (5 %: {c['pieces_5pct'][WINDOW]}, peak {max(c['pieces_5pct'])}), at frame "
              f"{N_FRAMES} {c['pieces'][-1]} + {c['debris'][-1]} crumbs; |tracker - frames| <= {c['max_diff_window']} "
              f"to frame {WINDOW}, {c['max_diff_all']} to {N_FRAMES}; decreased: {c['decreased']}")


if __name__ == "__main__":
    main()
