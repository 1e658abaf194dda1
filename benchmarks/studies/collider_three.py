"""Round 64 (issue 67 item 4, ``docs/rigid.md`` "Round 64: the rigid collider among three or more bodies"): the rest
drift of every soft/rigid interface in scenes of three bodies with a rigid one, and the sandwich's thrown top block.

Scenes (:func:`rest_setup`, ``gasp_core.testing.scenes_rigid3._setup``: jelly rho 1000, a frictionless ground at 0,
frames of 1/60 s, at rest at t = 0; body 0 first):

- ``sandwich``: the slide's blocks, rigid 6 x 6 x 3 cm / jelly 28 x 16 x 8 cm / rigid 32 x 20 x 3 cm (top first);
- ``rjj``: the same blocks rigid / jelly / jelly;
- ``beside``: a 6 cm jelly cube and a 6 x 6 x 3 cm rigid block side by side (8 cm apart) on a 40 x 16 x 3 cm rigid
  slab (a soft/rigid interface next to a rigid/rigid one, the slab in one field, the cube and block in the other).

Figures per interface (upper body, lower body): the gap (the upper body's lowest point less the lower body's highest
under it) at 0.3 and 1.0 s, the drift 0.3 -> 1.0 s and the settle 0 -> 0.3 s in dx (``tests/test_three_soft_rigid.py``
holds them within 0.1 dx). ``--slide``: the sandwich's thrown top block (``scenes_rigid3.measure_slide``) against
Coulomb's closed form (``--models``: another mix, top first).

    python benchmarks/studies/collider_three.py --engine warp_mpm --cases sandwich,rjj,beside --grids 32 --E 1e5 \
        [--set gasp_core.mpm.rigid_collider.MULTI=0] [--slide]
"""
from __future__ import annotations

import argparse
import dataclasses
import importlib
import time

import numpy as np

from gasp_core.testing import scenes_rigid3 as S

T0, T1 = 0.3, 1.0


def rest_setup(case: str, n_grid: int, E: float = 1.0e5):
    """``(setup, pairs)``: the scene of the module notes and its soft/rigid or rigid/rigid interfaces
    ``(upper, lower)``."""
    h = S.MIDDLE_H
    top, mid = ([-0.03, -0.03, 0.03 + h], [0.03, 0.03, 0.06 + h]), ([-0.10, -0.08, 0.03], [0.18, 0.08, 0.03 + h])
    bot = ([-0.12, -0.10, 0.0], [0.20, 0.10, 0.03])
    if case == "sandwich":
        boxes, models, pairs = [top, mid, bot], ("rigid", "elastic", "rigid"), [(0, 1), (1, 2)]
    elif case == "rjj":
        boxes, models, pairs = [top, mid, bot], ("rigid", "elastic", "elastic"), [(0, 1), (1, 2)]
    elif case == "beside":
        boxes = [([-0.09, -0.03, 0.03], [-0.03, 0.03, 0.09]), ([0.05, -0.03, 0.03], [0.11, 0.03, 0.06]),
                 ([-0.12, -0.08, 0.0], [0.28, 0.08, 0.03])]
        models, pairs = ("elastic", "rigid", "rigid"), [(0, 2), (1, 2)]
    else:
        raise ValueError(case)
    s = S._setup(boxes, models, [0.0, 0.0, 0.0], n_grid, 0.0, [None] * 3)
    s.materials = [dataclasses.replace(m, E=E) for m in s.materials]
    return s, pairs


def gaps(X, body, pairs) -> list[float]:
    """Each pair's gap (m): the upper body's lowest point less the lower body's highest within the upper's x-y
    extent."""
    out = []
    for a, b in pairs:
        xa, xb = X[body == a], X[body == b]
        lo, hi = xa[:, :2].min(0), xa[:, :2].max(0)
        under = np.all((xb[:, :2] >= lo) & (xb[:, :2] <= hi), axis=1)
        out.append(float(xa[:, 2].min() - xb[under, 2].max()))
    return out


def measure_rest(engine: str, case: str, n_grid: int, E: float) -> dict:
    """``{"pairs", "g0", "g1", "drift", "settle"}`` (gaps in m, drift and settle in dx per pair)."""
    from gasp_core.seam import build_engine, get_engine
    s, pairs = rest_setup(case, n_grid, E)
    body = np.asarray(s.body_id)
    start = gaps(np.asarray(s.x, float), body, pairs)
    e = build_engine(get_engine(engine), s)
    at = {}
    for f in range(round(T1 / s.frame_dt)):
        e.step_frame()
        t = round((f + 1) * s.frame_dt, 6)
        if abs(t - T0) < 1e-6 or abs(t - T1) < 1e-6:
            at[t] = gaps(e.positions().astype(float), body, pairs)
    g0, g1 = np.array(at[T0]), np.array(at[T1])
    return {"pairs": pairs, "g0": g0, "g1": g1, "drift": (g1 - g0) / s.dx, "settle": (g0 - np.array(start)) / s.dx}


def _set(assign: str) -> None:
    name, value = assign.split("=")
    mod, attr = name.rsplit(".", 1)
    setattr(importlib.import_module(mod), attr, type(getattr(importlib.import_module(mod), attr))(float(value)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--cases", default="sandwich,rjj,beside")
    ap.add_argument("--grids", default="32")
    ap.add_argument("--E", default="1e5")
    ap.add_argument("--set", action="append", default=[], help="module.ATTR=value (a broken variant or the rule off)")
    ap.add_argument("--slide", action="store_true", help="the sandwich's thrown top block instead")
    ap.add_argument("--models", default="rigid,elastic,rigid", help="--slide: the three's models, top first")
    a = ap.parse_args()
    for assign in a.set:
        _set(assign)
    for n in [int(g) for g in a.grids.split(",")]:
        if a.slide:
            t = time.time()
            s = S.slide_setup(n, 0.5, models=tuple(a.models.split(",")))
            r = S.measure_slide(a.engine, s)
            print(f"{a.engine} {a.models} slide n{n}: error {100 * (r['slide'] / r['closed'] - 1):+.2f} %, {r}"
                  f"  ({time.time() - t:.0f} s)", flush=True)
            continue
        for case in a.cases.split(","):
            for E in [float(v) for v in a.E.split(",")]:
                t = time.time()
                r = measure_rest(a.engine, case, n, E)
                cells = ", ".join(f"{p[0]}/{p[1]}: {1e3 * g0:.2f} -> {1e3 * g1:.2f} mm drift {d:+.3f} settle {st:+.3f}"
                                  for p, g0, g1, d, st in zip(r["pairs"], r["g0"], r["g1"], r["drift"], r["settle"]))
                print(f"{a.engine} {case} n{n} E {E:g}: {cells}  ({time.time() - t:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
