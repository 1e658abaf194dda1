"""Round 96 (issue 67 item 4, ``docs/contact.md`` "Round 96: a soft block on a thin soft support"): the block on a
block of ``tests/test_block_on_block.py`` (a jelly block thrown at ``V0`` along a jelly support lying on a
frictionless ground, E 1e5 Pa, rho 1000, the pair's coefficient 0.5) over the support's thickness in cells, the
grid's offset against the bodies and the grid, judged by that test's closed form: the upper block slides
``V0^2 / (2 mu g (1 + m1 / m2))`` on the support and the support takes the momentum.

The family: n_grid 24, 32 and 48 in the 0.48 m box; the support 1, 1.5, 2 and 3 cells thick (its faces on node layers
at offset 0 for whole cells); the grid shifted 0, 1/4 and 1/2 cell up against the bodies and the ground (the ground
stays at z = 0); the upper block 6 x 6 cm across and 3 cells thick. ``--face-share 0`` runs the rule before round 96
(``gasp_core.mpm.face_share.FACE_SHARE``), the catch. Round 97 (``docs/contact.md`` "Round 97"): ``--rigid both``
(the rigid pair) and ``three`` (two rigid blocks on a rigid board), and ``rest``, the slide to the moment the block
comes to rest (``--fps 240``), before a jelly support's recoil. Round 98 (``docs/contact.md`` "Round 98"): the
three-body scenes mixed, ``--rigid rrj`` (block, support, block: r rigid, j jelly; :func:`three_code`).
``python benchmarks/studies/thin_support96.py --engine warp_mpm --out benchmarks/results/thin_support96_warp.json``
(refused if the file exists).
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
import test_block_on_block as bb  # noqa: E402

GRIDS = (24, 32, 48)
SUPPORTS = (1.0, 1.5, 2.0, 3.0)
SHIFTS = (0.0, 0.25, 0.5)
UPPER = 3.0
#: The support's length along the throw, m (round 96's 0.40). Round 98: its far end starts 1 cm inside the grid's last
#: usable cell (n_grid 24: x < hi - 1.5 dx = 0.33 m) and, carried at the support's final speed, leaves it in every run
#: (2.2 cm in 0.3 s under one block, 3.8 cm under two): the engines drop such points (feature ``left_domain``), so the
#: support's mass centre read from the positions lags its momentum (``--length 0.36`` keeps it in; ``left``).
LENGTH = 0.40


def setup(n_grid: int, support: float, shift: float, upper: float = UPPER, half: float = 0.03, rigid: str = ""):
    """The scene: the upper block (body 0, ``upper`` cells thick, ``2 half`` m across) thrown at ``bb.V0`` on a
    support (body 1, 40 x 16 cm, ``support`` cells thick) on a frictionless ground at z = 0; the grid's lower corner
    ``shift`` cells above ``bb.block_setup``'s; ``rigid`` "upper" or "support": that body ``model = "rigid"`` (the
    mixed pairs, a neighbour the face rule does not act on); round 97, "both": the rigid pair."""
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    from gasp_core.testing.helpers import box_points
    dx = bb.SIDE / n_grid
    lo = np.array([-0.12, -bb.SIDE / 2, (shift - 3.0) * dx])
    h1, h0 = support * dx, upper * dx
    xs, vs = box_points([-half, -half, h1], [half, half, h1 + h0], dx / 2)
    xb, vb = box_points([-0.08, -0.08, 0.0], [LENGTH - 0.08, 0.08, h1], dx / 2)
    x = np.concatenate([xs, xb])
    v = np.zeros_like(x)
    v[:len(xs), 0] = bb.V0
    code = three_code(rigid)
    rigid_b = ([rigid in ("upper", "both"), rigid in ("support", "both")] if code is None
               else [c == "r" for c in code])
    mats = [Material("jelly", model="rigid" if r else "elastic", E=1.0e5, nu=0.3, rho=1000.0) for r in rigid_b]
    vol, body = [np.full(len(xs), vs), np.full(len(xb), vb)], [np.zeros(len(xs), int), np.ones(len(xb), int)]
    if code is not None:   # a second block 16 cm on, thrown alike (round 62's pairs: three bodies coloured)
        x, v = np.concatenate([x, xs + [0.16, 0.0, 0.0]]), np.concatenate([v, v[:len(xs)]])
        vol, body = vol + [vol[0]], body + [np.full(len(xs), 2)]
    s = SimSetup(x=x, v=v, p_vol=np.concatenate(vol), body_id=np.concatenate(body), materials=mats,
                 gravity=np.array([0.0, 0.0, -bb.G]), domain_lo=lo, domain_hi=lo + bb.SIDE, n_grid=n_grid,
                 frame_dt=1.0 / bb.FPS, boundaries=[Boundary("ground", height=0.0, friction=0.0)])
    s.n_render = 0
    return s


def three_code(rigid: str):
    """The three-body scenes' models, block 0, the support and block 2, each "r" (rigid) or "j" (jelly): ``three`` is
    "rrr" (round 97); round 98 names the mixed ones by their code ("rrj": a rigid and a jelly block on a rigid board,
    "rjj", "jjj", "jrj"); None for the two-body scenes."""
    if rigid == "three":
        return "rrr"
    if len(rigid) == 3 and set(rigid) <= {"r", "j"}:
        return rigid
    return None


def row(engine: str, n_grid: int, support: float, shift: float, rigid: str = "", output=None) -> dict:
    """One case: the slide and the support's final speed against the closed forms (``bb.check``'s figures), and
    (round 97) ``rest``: the slide to the moment the block comes to rest on the support (the separation's largest
    value over the frames, at ``bb.FPS``), before the support's elastic recoil after the stick. ``output``:
    ``bb.measure``'s (a broken engine's separation per frame)."""
    s = setup(n_grid, support, shift, rigid=rigid)
    t0 = time.time()
    if three_code(rigid) is not None:
        return three_row(engine, s, {"engine": engine, "rigid": rigid, "n_grid": n_grid, "support_cells": support,
                                     "shift": shift, "V0": bb.V0, "fps": bb.FPS}, t0)
    seps = []
    d, v2 = bb.measure(engine, s, output=lambda sep: seps.append(sep if output is None else output(sep)) or seps[0])
    d0, vf = bb.closed_form(s)
    rest = float(np.max(seps[0]) - seps[0][0])
    return {"engine": engine, "rigid": rigid, "n_grid": n_grid, "support_cells": support, "shift": shift, "V0": bb.V0,
            "fps": bb.FPS, "slide": d, "slide_want": d0, "slide_err": d / d0 - 1.0, "rest": rest,
            "rest_err": rest / d0 - 1.0, "lower": v2, "lower_want": vf, "lower_err": v2 / vf - 1.0,
            "wall_s": time.time() - t0}


def three_row(engine: str, s, out: dict, t0: float) -> dict:
    """Round 97, ``--rigid three``: two rigid blocks (bodies 0 and 2, mass ``m1`` together) thrown alike on a rigid
    board (body 1, ``m2``; round 98: any of the three jelly, :func:`three_code`): each comes to rest on it after
    ``V0^2 / (2 mu g (1 + m1 / m2))`` and the board ends at ``V0 m1 / (m1 + m2)``. ``rest``, ``slide``: the block
    whose figure is the farther from it."""
    from gasp_core.mpm.fields import body_friction, combine_friction
    from gasp_core.seam import build_engine, get_engine
    from gasp_core.seam.runner import left_grid
    pm, body = np.asarray(s.p_mass, float), np.asarray(s.body_id)
    e = build_engine(get_engine(engine), s)
    X = [np.asarray(s.x, float)]
    for _ in range(round(bb.T * bb.FPS)):
        e.step_frame()
        X.append(e.positions().astype(float))
    X = np.array(X)
    c = [(X[:, body == k, 0] * pm[body == k]).sum(1) / pm[body == k].sum() for k in range(3)]
    m1, m2 = pm[body != 1].sum(), pm[body == 1].sum()
    mu = combine_friction(body_friction(s.materials[0]), body_friction(s.materials[1]))
    assert mu == combine_friction(body_friction(s.materials[2]), body_friction(s.materials[1]))
    d0, vf = float(bb.V0 ** 2 / (2 * mu * bb.G * (1 + m1 / m2))), float(bb.V0 * m1 / (m1 + m2))
    rests = [float(np.max(c[k] - c[1]) - (c[k] - c[1])[0]) for k in (0, 2)]
    ends = [float((c[k] - c[1])[-1] - (c[k] - c[1])[0]) for k in (0, 2)]
    k = round(0.1 * bb.FPS)
    v2 = float((c[1][-1] - c[1][-1 - k]) * bb.FPS / k)
    rest, d = max(rests, key=lambda r: abs(r / d0 - 1.0)), max(ends, key=lambda r: abs(r / d0 - 1.0))
    left = int(left_grid(X[-1], s).sum())   # round 98: the points out of the grid at the end (feature left_domain)
    return {**out, "slide": d, "slide_want": d0, "slide_err": d / d0 - 1.0, "rest": rest, "rest_err": rest / d0 - 1.0,
            "lower": v2, "lower_want": vf, "lower_err": v2 / vf - 1.0, "left": left, "length": LENGTH,
            "wall_s": time.time() - t0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--grids", default=",".join(map(str, GRIDS)))
    ap.add_argument("--face-share", type=float, default=None, help="gasp_core.mpm.face_share.FACE_SHARE (0: off)")
    ap.add_argument("--rigid", default="", help="upper or support: that body rigid (a mixed pair); both: the rigid pair; three: two rigid "
                    "blocks on a rigid board; round 98: a three-letter code of r and j (block, support, block)")
    ap.add_argument("--v0", type=float, default=bb.V0, help="the upper block's throw, m/s")
    ap.add_argument("--fps", type=int, default=bb.FPS, help="frames a second (round 97: 240 reads the rest's slide "
                    "to 0.2 %% of it)")
    ap.add_argument("--length", type=float, default=LENGTH,
                    help="round 98: the support's length, m (0.36 keeps its far end in the grid)")
    ap.add_argument("--out", default=None, help="a new JSON file for the rows (refused if it exists)")
    a = ap.parse_args(argv)
    globals()["LENGTH"] = a.length
    import gasp_core.mpm.face_share as fs
    if a.face_share is not None:
        fs.FACE_SHARE = a.face_share
    bb.V0, bb.FPS = a.v0, a.fps
    out = RF.new_out(ap, a.out)
    rows = []
    for n_grid in map(int, a.grids.split(",")):
        for support in SUPPORTS:
            for shift in SHIFTS:
                r = row(a.engine, n_grid, support, shift, a.rigid)
                r["face_share"] = fs.FACE_SHARE
                rows.append(r)
                print(f"{a.engine} n_grid {n_grid} support {support} cells shift {shift}: slide "
                      f"{100 * r['slide_err']:+.2f} % (at rest {100 * r['rest_err']:+.2f} %), support's speed {100 * r['lower_err']:+.2f} % "
                      f"({r['wall_s']:.1f} s; {r.get('left', '-')} points out of the grid)", flush=True)
    RF.write_rows(out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
