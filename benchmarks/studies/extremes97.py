"""Round 97 (issue 66 item 6, ``docs/fracture.md`` "Round 97: the extremes' neighbours"): the bodies of
``tests/test_brittle_extremes_family.py`` (a brittle box of 12 x 12 x 5 cm and a ball of R 5 cm, filled as a scene
fills them) thrown at the neighbours of that test's one direction, grid and strength:

- ``--direction``: ``down`` onto the ground (the test's), ``side`` into the +x wall (5 mm from its plane, 10 cm up),
  ``oblique`` at 45 degrees down and along +x onto the ground, 9 cm from the wall (it lands, then meets the wall);
- ``--grids``: n_grid over the test's 0.6 m box (the test's is 64);
- ``--strength old|defaults``: the test's weak brittle (f_t 1 kPa, G_f 10 J/m^2) or today's defaults (10 kPa, 50).

Per frame (1/30 s): the energy (kinetic, gravitational, the damaged Hencky energy) over the start's, the deepest
point under the ground and the farthest point past the walls' planes (``lo + 3 dx``, ``hi - 3 dx``,
``gasp_core.mpm.points.passive_bounds``: the test reads the domain's faces, three cells further out). The must-show:
no energy gained, no point under the ground or beyond a wall, the run ends.

``python benchmarks/studies/extremes97.py --engine warp_mpm --out benchmarks/results/extremes97_warp.json``
(refused if the file exists).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))

import roll_family88 as RF  # noqa: E402

SHAPES = ("box", "ball")
SPEEDS = (20.0, 50.0)
DIRECTIONS = ("down", "side", "oblique")
CONTACTS = ("auto", "grid")
GRIDS = (32, 48)
FRAMES = 3
STRENGTHS = {"old": {"tensile_strength": 1.0e3, "fracture_energy": 10.0},
             "defaults": {"tensile_strength": 1.0e4, "fracture_energy": 50.0}}


def setup(shape: str, speed: float, direction: str, n_grid: int, contact: str, strength: str = "old"):
    """The body (module notes) at ``speed`` m/s along ``direction``, on the test's box and boundaries at ``n_grid``."""
    import brittle_drop_family as fam
    from gasp_core.maps.fill import fill_interior
    from gasp_core.seam.setup import Boundary, Material
    from gasp_core.testing.helpers import make_setup
    dx = (fam.HI[0] - fam.LO[0]) / n_grid
    wall = fam.HI[0] - 3 * dx
    half = 0.06 if shape == "box" else 0.05
    cx = {"down": 0.0, "side": wall - 0.005 - half, "oblique": wall - 0.09 - half}[direction]
    cz = 0.10 if direction == "side" else 0.005 + (0.025 if shape == "box" else 0.05)
    splats = (fam.box_splats((cx - 0.06, -0.06, cz - 0.025), (cx + 0.06, 0.06, cz + 0.025)) if shape == "box"
              else fam.ball_splats((cx, 0.0, cz), 0.05))
    fr = fill_interior(splats.reshape(-1, 3), dx / 4 ** (1 / 3), splats=splats, surface_mass=False)
    u = {"down": (0.0, 0.0, -1.0), "side": (1.0, 0.0, 0.0), "oblique": (2 ** -0.5, 0.0, -2 ** -0.5)}[direction]
    return make_setup(fr.fill_x, fr.p_vol_fill, Material("brittle", **STRENGTHS[strength]),
                      v=tuple(speed * np.asarray(u)), lo=fam.LO, hi=fam.HI, n_grid=n_grid, frame_dt=1 / 30,
                      boundaries=[Boundary("ground", height=0.0, friction=0.5), Boundary("walls")],
                      options={"contact": contact})


def row(engine: str, shape: str, speed: float, direction: str, n_grid: int, contact: str, strength: str) -> dict:
    """One run of ``FRAMES`` frames (``test_brittle_extremes_family.record``): per frame the energy ratio, the depth
    under the ground and the distance past the walls' planes on x and y (m)."""
    from test_brittle_extremes_family import record, walls_box
    s = setup(shape, speed, direction, n_grid, contact, strength)
    lo, hi = walls_box(s)   # the ground is the floor (read as ``under``)
    t0 = time.time()
    out = {"engine": engine, "shape": shape, "speed": speed, "direction": direction, "n_grid": n_grid,
           "contact": contact, "strength": strength, **record(engine, s, FRAMES, lo, hi)}
    out["wall_s"] = time.time() - t0
    return out


#: A point on a plane, held there in float32, may read this far past it (cells; ``tests/test_passive.py``'s
#: ``HOLD_TOL``: the planes' float32 rounding is about 1e-6 dx).
HOLD_TOL = 1e-3


def verdict(r: dict) -> str:
    """What the run broke of the must-show, or "ok"."""
    bad = [r["error"]] if r["error"] or len(r["E"]) < FRAMES else []
    tol = HOLD_TOL * 0.6 / r["n_grid"]   # the box is 0.6 m wide
    if r["E"] and max(r["E"]) > 1.0:
        bad.append(f"energy {max(r['E']):.4f}")
    if r["under"] and max(r["under"]) > tol:
        bad.append(f"{1e3 * max(r['under']):.3f} mm under the ground")
    if r["past"] and max(r["past"]) > tol:
        bad.append(f"{1e3 * max(r['past']):.3f} mm past a wall")
    return "; ".join(str(b) for b in bad) or "ok"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--grids", default=",".join(map(str, GRIDS)))
    ap.add_argument("--directions", default=",".join(DIRECTIONS))
    ap.add_argument("--speeds", default=",".join(map(str, SPEEDS)))
    ap.add_argument("--contacts", default=",".join(CONTACTS))
    ap.add_argument("--shapes", default=",".join(SHAPES))
    ap.add_argument("--strength", default="old", choices=sorted(STRENGTHS))
    ap.add_argument("--out", default=None, help="a new JSON file for the rows (refused if it exists)")
    a = ap.parse_args(argv)
    out = RF.new_out(ap, a.out)
    rows = []
    for n_grid in map(int, a.grids.split(",")):
        for direction in a.directions.split(","):
            for contact in a.contacts.split(","):
                for shape in a.shapes.split(","):
                    for speed in map(float, a.speeds.split(",")):
                        r = row(a.engine, shape, speed, direction, n_grid, contact, a.strength)
                        r["verdict"] = verdict(r)
                        rows.append(r)
                        print(f"{a.engine} n_grid {n_grid} {direction} {contact} {shape} {speed:g} m/s: "
                              f"E max {max(r['E'], default=float('nan')):.4f}, under "
                              f"{1e3 * max(r['under'], default=float('nan')):+.3f} mm, past "
                              f"{1e3 * max(r['past'], default=float('nan')):+.3f} mm: {r['verdict']} "
                              f"({r['wall_s']:.1f} s)", flush=True)
    RF.write_rows(out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
