"""Round 82: the flaw-based, rate-limited damage class (Benz & Asphaug 1994, 1995; Grady & Kipp 1980) tried on the
pieces family's ball (issue 66 "Pieces": the pieces of 5 % or more never decrease with speed; ``docs/fracture.md``
"Round 82"). An experiment, not the engines' code: warp_mpm only, with ``flaws82.patch`` applied
(``git apply benchmarks/studies/flaws82.patch``; ``git apply -R`` to take it off). The patch gives the brittle
return two switches, read from ``gasp_core.mpm.materials`` when the engine is built:

- ``PROBE_CRACK_SPEED`` c (0: off): the damage of a point grows by at most ``c c_l dt / h`` a substep (a crack
  crosses the band ``h`` no faster than ``c`` times the longitudinal wave speed ``c_l = sqrt((lam + 2 mu) / rho)``;
  Benz & Asphaug take c = 0.4);
- ``PROBE_WEIBULL_M`` m (0: off): each point's strength is ``f_t k``, ``k = (-ln(1 - u) / ln 2)^(1/m)`` (a Weibull
  draw of modulus m whose median is ``f_t``, ``u`` a counter-based uniform of the point's index), its ``s_f`` moved
  to keep the band's ``G_f``.

    python benchmarks/studies/flaws82.py --grids 28,32,48 --out benchmarks/results/flaws82.json
"""
from __future__ import annotations

import argparse
import itertools
import json
import time

import gasp_core.mpm.materials as materials
from gasp_core.testing.scenes_pieces import SPEEDS, ball_setup, counted_run


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grids", default="28,32,48")
    ap.add_argument("--speeds", default=",".join(str(v) for v in SPEEDS))
    ap.add_argument("--crack-speeds", default="0,0.1,0.2,0.4")
    ap.add_argument("--moduli", default="0,4,8")
    ap.add_argument("--out", default="benchmarks/results/flaws82.json")
    a = ap.parse_args()
    if not hasattr(materials, "PROBE_CRACK_SPEED"):
        raise SystemExit("flaws82.patch is not applied: git apply benchmarks/studies/flaws82.patch")
    rows = []
    for g in (int(s) for s in a.grids.split(",")):
        frames = 12 if g <= 32 else 16
        for c, m in itertools.product((float(s) for s in a.crack_speeds.split(",")),
                                      (float(s) for s in a.moduli.split(","))):
            materials.PROBE_CRACK_SPEED, materials.PROBE_WEIBULL_M = c, m
            five = []
            for v in (float(s) for s in a.speeds.split(",")):
                t0 = time.time()
                r = counted_run("warp_mpm", ball_setup(v, g), frames)
                rows.append({"n_grid": g, "frames": frames, "crack_speed": c, "weibull_m": m, "speed": v,
                             "pieces_5": r["tracker_5"][-1], "peak_5": max(r["tracker_5"]),
                             "pieces_1": r["tracker_1"][-1], "seconds": round(time.time() - t0, 2)})
                five.append(r["tracker_5"][-1])
            print(f"n_grid {g} c {c} m {m}: pieces of 5 % {five}", flush=True)
    with open(a.out, "w") as f:
        json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
