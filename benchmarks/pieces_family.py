"""The pieces of a brittle ball landing at 1, 2, 4, 7 and 10 m/s (issue 66, item 4 "Pieces as a user counts them"),
at n_grid 28 and 32, counted two ways on every frame: by the run's tracker (:class:`gasp_core.run.pieces.PieceTracker`:
the geometry and the damage together, cut links kept, crumbs under 0.1 % of the mass apart) and from the frames alone
(:class:`gasp_core.testing.pieces_count.FramePieces`: rest neighbours within their rest distance plus 1 dx, parts of
1 % of the mass or more, no damage read). The ball: :func:`gasp_core.testing.scenes_pieces.ball_setup` (radius 0.1 m,
E 200 kPa, f_t 10 kPa, G_f 15 J/m^2, frames of 0.01 s), 20 frames.

Per engine, grid and speed: the per-frame counts (``pieces``, ``debris``, ``pieces_1pct``, ``frames_1pct``,
``pieces_5pct``), the largest |tracker - frames| over the test's window (frames 0-12, ``tests/test_pieces_family.py``)
and over all 20 frames, and whether the count (crumbs apart) ever decreased. Round 77: also ``frames_kept_1pct``
(the frames-only count whose links, once opened, stay open: ``FramePieces(remember=True)``), its largest difference
``max_diff_kept``, and per frame ``rejoined`` (the share of the tracker's cut links that hold again in the frames-only
reference: the fragments meeting again).

``--scene FILE --frames N``: a scene file run through ``gasp simulate``'s pipeline instead (the README donut made
brittle: ``examples/donut_shatter.toml``), the same two counts on each frame (the tracker's positions read as the run
hands them over), added to the file's ``scenes``.

Run: ``python benchmarks/pieces_family.py --engine warp_mpm`` (and ``--engine taichi_mpm``), one engine per process;
each engine's rows are added to ``benchmarks/results/pieces_family.json`` (replacing that engine's rows on the same
grids). ``--grids 40,48,56,64``: finer grids than the test's (round 77: the counts part at 10 m/s from n_grid 48).
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from gasp_core.run import pieces
from gasp_core.testing.pieces_count import FramePieces, tracker_count
from gasp_core.testing.scenes_pieces import SPEEDS, ball_setup, counted_run

OUT = Path(__file__).resolve().parent / "results" / "pieces_family.json"
GRIDS = (28, 32)
N_FRAMES = 20
WINDOW = 12     # tests/test_pieces_family.py's frames


def case(engine: str, n_grid: int, speed: float) -> dict:
    t0 = time.perf_counter()
    r = counted_run(engine, ball_setup(speed, n_grid), N_FRAMES)
    diff = [abs(a - b) for a, b in zip(r["tracker_1"], r["frames_1"])]
    kept = [abs(a - b) for a, b in zip(r["tracker_1"], r["frames_kept_1"])]
    seq = r["tracker"]
    return {"engine": engine, "n_grid": n_grid, "speed": speed, "pieces": seq, "debris": r["debris"],
            "pieces_1pct": r["tracker_1"], "frames_1pct": r["frames_1"], "frames_kept_1pct": r["frames_kept_1"],
            "pieces_5pct": r["tracker_5"], "rejoined": [round(x, 4) for x in r["rejoined"]],
            "max_diff_window": max(diff[:WINDOW + 1]), "max_diff_all": max(diff), "max_diff_kept": max(kept),
            "decreased": any(b < a for a, b in zip(seq, seq[1:])), "wall_s": round(time.perf_counter() - t0, 2)}


def scene_case(path: Path, engine: str, n_frames: int) -> dict:
    """A scene file through the pipeline: per frame the tracker's pieces, crumbs, pieces of 1 % and 5 %, and the
    frames-only count of 1 % (its points' positions as the run hands them to the tracker)."""
    import tempfile
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    rows, ref = [], {}
    row_of, tracker_of = pieces.frame_row, pieces.tracker_for

    def tracker_for(setup):
        t = tracker_of(setup)
        m = t.mass > 0
        spacing = float(np.cbrt(np.percentile(np.asarray(setup.p_vol)[m], pieces.SPACING_PERCENTILE)))
        ref.update(m=m, count=FramePieces(setup.x[m], t.mass[m], pieces.LINK_RADIUS * spacing, setup.dx))
        return t

    def frame_row(tracker, reporter, frame, x, damage):
        row = row_of(tracker, reporter, frame, x, damage)
        total = float(tracker.mass.sum())
        rows.append([row["pieces"], row["debris"], tracker_count(row, total), tracker_count(row, total, 0.05),
                     ref["count"].count(np.asarray(x)[ref["m"]])])
        return row

    pieces.frame_row, pieces.tracker_for = frame_row, tracker_for
    t0 = time.perf_counter()
    try:
        with tempfile.TemporaryDirectory() as tmp:
            simulate_scene(load_scene(path), Path(tmp) / "out", quiet=True, n_frames=n_frames, engine=engine)
    finally:
        pieces.frame_row, pieces.tracker_for = row_of, tracker_of
    cols = list(zip(*rows))
    return {"scene": path.name, "engine": engine, "pieces": cols[0], "debris": cols[1], "pieces_1pct": cols[2],
            "pieces_5pct": cols[3], "frames_1pct": cols[4],
            "max_diff": max(abs(a - b) for a, b in zip(cols[2], cols[4])),
            "decreased": any(b < a for a, b in zip(cols[0], cols[0][1:])), "wall_s": round(time.perf_counter() - t0, 1)}


def save(key: str, rows: list[dict], same) -> None:
    """Add ``rows`` to the results' ``key`` list, replacing the rows ``same(old_row)`` says they stand for."""
    old = json.loads(OUT.read_text()) if OUT.is_file() else {}
    old.update(n_frames=N_FRAMES, window=WINDOW)
    old[key] = [c for c in old.get(key, []) if not same(c)] + rows
    OUT.parent.mkdir(exist_ok=True)
    lines = [f'"{k}": ' + (json.dumps(v) if not isinstance(v, list) else
                          "[\n  " + ",\n  ".join(json.dumps(c) for c in v) + "\n ]") for k, v in old.items()]
    OUT.write_text("{\n " + ",\n ".join(lines) + "\n}\n")      # one case a line


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="warp_mpm", choices=("warp_mpm", "taichi_mpm"))
    ap.add_argument("--scene", type=Path, help="a scene file through the pipeline instead of the ball family")
    ap.add_argument("--frames", type=int, default=10, help="the scene's frames (--scene)")
    ap.add_argument("--grids", default=",".join(map(str, GRIDS)),
                    help="n_grid values, comma-separated (default the test's 28,32; round 77 ran 40,48,56,64)")
    args = ap.parse_args()
    if args.scene is not None:
        c = scene_case(args.scene, args.engine, args.frames)
        save("scenes", [c], lambda o: o["scene"] == c["scene"] and o["engine"] == c["engine"])
        print(json.dumps(c))
        return
    grids = [int(g) for g in args.grids.split(",")]
    rows = [case(args.engine, g, v) for g in grids for v in SPEEDS]
    save("cases", rows, lambda o: o["engine"] == args.engine and o["n_grid"] in grids)
    for c in rows:
        print(f"{c['engine']:10s} n_grid {c['n_grid']} {c['speed']:4.1f} m/s: pieces at frame {WINDOW} "
              f"{c['pieces'][WINDOW]} (5 %: {c['pieces_5pct'][WINDOW]}, peak {max(c['pieces_5pct'])}), at frame "
              f"{N_FRAMES} {c['pieces'][-1]} + {c['debris'][-1]} crumbs; |tracker - frames| <= {c['max_diff_window']} "
              f"to frame {WINDOW}, {c['max_diff_all']} to {N_FRAMES} (links kept open: {c['max_diff_kept']}); "
              f"decreased: {c['decreased']}")


if __name__ == "__main__":
    main()
