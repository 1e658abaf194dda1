"""Round 90 (issue 67 item 2 on a moving ``[[collider]]``, ``docs/rigid.md`` "Round 90: round bodies on moving
colliders"): rigid balls and solid cylinders, and jelly blocks, set at rest on a collider that slides, against
closed forms.

**The belt.** A flat plate 1.0 x 0.5 x 0.1 m (12 triangles, trimesh's exact signed distance), its top 0.15 m over the
floor of a 0.6 m box, moves at ``U`` 0.3 m/s along x from ``t = 0`` (``[[collider]] velocity``: a belt started at
once); the body of ``roll_family88.body`` (its axis along y) rests on it, gravity straight down. Coulomb's closed form,
of the body's own ``k = I / (M R^2)`` (``roll_family88.inertia_share``): while it slips the centre accelerates at
``mu g`` along the belt and the spin grows at ``mu g / (k R)``; the slip ends at ``t* = k U / ((1 + k) mu g)``; then
the centre moves at ``v = k U / (1 + k)`` (2/7 U for a solid sphere, U/3 for a solid cylinder: the angular momentum
about the contact line is kept) with ``omega R = U - v``. Figures: the slipping acceleration (a parabola fitted to the
centre's travel over the frames within ``0.8 t*``, where those are ``MIN_FIT_FRAMES`` or more: mu 0.05), ``v`` and
``omega R`` at ``T`` s. The family: R 0.05 and 0.1 m, n_grid 32 and 48, mu 0.05 and 0.5, and the 5 cm body at n_grid
48 with ``roll_family88``'s other samplings.

**Blocks on the belt** (``--parts blocks``, issue 67 items 1 and 3): ``tests/test_elastic_slope.py``'s jelly (E 1e5
Pa) as its flat block and round 77's cube, on the particle and the grid contact, and the same blocks rigid
(``tests/test_rigid_slope.py``'s hardwood), each slipping at ``mu g`` until it rides the belt (:func:`block`).
Colliders that turn (a turntable, a drum): ``roll_spin90.py``.

Each figure within ``test_rolling.TOL`` (5 %, two-sided) of its closed form.
``python benchmarks/studies/roll_belt90.py --engine warp_mpm --parts belt --out
benchmarks/results/roll_belt90_warp.json`` (refused if the file exists), and ``--parts blocks``;
``--round-collider 0`` runs round 88's contact on the points (the broken variant).
"""
from __future__ import annotations

import argparse
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


def problem(want: dict, fig: dict, keys=("a", "v", "wR")) -> str | None:
    """None when every figure of ``keys`` that ``fig`` holds (not None) is within ``test_rolling.TOL`` of ``want``'s
    (two-sided), else what is wrong."""
    out = [f"{key} {fig[key]:.5g} against {want[key]:.5g} ({100 * (fig[key] / want[key] - 1):+.2f} %)"
           for key in keys if fig.get(key) is not None and abs(fig[key] / want[key] - 1.0) > rl.TOL]
    return "; ".join(out) or None


def measure(engine: str, shape: str, radius: float, n_grid: int, mu: float, sampling: str = "fibonacci",
            friction: float | None = None, output=None) -> tuple[float, dict, dict]:
    """``(k, figures, closed form)`` of the body of ``shape`` (``roll_family88.body``, its axis along y, across the
    belt) at rest on the belt of friction ``mu``. The broken variants: ``friction`` the collider's friction in place
    of ``mu`` (the closed form stays ``mu``'s), ``output(centroids)`` the frames' centres rewritten (the velocity then
    taken from them)."""
    from gasp_core.seam.setup import Material
    from gasp_core.testing.helpers import make_setup
    x, vol, n_render = RF.body(shape, radius, n_grid, sampling)
    k = RF.inertia_share(x, vol, radius)
    x = x - (vol[:, None] * x).sum(0) / vol.sum() + START + np.array([0.0, 0.0, radius])
    st = make_setup(x, vol, Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0), lo=np.zeros(3),
                    hi=np.full(3, BOX), n_grid=n_grid, frame_dt=1.0 / FPS)
    st.n_render = n_render
    st.colliders = [belt_collider(mu if friction is None else friction, n_grid)]
    want = closed_form(k, mu)
    c, v, w = rl.trace(engine, st, T)
    if output is not None:
        c = output(c)
        v = np.vstack([np.zeros(3), np.diff(c, axis=0) * FPS])
    return k, figures(c, v, w, radius, want["t_star"]), want


def row(engine: str, shape: str, radius: float, n_grid: int, mu: float, sampling: str = "fibonacci") -> dict:
    """One case on ``engine`` (:func:`measure`): its figures, the closed form of its own ``k`` and the verdict."""
    t0 = time.time()
    k, fig, want = measure(engine, shape, radius, n_grid, mu, sampling)
    return {"engine": engine, "shape": shape, "R": radius, "n_grid": n_grid, "sampling": sampling, "mu": mu, "U": U,
            "k": k, **fig, **{f"{key}_want": val for key, val in want.items()},
            **{f"{key}_err": (None if fig[key] is None else fig[key] / want[key] - 1.0) for key in ("a", "v", "wR")},
            "problem": problem(want, fig), "wall_s": time.time() - t0}


def family() -> list[tuple[float, int, str]]:
    """``(radius m, n_grid, sampling)`` of the family (for each shape and ``mu``): every radius and grid on the
    test's sampling, and the other samplings of ``roll_family88`` on the 5 cm body at n_grid 48."""
    return [(r, n, "fibonacci") for r in RADII for n in GRIDS] + [(0.05, 48, s) for s in RF.SAMPLINGS
                                                                      if s != "fibonacci"]


def report(r: dict) -> str:
    errs = ", ".join(f"{key} {100 * r[key + '_err']:+.2f} %" for key in ("a", "v", "wR")
                     if r[key + "_err"] is not None)
    return (f"{r['engine']} {r['shape']} R {r['R']} n_grid {r['n_grid']} {r['sampling']} mu {r['mu']} (k "
            f"{r['k']:.3f}, t* {r['t_star_want']:.3f} s): {errs}; {r['problem'] or 'ok'} [{r['wall_s']:.0f} s]")


# --------------------------------------------------------------------------- soft blocks on the belt
#: The jelly of ``tests/test_elastic_slope.py`` and its two blocks (m): the issue's flat block and round 77's cube.
BLOCKS = {"block": (0.15, 0.15, 0.05), "cube": (0.1, 0.1, 0.1)}
BLOCK_GRIDS, BLOCK_MUS, CONTACTS = (24, 48), (0.1, 0.4), ("particle", "grid")
#: The blocks' kinds: the jelly on each contact, and the rigid block (its own contact).
BLOCK_KINDS = (("elastic", "particle"), ("elastic", "grid"), ("rigid", None))
#: The slipping fit starts after the first frames (the block settles onto the plate; ``test_rigid_slope``'s 0.05 s).
BLOCK_FIT_FROM = 0.05


def block(engine: str, shape: str, contact: str | None, n_grid: int, mu: float, friction: float | None = None,
          output=None, model: str = "elastic") -> dict:
    """A jelly block (E 1e5 Pa, nu 0.3, rho 1000) of ``BLOCKS[shape]`` at rest on the belt, on the ``contact``
    model (None: the default); ``model = "rigid"``: the hardwood block of ``tests/test_rigid_slope.py`` (E 1e10 Pa,
    rho 700, rigid) in its place. Coulomb: its centre accelerates at ``mu g`` until it moves with the belt at
    ``t* = U / (mu g)``, then keeps ``U``. Figures: ``a`` (a parabola over the frames from ``BLOCK_FIT_FROM`` to
    ``0.8 t*``, where those are ``MIN_FIT_FRAMES`` or more) and ``v`` (the centre's speed over the last frame), with
    ``problem`` (None within ``test_rolling.TOL``, two-sided). ``friction``, ``output``: the broken variants
    (:func:`measure`'s)."""
    from gasp_core.seam.setup import Material
    from gasp_core.testing.helpers import box_points, make_setup
    side = np.asarray(BLOCKS[shape])
    lo = START - np.array([0.05, side[1] / 2, 0.0])
    x, vol = box_points(lo, lo + side, BOX / n_grid / 2)
    mat = (Material("jelly", model="elastic", E=1.0e5, nu=0.3, rho=1000.0) if model == "elastic"
           else Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0))
    st = make_setup(x, vol, mat, lo=np.zeros(3), hi=np.full(3, BOX), n_grid=n_grid, frame_dt=1.0 / FPS,
                    options={} if contact is None else {"contact": contact})
    st.n_render = 0
    st.colliders = [belt_collider(mu if friction is None else friction, n_grid)]
    t0 = time.time()
    c = rl.trace(engine, st, T)[0]
    c = c if output is None else output(c)
    t = np.arange(len(c)) / FPS
    sel = (t >= BLOCK_FIT_FROM) & (t <= 0.8 * U / (mu * rl.G))
    fig = {"a": 2.0 * float(np.polyfit(t[sel], c[sel, 0], 2)[0]) if sel.sum() >= MIN_FIT_FRAMES else None,
           "v": float(c[-1, 0] - c[-2, 0]) * FPS}
    want = {"a": mu * rl.G, "v": U}
    return {"engine": engine, "model": model, "shape": shape, "contact": contact, "n_grid": n_grid, "mu": mu, **fig,
            **{f"{key}_want": val for key, val in want.items()},
            **{f"{key}_err": (fig[key] / want[key] - 1.0 if fig[key] is not None else None) for key in want},
            "problem": problem(want, fig), "wall_s": time.time() - t0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--shapes", default="ball,cylinder", help="ball, cylinder or both (comma-separated)")
    ap.add_argument("--parts", default="belt,blocks", help="belt, blocks (elastic and rigid), elastic, rigid "
                                                           "(comma-separated)")
    ap.add_argument("--round-collider", type=int, default=1, help="gasp_core.mpm.round_ground.ROUND_COLLIDER")
    ap.add_argument("--out", default=None, help="a new JSON file for the rows (refused if it exists)")
    a = ap.parse_args(argv)
    out = RF.new_out(ap, a.out)
    import gasp_core.mpm.round_ground as rg
    rg.ROUND_COLLIDER = a.round_collider
    rows = []
    for shape in a.shapes.split(",") if "belt" in a.parts else []:
        for radius, n_grid, sampling in family():
            for mu in MUS:
                rows.append(row(a.engine, shape, radius, n_grid, mu, sampling))
                print(report(rows[-1]), flush=True)
    kinds = [(m, c) for m, c in BLOCK_KINDS if m in a.parts.replace("blocks", "elastic,rigid")]
    for model, contact in kinds:
        for shape in BLOCKS:
            for n_grid in BLOCK_GRIDS:
                for mu in BLOCK_MUS:
                    rows.append(block(a.engine, shape, contact, n_grid, mu, model=model))
                    r = rows[-1]
                    errs = ", ".join(f"{key} {100 * r[key + '_err']:+.2f} %" for key in ("a", "v")
                                     if r[key + "_err"] is not None)
                    print(f"{a.engine} {model} {shape} {contact} n_grid {n_grid} mu {mu}: {errs}; "
                          f"{r['problem'] or 'ok'} [{r['wall_s']:.0f} s]", flush=True)
    RF.write_rows(out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
