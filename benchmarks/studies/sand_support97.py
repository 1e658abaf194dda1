"""Round 97 (issue 67 items 4-5, ``docs/contact.md`` "Round 97: sand on a thin support"): round
96's family of thin supports with a sand block on top, the neighbour that round 96's face rule does not act on (a
flowing body keeps its touch, ``FLOW_TOUCH``).

The scene is ``tests/test_thin_support.py``'s (``gasp_core.testing.sand_ball.slide_setup``: a 6 x 6 x 3 cm sand block,
30 degrees, on a jelly slab of E 2e5 Pa lying on a ground of friction 0.5), over the slab's thickness in quarter cells
(1 to 3 cells: its face 0, 1/4, 1/2 and 3/4 of a cell above a node layer; that test's slabs are whole cells) and
n_grid 32 and 48. A body of sand takes the grid contact, so the engines lay the grid with the ground on a node layer
(``gasp_core.mpm.grid_origin``): round 96's shifted grid is the slab's thickness here. Two figures a case:

- ``ratio_err``: round 38's Coulomb ratio (``sand_ball.coulomb_ratio``, the block's horizontal momentum lost over the
  normal impulse, from the throw to frame 3) over the pair's ``mu``, less 1, at 1.2 and 1.6 m/s (the test's
  ``RATIO_TOL`` is 2.5 %);
- ``depth_dx``: the block thrown at 0, after 0.5 s: the lowest sand point below the slab's face (its top points'
  mean height plus half the fill's spacing), in cells (issue 67 item 5: sand stays outside what it meets within a
  quarter cell; positive is inside; a block resting on the face reads -0.25, its own points' half spacing).

``python benchmarks/studies/sand_support97.py --engine warp_mpm --out benchmarks/results/sand_support97_warp.json``
(refused if the file exists).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import roll_family88 as RF  # noqa: E402

GRIDS = (32, 48)
SUPPORTS = (1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5, 3.0)
REST_FRAMES = 15


def setup(v0: float, n_grid: int, support: float):
    """``sand_ball.slide_setup`` at ``n_grid`` with the slab ``support`` cells thick."""
    from gasp_core.testing import sand_ball as S
    old = S.N_GRID
    S.N_GRID = n_grid
    try:
        s = S.slide_setup(v0, {"threads": 1}, slab_h=support * S.SIDE / n_grid)
    finally:
        S.N_GRID = old
    s.n_render = 0
    return s


def row(engine: str, n_grid: int, support: float) -> dict:
    """One case: the Coulomb ratio's error at each of ``RATIO_SPEEDS`` and the resting block's depth."""
    from gasp_core.mpm.fields import field_friction
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing import sand_ball as S
    from gasp_core.testing.kit import run_trace
    from gasp_core.testing.scenes_flow_pairs import RATIO_FRAMES, RATIO_SPEEDS
    t0 = time.time()
    out = {"engine": engine, "n_grid": n_grid, "support_cells": support}
    for v0 in RATIO_SPEEDS:
        s = setup(v0, n_grid, support)
        tr = run_trace(get_engine(engine), s, RATIO_FRAMES)
        out[f"ratio_err_{v0}"] = S.coulomb_ratio(tr.v, s, 0, RATIO_FRAMES) / field_friction(s) - 1.0
    s = setup(0.0, n_grid, support)
    tr = run_trace(get_engine(engine), s, REST_FRAMES)
    dx = S.SIDE / n_grid
    body = np.asarray(s.body_id)
    x0, x1 = np.asarray(tr.x[0]), np.asarray(tr.x[-1])
    top = (body == 1) & (x0[:, 2] > x0[body == 1, 2].max() - 1e-9)
    under = top & (np.abs(x0[:, 0]) < 0.05) & (np.abs(x0[:, 1]) < 0.05)
    face = x1[under, 2].mean() + dx / 4   # the fill is cell-centred at dx / 2: its top points half a spacing below
    out["depth_dx"] = float((face - x1[body == 0, 2].min()) / dx)
    out["wall_s"] = time.time() - t0
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--grids", default=",".join(map(str, GRIDS)))
    ap.add_argument("--out", default=None, help="a new JSON file for the rows (refused if it exists)")
    a = ap.parse_args(argv)
    out = RF.new_out(ap, a.out)
    rows = []
    for n_grid in map(int, a.grids.split(",")):
        for support in SUPPORTS:
            r = row(a.engine, n_grid, support)
            rows.append(r)
            errs = ", ".join(f"{100 * v:+.2f} %" for k, v in r.items() if k.startswith("ratio_err"))
            print(f"{a.engine} n_grid {n_grid} support {support} cells: Coulomb ratio {errs}; "
                  f"at rest {r['depth_dx']:+.3f} dx inside ({r['wall_s']:.1f} s)", flush=True)
    RF.write_rows(out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
