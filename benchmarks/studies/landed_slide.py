"""Round 50 (docs/contact.md "Round 50: a slide after a landing"): the jelly block of ``gasp_core.testing.grid_hold``
thrown at the slope's plane (normal speed ``v_land``) on the grid contact, with ``touch_credit`` on and off: its
acceleration along the slope after the landing (``LAND_FIT``) against Coulomb's ``g (sin - mu cos)``, and its travel
at the fit's end against Coulomb's from rest at the landing (``a t^2 / 2``; Coulomb's impulse law loses nothing of a
tangential speed that is 0 at the impact). Prints one line a case.

    python benchmarks/studies/landed_slide.py --engine warp_mpm --n 32 48 --speeds 0 0.5 1 2
"""
import argparse
import math
import time

import numpy as np


def _cls(engine: str):
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.grid import GridUpdate as cls
    else:
        from gasp_warp_mpm.engine import WarpMPMEngine as cls
    return cls


def main() -> None:
    from gasp_core.testing.grid_hold import LAND_FIT, landed_trace
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--n", type=int, nargs="+", default=[32, 48])
    ap.add_argument("--speeds", type=float, nargs="+", default=[0.0, 0.5, 1.0, 2.0])
    ap.add_argument("--cases", default="45:0.95,30:0.4")
    ap.add_argument("--credit", type=int, nargs="+", default=[1, 0])
    a = ap.parse_args()
    cls = _cls(a.engine)
    for n in a.n:
        for case in a.cases.split(","):
            theta, mu = (float(v) for v in case.split(":"))
            r = math.radians(theta)
            ac = 9.81 * (math.sin(r) - mu * math.cos(r))
            for v in a.speeds:
                for credit in a.credit:
                    cls.touch_credit = bool(credit)
                    t0 = time.time()
                    tr = landed_trace(a.engine, n, theta, mu, v)
                    if tr is None:
                        print(f"{a.engine} n{n} {theta:g} deg mu {mu:g} v {v:g} credit {credit}: diverged")
                        continue
                    t, c = tr
                    sel = (t >= LAND_FIT[0] - 1e-9) & (t <= LAND_FIT[1] + 1e-9)
                    acc = 2.0 * float(np.polyfit(t[sel], c[sel, 0], 2)[0])
                    travel = float(c[-1, 0] - c[0, 0])
                    ref = 0.5 * ac * t[-1] ** 2
                    dz = 1000 * float(c[:, 2].min() - c[0, 2])
                    print(f"{a.engine} n{n} {theta:g} deg mu {mu:g} v {v:g} credit {credit}: a {100 * (acc / ac - 1):+.2f} %"
                          f" travel {1000 * travel:.2f} mm ({100 * (travel / ref - 1):+.2f} % of {1000 * ref:.2f}),"
                          f" sink {dz:.2f} mm, {time.time() - t0:.1f} s", flush=True)


if __name__ == "__main__":
    main()
