"""Round 90 (issue 67 item 2 on a moving ``[[collider]]``, ``docs/rigid.md`` "Round 90: a round body on a moving
belt"): a rigid ball or solid cylinder at rest on a flat mesh plate that moves at a constant ``U`` from ``t = 0``
(a belt started at once). Friction drags the body along and spins it up until its bottom moves with the belt; then it
rolls at a constant speed.

The closed form (Coulomb, ``k = I / (M R^2)`` of the body's own points, ``roll_family88.inertia_share``): while it slips
the centre accelerates at ``mu g`` along the belt and the spin grows at ``mu g / (k R)``; the slip ends at
``t* = k U / ((1 + k) mu g)``; after it the centre moves at ``v = k U / (1 + k)`` (2/7 U for a solid sphere, U/3 for a
solid cylinder: the angular momentum about the contact line is kept) and ``omega R = U - v``.

The case: a plate 1.0 x 0.5 x 0.1 m (12 triangles, trimesh's exact signed distance), its top 0.15 m over the floor of
a 0.6 m box, moving at ``U`` 0.3 m/s along x with ``[[collider]] velocity``; the body of ``roll_family88.body`` on it,
gravity straight down. Figures: the slipping acceleration (a parabola fitted to the centre's travel over the frames
within ``0.8 t*``, only where that holds ``MIN_FIT_FRAMES`` frames: mu 0.05), ``v`` and ``omega R`` at ``T`` s,
each against the closed form within ``test_rolling.TOL`` (5 %, two-sided).
``python benchmarks/studies/roll_belt90.py --engine warp_mpm --out benchmarks/results/roll_belt90_warp.json``
(refused if the file exists); ``--round-collider 0`` runs round 88's contact on the points (the broken variant).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import roll_family88 as RF  # noqa: E402
import test_rolling as rl  # noqa: E402

#: The belt's speed (m/s, along +x), the box (m), frames a second, the run (s).
U, BOX, FPS, T = 0.3, 0.6, 60, 0.5
#: The plate's half sides (m) and its centre at ``t = 0`` (m): the top face at z = 0.15.
PLATE_HALF = (0.5, 0.25, 0.05)
PLATE_C = np.array([0.3, 0.3, 0.1])
#: Where the body's lowest point starts (m): on the plate's top, 0.2 m from the box's -x wall.
START = np.array([0.2, 0.3, 0.15])
#: The fewest frames the slipping fit takes.
MIN_FIT_FRAMES = 6
RADII, GRIDS, MUS = (0.05, 0.1), (32, 48), (0.05, 0.5)
_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)
_FACES = np.array([(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6),
                   (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)])


def belt_collider(mu: float, n_grid: int, speed: float = U):
    """The plate as a moving collider (``Motion(velocity=(speed, 0, 0))``), friction ``mu``, sampled at
    ``SDF_SPACING`` of the cell."""
    from gasp_core.colliders.model import Motion
    from gasp_core.colliders.sdf import SDF_SPACING, collider_from_triangles
    tri = (PLATE_C + _CORNERS * np.asarray(PLATE_HALF))[_FACES]
    return collider_from_triangles(tri, SDF_SPACING * BOX / n_grid, name="belt", friction=mu,
                                   motion=Motion(velocity=(speed, 0.0, 0.0)))


def closed_form(k: float, mu: float, speed: float = U) -> dict:
    """``t_star`` (s), the slipping ``a`` (m/s^2) and, at ``T``, ``v`` and ``wR`` (m/s) of a body of ``k``."""
    return {"t_star": k * speed / ((1.0 + k) * mu * rl.G), "a": mu * rl.G, "v": k * speed / (1.0 + k),
            "wR": speed / (1.0 + k)}


def figures(c: np.ndarray, v: np.ndarray, w: np.ndarray, radius: float, t_star: float) -> dict:
    """From :func:`test_rolling.trace`'s per-frame centre, velocity and spin: ``a`` (None where the slip is shorter
    than ``MIN_FIT_FRAMES`` frames), ``v`` along the belt and ``wR`` (``-omega_y R``: positive for the belt's roll)
    at the last frame."""
    t = np.arange(len(c)) / FPS
    sel = (t > 0.0) & (t <= 0.8 * t_star)
    a = 2.0 * float(np.polyfit(t[sel], c[sel, 0] - c[0, 0], 2)[0]) if sel.sum() >= MIN_FIT_FRAMES else None
    return {"a": a, "v": float(v[-1, 0]), "wR": -float(w[-1, 1]) * radius}


def problem(want: dict, fig: dict) -> str | None:
    """None when every figure is within ``test_rolling.TOL`` of the closed form (two-sided), else what is wrong."""
    out = [f"{key} {fig[key]:.5g} against {want[key]:.5g} ({100 * (fig[key] / want[key] - 1):+.2f} %)"
           for key in ("a", "v", "wR") if fig.get(key) is not None and abs(fig[key] / want[key] - 1.0) > rl.TOL]
    return "; ".join(out) or None


def row(engine: str, shape: str, radius: float, n_grid: int, mu: float, speed: float = U) -> dict:
    """One case on ``engine``: the body of ``shape`` (axis along y, across the belt) at rest on the belt of friction
    ``mu``; its figures, the closed form of its own ``k`` and the verdict."""
    from gasp_core.seam.setup import Material
    from gasp_core.testing.helpers import make_setup
    x, vol, n_render = RF.body(shape, radius, n_grid, "fibonacci")
    k = RF.inertia_share(x, vol, radius)
    x = x - (vol[:, None] * x).sum(0) / vol.sum() + START + np.array([0.0, 0.0, radius])
    st = make_setup(x, vol, Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0), lo=np.zeros(3),
                    hi=np.full(3, BOX), n_grid=n_grid, frame_dt=1.0 / FPS)
    st.n_render = n_render
    st.colliders = [belt_collider(mu, n_grid, speed)]
    want = closed_form(k, mu, speed)
    t0 = time.time()
    c, v, w = rl.trace(engine, st, T)
    fig = figures(c, v, w, radius, want["t_star"])
    return {"engine": engine, "shape": shape, "R": radius, "n_grid": n_grid, "mu": mu, "U": speed, "k": k, **fig,
            **{f"{key}_want": val for key, val in want.items()},
            **{f"{key}_err": (fig[key] / want[key] - 1.0 if fig[key] is not None else None) for key in ("a", "v", "wR")},
            "problem": problem(want, fig), "wall_s": time.time() - t0}


def report(r: dict) -> str:
    errs = ", ".join(f"{key} {100 * r[key + '_err']:+.2f} %" for key in ("a", "v", "wR") if r[key + "_err"] is not None)
    return (f"{r['engine']} {r['shape']} R {r['R']} n_grid {r['n_grid']} mu {r['mu']} (k {r['k']:.3f}, t* "
            f"{r['t_star_want']:.3f} s): {errs}; {r['problem'] or 'ok'} [{r['wall_s']:.0f} s]")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--shapes", default="ball,cylinder", help="ball, cylinder or both (comma-separated)")
    ap.add_argument("--round-collider", type=int, default=1, help="gasp_core.mpm.round_ground.ROUND_COLLIDER")
    ap.add_argument("--out", default=None, help="a new JSON file for the rows (refused if it exists)")
    a = ap.parse_args(argv)
    out = Path(a.out) if a.out else None
    if out is not None and out.exists():
        ap.error(f"--out {out} exists; give a new file")
    import gasp_core.mpm.round_ground as rg
    rg.ROUND_COLLIDER = a.round_collider
    rows = []
    for shape in a.shapes.split(","):
        for radius in RADII:
            for n_grid in GRIDS:
                for mu in MUS:
                    rows.append(row(a.engine, shape, radius, n_grid, mu))
                    print(report(rows[-1]), flush=True)
    RF.write_rows(out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
