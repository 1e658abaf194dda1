"""Round 89 (issue 67 item 2 on a ``[[collider]]``, ``docs/rigid.md`` "Round 89: a ball rests on its sphere on a
mesh"): ``roll_family88.py``'s family of rigid balls and solid cylinders (radii, grids, the ways their Gaussians sample
them), set on ``tests/test_ramp_collider.py``'s 20 degree mesh ramp (a closed box of 12 triangles, trimesh's exact
signed distance, gravity straight down) instead of the tilted ground, each judged by ``test_rolling``'s two-sided check
(5 %) against the closed forms of the body's own inertia.

The grids are the ramp's box (0.8 m) at n_grid 32, 48 and 64: the cells of ``roll_family88``'s 24, 36 and 48.
``python benchmarks/studies/roll_collider89.py --engine warp_mpm --out benchmarks/results/roll_collider89_warp.json``
(refused if the file exists); ``--round-collider 0`` runs round 88's contact on the points (the broken variant).
"""
from __future__ import annotations

import argparse
import dataclasses
import itertools
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import roll_family88 as RF  # noqa: E402
import test_rolling as rl  # noqa: E402

#: The family: every radius and grid on the test's sampling, and every sampling on two of them (the ramp's n_grid).
RADII, GRIDS = (0.05, 0.1), (32, 48, 64)
SAMPLED_AT = ((0.05, 64), (0.1, 32))


def family() -> list[tuple[float, int, str]]:
    """``(radius m, n_grid, sampling)`` of the family (for each shape)."""
    out = [(r, n, "fibonacci") for r in RADII for n in GRIDS]
    return out + [(r, n, s) for r, n in SAMPLED_AT for s in RF.SAMPLINGS if s != "fibonacci"]


def row(engine: str, shape: str, radius: float, n_grid: int, sampling: str, mu: float, seed: int = 0) -> dict:
    """One case on ``engine``: the body of ``shape`` (``roll_family88.body``, its axis across the slope) set on the
    ramp of friction ``mu``, its figures, the closed form of its own inertia and the verdict (``roll_family88.problem``);
    ``seed`` the ``scan`` sampling's draw (round 99)."""
    import test_ramp_collider as rc
    from gasp_core.seam.setup import Material
    from gasp_core.testing.helpers import make_setup
    n, s = rc.ramp_frame(rl.THETA)
    x, vol, n_render = RF.body(shape, radius, n_grid * 24 // 32, sampling, seed)
    k = RF.inertia_share(x, vol, radius)
    x = x - (vol[:, None] * x).sum(0) / vol.sum()
    x = rc.START + 0.15 * s + radius * n + x[:, :1] * s + x[:, 1:2] * np.array([0.0, 1.0, 0.0]) + x[:, 2:] * n
    st = make_setup(x, vol, Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0), lo=np.zeros(3),
                    hi=np.full(3, 0.8), n_grid=n_grid, frame_dt=1.0 / rc.FPS)
    st.n_render = n_render
    st.colliders = [dataclasses.replace(rc.ramp_collider(rl.THETA), friction=mu)]
    t0 = time.time()
    c, v, w = rl.trace(engine, st)
    t = np.arange(len(c)) / rc.FPS
    sel = t >= rl.FIT_FROM
    fig = {"a": 2.0 * float(np.polyfit(t[sel], (c[sel] - c[0]) @ s, 2)[0]), "wR": float(w[-1, 1]) * radius,
           "v": float(v[-1] @ s)}
    return RF.record(engine, shape, radius, n_grid, sampling, n_render, mu, k, fig, time.time() - t0)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--shapes", default="ball,cylinder", help="ball, cylinder or both (comma-separated)")
    ap.add_argument("--round-collider", type=int, default=1, help="gasp_core.mpm.round_ground.ROUND_COLLIDER")
    ap.add_argument("--seeds", default=None, help="round 99: the scan sampling's draws (comma-separated); with it only "
                    "the family's scan rows run, once a seed")
    ap.add_argument("--out", default=None, help="a new JSON file for the rows (refused if it exists)")
    a = ap.parse_args(argv)
    out = RF.new_out(ap, a.out)
    import gasp_core.mpm.round_ground as rg
    rg.ROUND_COLLIDER = a.round_collider
    rows = []
    for shape in a.shapes.split(","):
        for radius, n_grid, sampling in family():
            if a.seeds and sampling != "scan":
                continue
            for seed, mu in itertools.product([int(k) for k in a.seeds.split(",")] if a.seeds else [0], RF.MUS):
                rows.append({**row(a.engine, shape, radius, n_grid, sampling, mu, seed), "seed": seed})
                print(RF.report(rows[-1]) + (f" (seed {seed})" if a.seeds else ""), flush=True)
    RF.write_rows(out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
