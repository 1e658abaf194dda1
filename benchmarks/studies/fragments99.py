"""Round 99: two more classes of damage tried on the pieces family's ball (issue 66 "Pieces": the pieces of 5 % or
more never decrease with speed; ``docs/fracture.md`` "Round 99"). Experiments, not the engines' code: warp_mpm only,
each with its patch applied (``git apply benchmarks/studies/crack99.patch`` or ``inside99.patch``; ``git apply -R``
to take it off).

- ``--probe crack`` (``crack99.patch``): a **rotating crack** (Rots 1988; Jirasek & Zimmermann 1998, "Rotating crack
  model with transition to scalar damage", J. Eng. Mech. 124, 277) in place of the isotropic tension damage: only
  the largest principal stress is softened, the crack's opening strain is taken out of the other two (their stress
  is the plane-stress response of the uncracked directions). ``--mode 1``: a point broken through turns to sand as
  today; ``--mode 2``: it turns to sand only when a second principal stress passes ``f_t`` (the transition to
  scalar damage).
- ``--probe inside`` (``inside99.patch``): **Grady's fragments as a sub-grid closure**. The stiff route's split
  (``gasp_core.run.fragments``: ``break_check`` at the landing speed, ``split_body`` Voronoi cells of Grady's size,
  not smaller than ``--min-cells`` cells) is laid on the soft ball before it lands; a point with a rest neighbour in
  another cell (``cut_damage``) keeps the crack band, every other point is a fragment's inside (``Jp`` -1: the
  patch's brittle return leaves it undamaged).
- ``--probe none``: today's model (no patch needed).

    python benchmarks/studies/fragments99.py --probe none --frames 30 --out benchmarks/results/fragments99_none.json
"""
from __future__ import annotations

import argparse
import json
import os

import numpy as np

import gasp_core.mpm.materials as materials
import gasp_core.testing.scenes_pieces as scenes
from gasp_core.run import fragments
from gasp_core.testing.scenes_pieces import SPEEDS, ball_setup, counted_run


def lay_cells(setup, speed: float, min_cells: float = 0.0, centre=(0.5, 0.5)):
    """Grady's cells on the body of ``setup`` landing at ``speed`` m/s, as the stiff route lays them
    (``gasp_core.run.fragments``: ``break_check``, ``split_body`` from the lowest point below ``centre`` (x, y), m):
    ``(cell, count, size)``, each point's cell (setup order, int), the count asked and the size (m; none under
    ``min_cells`` grid cells); ``(None, 0, size)`` where the landing does not break the body."""
    m = setup.materials[0]
    vol = float(setup.p_vol.sum())
    chk = fragments.break_check(m, float(setup.p_mass.sum()), vol, float(np.ptp(setup.x[:, 2])), speed)
    if not chk["breaks"]:
        return None, 0, chk["size"]
    size = max(chk["size"], min_cells * setup.dx)
    count = int(min(fragments.MAX_FRAGMENTS, max(2, round(vol / size ** 3))))
    spacing = float(np.cbrt(np.max(setup.p_vol)))
    cell = fragments.split_body(setup.x, np.ones(len(setup.x), bool), spacing,
                                np.array([*centre, setup.x[:, 2].min()]), count, size)
    return cell, count, size


def inside_jp(setup, speed: float, min_cells: float) -> tuple[np.ndarray | None, dict]:
    """The probe's initial ``Jp`` (setup order; None where the landing does not break the ball) and its split."""
    cell, count, _ = lay_cells(setup, speed, min_cells)
    if cell is None:
        return None, {"count": 0}
    every = np.ones(len(setup.x), bool)
    cut = fragments.cut_damage(setup.x, cell, every, float(np.cbrt(np.max(setup.p_vol))))
    return np.where(cut > 0, 0.0, -1.0), {"count": count, "cells": int(cell.max() + 1),
                                          "breakable": round(float(np.mean(cut > 0)), 3)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--probe", choices=("none", "crack", "inside"), default="none")
    ap.add_argument("--mode", type=float, default=2.0, help="crack: 1 (sand when broken) or 2 (sand at a 2nd crack)")
    ap.add_argument("--min-cells", type=float, default=0.0, help="inside: the smallest cell, in grid cells")
    ap.add_argument("--grids", default="28,32")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--out", required=True, help="a new JSON file (refused if it exists)")
    a = ap.parse_args()
    if os.path.exists(a.out):
        raise SystemExit(f"--out {a.out} exists; give a new file")
    if a.probe == "crack":
        if not hasattr(materials, "PROBE_CRACK_MODE"):
            raise SystemExit("crack99.patch is not applied: git apply benchmarks/studies/crack99.patch")
        materials.PROBE_CRACK_MODE = a.mode
    if a.probe == "inside":
        import gasp_warp_mpm.constitutive as c
        if "a fragment's inside" not in open(c.__file__).read():
            raise SystemExit("inside99.patch is not applied: git apply benchmarks/studies/inside99.patch")
    build = scenes.build_engine
    rows = []
    for g in (int(s) for s in a.grids.split(",")):
        five = []
        for v in SPEEDS:
            setup = ball_setup(v, g)
            jp, split = inside_jp(setup, v, a.min_cells) if a.probe == "inside" else (None, {})

            def built(entry, s, _jp=jp):
                e = build(entry, s)
                if _jp is not None:
                    e.write_array("Jp", _jp[e._order])
                return e
            scenes.build_engine = built
            r = counted_run("warp_mpm", setup, a.frames)
            scenes.build_engine = build
            rows.append({"probe": a.probe, "mode": a.mode if a.probe == "crack" else None, "n_grid": g, "speed": v,
                         "split": split, "pieces_5": r["tracker_5"], "pieces_1": r["tracker_1"],
                         "debris": r["debris"]})
            five.append((r["tracker_5"][12], r["tracker_5"][-1]))
        print(f"{a.probe} n_grid {g}: pieces of 5 % at frame 12 / {a.frames}: {five}", flush=True)
    with open(a.out, "x") as f:
        json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
