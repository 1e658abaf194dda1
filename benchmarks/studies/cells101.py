"""Round 101: Grady's cells parted by the cells themselves, not by the damage gradient (issue 66 "Pieces": the pieces
of 5 % or more never decrease with speed; ``docs/fracture.md`` "Round 101").

Round 100 (``dfg100.py``) found that Grady's cells parted by DFG meet the row on n_grid 48 but not on n_grid 28 and
32: there the cells are about 2 grid cells across, and the damage gradient, smoothed over the kernel's 3 cells, does
not find their faces (their speed relative to their centre died by frame 9 even with frictionless faces and no
separability threshold). Where the cells are laid, the crack's path is known: it is their faces. This study keeps
round 100's solver, ball, material, ground, walls and steps, and changes one thing, the side a point takes at a node:

- ``--side cells``: a node's reference cell is the cell of its point of largest weight (the point nearest the node);
  that cell's points are field 0 there, every other cell's field 1 (at a node where three cells meet, two of them
  share field 1: the same local two-sidedness as DFG's).
- ``--side damage``: round 100's DFG (the sign of the smoothed damage's gradient), for the side-by-side.

Which nodes may part (``--gate``): ``mean`` is DFG's (a point there fully broken and each field's mean damage over
``--d-min``), ``broken`` asks a fully broken point in each field, ``none`` lets every node with two fields part (the
cells then come apart at the touch, broken or not: the bound on what the fields can do).

    python benchmarks/studies/cells101.py --grids 28,32 --out benchmarks/results/cells101_28_32.json
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

from gasp_core.run import fragments
from gasp_core.testing.scenes_pieces import SPEEDS, ball_setup

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import dfg100  # noqa: E402 (round 100's study beside this one)
from fragments99 import lay_cells  # noqa: E402 (round 99's)


def cube_setup(speed: float, n_grid: int, side: float):
    """The ball family's scene with a cube of ``side`` m landing flat on a face at ``speed`` m/s: a neighbour shape for
    the cells (``gasp_core.testing.scenes_pieces.cube_setup`` since round 103)."""
    from gasp_core.testing.scenes_pieces import cube_setup as cube
    return cube(speed, n_grid, side)


def donut_setup(n_grid: int):
    """The brittle README donut thrown down at 4.43 m/s (a 1 m drop; ``benchmarks/brittle_readme_donut.py``'s scene at
    the schema's brittle defaults, ``n_grid``), its material points alone, moved so that the grid starts at the
    origin (the study's grid), its ground there too."""
    from types import SimpleNamespace
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    from brittle_readme_donut import brittle, donut_setup as scene
    s = scene("warp_mpm", n_grid, brittle("new"))
    m = s.p_mass > 0
    lo = np.asarray(s.domain_lo, np.float64)
    ground = SimpleNamespace(height=s.boundaries[0].height - lo[2], friction=s.boundaries[0].friction)
    return SimpleNamespace(materials=s.materials, x=s.x[m] - lo, v=s.v[m], p_mass=s.p_mass[m], p_vol=s.p_vol[m],
                           body_id=np.zeros(int(m.sum()), int), crack_band=s.crack_band, n_grid=s.n_grid, dx=s.dx,
                           gravity=s.gravity, frame_dt=s.frame_dt, boundaries=[ground])


def grady_cells(setup, speed: float) -> tuple[np.ndarray | None, dict]:
    """Each point's Grady cell (setup order, int; None where the landing does not break the ball) and the split, laid
    as round 99's and 100's probes lay them (``fragments99.lay_cells``), below the body's centre (the ball and the
    cube at the grid's middle, the donut at its own)."""
    centre = [0.5, 0.5] if len(setup.x) and abs(float(np.mean(setup.x[:, 0])) - 0.5) < 0.05 else \
        list(np.mean(setup.x[:, :2], axis=0))
    cell, count, size = lay_cells(setup, speed, centre=centre)
    if cell is None:
        return None, {"count": 0}
    return cell, {"count": count, "cells": int(cell.max() + 1), "size_dx": round(size / setup.dx, 2)}


class CellBall(dfg100.Ball):
    """Round 100's ball with the side taken from the points' cells (module notes)."""

    def __init__(self, setup, cell, side: str, gate: str, mu_c: float, d_min: float):
        never = None
        if cell is not None:
            cut = fragments.cut_damage(setup.x, cell, np.ones(len(setup.x), bool), float(np.cbrt(np.max(setup.p_vol))))
            never = cut == 0
        super().__init__(setup, True, mu_c, d_min, never)
        self.cell = np.zeros(len(self.x), int) if cell is None else cell
        self.side, self.gate = side, gate

    def colour_cells(self) -> np.ndarray:
        """``--side colour``: each cell's field (n_cells,) int from the engines' per-body colouring
        (``gasp_core.mpm.colouring.colour``) of the graph of cells within 3 cells (Chebyshev) of each other now,
        closest pairs first, oriented to keep the last frame's fields."""
        from scipy.spatial import cKDTree
        from gasp_core.mpm.colouring import colour
        nc = int(self.cell.max() + 1)
        trees = [cKDTree(self.x[self.cell == c]) for c in range(nc)]
        edges = []
        for i in range(nc):
            for j in range(i + 1, nc):
                d, _ = trees[j].query(self.x[self.cell == i], distance_upper_bound=3 * self.dx, p=np.inf)
                if np.isfinite(d).any():
                    edges.append((float(d.min()), i, j))
        vol = np.bincount(self.cell, self.vol, nc)
        vel = np.stack([np.bincount(self.cell, self.vol * self.v[:, k], nc) / vol for k in range(3)], 1)
        in_a, self.shared = colour(nc, [(i, j) for _, i, j in sorted(edges)], vol, vel, getattr(self, "in_a", None))
        self.in_a = in_a
        return in_a.astype(int)

    def step_frame(self) -> None:
        if self.side == "colour":
            self.cell_field = self.colour_cells()
        super().step_frame()

    def fields(self, node, W, gW):
        if self.side == "colour":
            if not hasattr(self, "cell_field"):
                self.cell_field = self.colour_cells()
            f = np.broadcast_to(self.cell_field[self.cell][:, None], node.shape)
            nn = self.n ** 3
            both = (np.bincount((node * 2 + f).ravel(), minlength=2 * nn).reshape(nn, 2) > 0).all(1)
        elif self.side == "damage":
            f, sep, both = super().fields(node, W, gW)
        else:
            nn = self.n ** 3
            ref = dfg100.node_max(node, W, nn)
            ref_cell = np.zeros(nn, int)
            has = ref >= 0
            ref_cell[has] = self.cell[ref[has] // 27]
            f = (self.cell[:, None] != ref_cell[node]).astype(int)
            key = (node * 2 + f).ravel()
            both = (np.bincount(key, minlength=2 * nn).reshape(nn, 2) > 0).all(1)
        if self.gate == "none":
            return f, both, both
        key = (node * 2 + f).ravel()
        nn = self.n ** 3
        d27 = np.repeat(self.d, 27)
        dmax = np.zeros(2 * nn)
        np.maximum.at(dmax, key, d27)
        dmax = dmax.reshape(nn, 2)
        if self.gate == "broken":
            return f, both & (dmax >= 1.0).all(1), both
        wm = (W * self.mass[:, None]).ravel()
        m_f = np.bincount(key, wm, 2 * nn).reshape(nn, 2)
        dmean = np.bincount(key, wm * d27, 2 * nn).reshape(nn, 2) / np.maximum(m_f, 1e-300)
        return f, both & (dmax.max(1) >= 1.0) & (dmean.min(1) > self.d_min), both


def counted(setup, cell, side: str, gate: str, frames: int, mu_c: float, d_min: float) -> dict:
    """Round 100's counts (``dfg100.counted``: the tracker's and the frames-only count with links kept open, pieces of
    5 % per frame) on a :class:`CellBall`, and ``tracker_cells_5``: the tracker with a split ball's band points (a
    rest neighbour in another cell) read as broken, so that a link across the cells' faces is cut once it opens past
    its gap, whatever its points' damage (one rule for the fields and the count)."""
    from gasp_core.run.pieces import LINK_RADIUS, tracker_for
    from gasp_core.testing.pieces_count import FramePieces, tracker_count
    ball = CellBall(setup, cell, side, gate, mu_c, d_min)
    t, t_cells = tracker_for(setup), tracker_for(setup)
    kept = FramePieces(setup.x, setup.p_mass, LINK_RADIUS * float(np.cbrt(np.max(setup.p_vol))), setup.dx,
                       remember=True)
    band = ~ball.never if cell is not None else np.zeros(len(ball.x), bool)
    total = float(setup.p_mass.sum())
    out = {"tracker_5": [], "tracker_cells_5": [], "frames_kept_5": [], "tracker_cells_1": [], "frames_kept_1": [],
           "broken": []}
    for i in range(frames + 1):
        if i:
            ball.step_frame()
        d = ball.d if i else None
        out["tracker_5"].append(tracker_count(t.row(ball.x, d)[0], total, 0.05))
        d_cells = None if d is None else np.where(band, 1.0, d)
        row = t_cells.row(ball.x, d_cells)[0]
        out["tracker_cells_5"].append(tracker_count(row, total, 0.05))
        out["tracker_cells_1"].append(tracker_count(row, total, 0.01))
        out["frames_kept_5"].append(kept.count(ball.x, 0.05))
        out["frames_kept_1"].append(kept.count(ball.x, 0.01))
        out["broken"].append(round(float(np.mean(ball.d >= 0.9)), 3))
    out["n_substeps"] = ball.n_sub
    return out


def trace(speed: float, n_grid: int, side: str, gate: str, mu_c: float, d_min: float, frames: int) -> list:
    """Per frame: the cells' mean distance from their common centre (m), their mean speed relative to it (m/s), the
    separable nodes, and the ball's lowest and highest points (m; the top wall holds the nodes from ``1 - 3 dx``)."""
    setup = ball_setup(speed, n_grid)
    cell, _ = grady_cells(setup, speed)
    ball = CellBall(setup, cell, side, gate, mu_c, d_min)
    rows = []
    for fr in range(1, frames + 1):
        ball.step_frame()
        rows.append(dfg100.motion_row(ball, ball.cell, fr))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--side", default="cells", help="cells or damage (round 100's DFG), or both: cells,damage")
    ap.add_argument("--gate", default="mean", choices=("mean", "broken", "none"))
    ap.add_argument("--grids", default="28,32")
    ap.add_argument("--speeds", default=",".join(str(s) for s in SPEEDS))
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--mu", type=float, default=0.5, help="the crack faces' Coulomb coefficient")
    ap.add_argument("--d-min", type=float, default=0.25, help="--gate mean: each field's mean damage to part")
    ap.add_argument("--radius", type=float, default=0.1, help="the ball's radius, m (the family's is 0.1)")
    ap.add_argument("--cube", type=float, default=0.0, help="over 0: a cube of this side, m, instead of the ball")
    ap.add_argument("--donut", action="store_true", help="the brittle README donut at 4.43 m/s (donut_setup)")
    ap.add_argument("--one", action="store_true", help="one velocity field (the engines' class), no cells")
    ap.add_argument("--trace", action="store_true", help="the cells' motion (trace) at the first speed and grid")
    ap.add_argument("--out", required=True, help="a new JSON file (refused if it exists)")
    a = ap.parse_args()
    if os.path.exists(a.out):
        raise SystemExit(f"--out {a.out} exists; give a new file")
    if a.trace:
        rows = trace(float(a.speeds.split(",")[0]), int(a.grids.split(",")[0]), a.side, a.gate, a.mu, a.d_min,
                     a.frames)
        for r in rows:
            print(r)
        with open(a.out, "x") as f:
            json.dump(rows, f, indent=1)
        return
    rows = []
    for side in a.side.split(","):
        for g in (int(s) for s in a.grids.split(",")):
            for v in (float(s) for s in a.speeds.split(",")):
                t0 = time.perf_counter()
                setup = cube_setup(v, g, a.cube) if a.cube > 0 else ball_setup(v, g, a.radius)
                if a.donut:
                    setup, v = donut_setup(g), 4.43
                cell, split = (None, {}) if a.one else grady_cells(setup, v)
                r = counted(setup, cell, side, a.gate, a.frames, a.mu, a.d_min)
                rows.append({"side": side, "gate": a.gate, "radius": a.radius, "cube": a.cube, "donut": a.donut, "one": a.one, "n_grid": g, "speed": v, "mu": a.mu, "d_min": a.d_min,
                             "split": split, "seconds": round(time.perf_counter() - t0, 1), **r})
                print(f"{side}/{a.gate} n_grid {g} v {v}: split {split}; tracker 5 % at 12 / {a.frames}: "
                      f"{r['tracker_5'][min(12, a.frames)]} / {r['tracker_5'][-1]}, with the cells' rule {r['tracker_cells_5'][-1]}, "
                      f"kept frames {r['frames_kept_5'][-1]} (1 %: {r['frames_kept_1'][-1]}), "
                      f"broken {r['broken'][-1]}, {rows[-1]['seconds']} s", flush=True)
    with open(a.out, "x") as f:
        json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
