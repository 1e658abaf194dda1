"""Round 50 (docs/contact.md "Round 50: a slide after a landing"): the jelly block of ``gasp_core.testing.grid_hold``
thrown at the slope's plane (normal speed ``v_land``) on the grid contact, with ``touch_credit`` on and off: its
acceleration along the slope after the landing (``LAND_FIT``) against Coulomb's ``g (sin - mu cos)``, and its travel
at the fit's end against Coulomb's from rest at the landing (``a t^2 / 2``; Coulomb's impulse law loses nothing of a
tangential speed that is 0 at the impact). Prints one line a case.

    python benchmarks/studies/landed_slide.py --engine warp_mpm --n 32 48 --speeds 0 0.5 1 2

``--throw``: instead, ``tests/test_ground_slide_coulomb.py``'s jelly block thrown along the ground at 1.2 and 1.6 m/s
with a downward speed of 0.5 and 1 m/s: ``sand_ball.coulomb_ratio`` over ``mu``, less 1, to frames 1, 2, 3 and 6.
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


def throw(engine: str, credits) -> None:
    """The ``--throw`` lines (module docstring)."""
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing import sand_ball as S
    from gasp_core.testing.kit import run_trace
    for credit in credits:
        _cls(engine).touch_credit = bool(credit)
        _cls(engine).touch_bound = "credit"   # round 51: round 50's bound, where touch_credit is read
        for vz in (0.5, 1.0):
            for v0 in (1.2, 1.6):
                s = S.slide_setup(v0, {"threads": 1, "contact": "grid"}, ground=True, solid=True)
                s.v = np.asarray(s.v, float) + np.array([0.0, 0.0, -vz])
                tr = run_trace(get_engine(engine), s, 6)
                r = [S.coulomb_ratio(tr.v, s, 0, f) / float(s.boundaries[0].friction) - 1 for f in (1, 2, 3, 6)]
                print(f"{engine} credit {credit} vz {vz} v0 {v0} ratio/mu-1 f1,2,3,6: "
                      + " ".join(f"{100 * x:+.1f}%" for x in r), flush=True)


def main() -> None:
    from gasp_core.testing.grid_hold import LAND_FIT, landed_trace
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--n", type=int, nargs="+", default=[32, 48])
    ap.add_argument("--speeds", type=float, nargs="+", default=[0.0, 0.5, 1.0, 2.0])
    ap.add_argument("--cases", default="45:0.95,30:0.4")
    ap.add_argument("--credit", type=int, nargs="+", default=[1, 0])
    ap.add_argument("--throw", action="store_true")
    a = ap.parse_args()
    if a.throw:
        return throw(a.engine, a.credit)
    cls = _cls(a.engine)
    for n in a.n:
        for case in a.cases.split(","):
            theta, mu = (float(v) for v in case.split(":"))
            r = math.radians(theta)
            ac = 9.81 * (math.sin(r) - mu * math.cos(r))
            for v in a.speeds:
                for credit in a.credit:
                    cls.touch_credit = bool(credit)
                    cls.touch_bound = "credit"   # round 51: round 50's bound, where touch_credit is read
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
