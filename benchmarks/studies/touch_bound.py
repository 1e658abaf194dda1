"""Issue 67 round 51 (docs/contact.md "Round 51: the landing's friction"): the grid contact's bound on a touched
column's friction, ``touch_bound`` (``gasp_core.mpm.contact.TOUCH_BOUNDS``: "credit" round 50's, "debt" round 51's,
"substep", "episode", round 52's "body", the default since round 52), on the landing and on the must-keeps. One line
a case:

- ``land``: ``tests/test_landed_slide.py``'s throw (the jelly block of ``tests/test_ground_slide_coulomb.py``, n_grid
  32, thrown at 1.6 m/s along and 0.5 / 1 m/s down): ``sand_ball.coulomb_ratio`` over ``mu`` in the landing's frame,
  less 1;
- ``landtravel``: that block thrown at 0.8 m/s along and 0.5 m/s down: its travel in 1 s against Coulomb's impulse
  law's ``(v0 - mu vz)^2 / (2 mu g)``;
- ``throw``: the block thrown along at 0.4 / 0.6 / 0.8 m/s: its travel against ``v0^2 / (2 mu g)``;
- ``slide:N:THETA:MU``, ``hold:N:THETA:MU``: ``gasp_core.testing.grid_hold``'s ``slide_error`` / ``hold_travel``
  (the released jelly);
- ``windows:N[:V]``: the released (or landed at ``V`` m/s) jelly at 45 degrees, mu 0.95, fitted over 0.05-0.3 /
  0.1-0.35 / 0.2-0.45 s (``slide_windows.py``'s), and the centroid's rise at the end;
- ``sag:SHAPE:N``: ``gasp_core.testing.sag.sag_ratio``;
- ``landslope:N:THETA:MU`` (round 52): ``gasp_core.testing.grid_hold.landing_error`` at 0.5 / 1 m/s down (the
  landing's friction impulse over ``mu`` times its normal impulse on the slope, thrown along at 1.6 m/s).

Usage: ``python benchmarks/studies/touch_bound.py ENGINE BOUND[/PULL] CASE...``, e.g. ``warp_mpm debt land windows:48``;
round 53: ``PULL`` the dashpots' pull under "body" (``touch_pull``, ``gasp_core.mpm.contact.TOUCH_PULLS``).
"""
from __future__ import annotations

import math
import sys
import time

import numpy as np


def _throw(engine: str, v0: float, vz: float, frames: int):
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing import sand_ball as S
    from gasp_core.testing.kit import run_trace
    s = S.slide_setup(v0, {"threads": 1, "contact": "grid"}, ground=True, solid=True)
    s.v = np.asarray(s.v, float) + np.array([0.0, 0.0, -vz])
    return s, run_trace(get_engine(engine), s, frames)


def case_line(engine: str, kind: str, args: list) -> str:
    """The figure of one case (module docstring)."""
    from gasp_core.testing import sand_ball as S
    from gasp_core.testing.grid_hold import hold_travel, landed_trace, slide_error
    if kind == "land":
        out = []
        for vz in (0.5, 1.0):
            s, tr = _throw(engine, 1.6, vz, 1)
            out.append(f"{100 * (S.coulomb_ratio(tr.v, s, 0, 1) / float(s.boundaries[0].friction) - 1):+.2f}")
        return "landing's friction over mu times its normal impulse, vz 0.5 / 1 m/s: " + " / ".join(out) + " %"
    if kind in ("landtravel", "throw"):
        out = []
        for v0, vz in ([(0.8, 0.5)] if kind == "landtravel" else [(0.4, 0.0), (0.6, 0.0), (0.8, 0.0)]):
            s, tr = _throw(engine, v0, vz, 30)
            mu, g = float(s.boundaries[0].friction), -float(s.gravity[2])
            ref = max(v0 - mu * vz, 0.0) ** 2 / (2 * mu * g)
            out.append(f"{100 * (S.slide_travel(tr.x[0], tr.x[-1], s) / ref - 1):+.2f}")
        return f"{kind} travel over Coulomb's: " + " / ".join(out) + " %"
    if kind in ("slide", "hold"):
        n, th, mu = int(args[0]), float(args[1]), float(args[2])
        if kind == "slide":
            return f"slide n{n} {th:g} deg mu {mu:g}: {100 * slide_error(engine, 'jelly', n, th, mu):+.2f} %"
        return f"hold n{n} {th:g} deg mu {mu:g}: {hold_travel(engine, 'jelly', 'release', n, th, mu):.4f} mm"
    if kind == "windows":
        n, v = int(args[0]), float(args[1]) if len(args) > 1 else 0.0
        r = math.radians(45.0)
        a_c = 9.81 * (math.sin(r) - 0.95 * math.cos(r))
        t, c = landed_trace(engine, n, 45.0, 0.95, v)
        out = []
        for lo, hi in [(0.05, 0.3), (0.1, 0.35), (0.2, 0.45)]:
            sel = (t >= lo - 1e-9) & (t <= hi + 1e-9)
            out.append(f"{100 * (2.0 * float(np.polyfit(t[sel], c[sel, 0], 2)[0]) / a_c - 1):+.1f}")
        return (f"45 deg mu 0.95 n{n} v {v:g}, windows 0.05-0.3 / 0.1-0.35 / 0.2-0.45 s: " + " / ".join(out)
                + f" %; rise {1e3 * (c[-1, 2] - c[0, 2]):+.3f} mm")
    if kind == "landslope":
        from gasp_core.testing.grid_hold import landing_error
        n, th, mu = int(args[0]), float(args[1]), float(args[2])
        out = [f"{100 * landing_error(engine, n, th, mu, vz):+.2f}" for vz in (0.5, 1.0)]
        return f"landing on the slope n{n} {th:g} deg mu {mu:g}, vz 0.5 / 1 m/s: " + " / ".join(out) + " %"
    if kind == "sag":
        from gasp_core.testing.sag import sag_ratio
        return f"sag {args[0]} n{args[1]}: {sag_ratio(engine, args[0], int(args[1]))[0]:.3f}"
    raise SystemExit(f"unknown case {kind}")


def main() -> None:
    engine, bound = sys.argv[1], sys.argv[2]
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.grid import GridUpdate as cls
    else:
        from gasp_warp_mpm.engine import WarpMPMEngine as cls
    cls.touch_bound, _, pull = bound.partition("/")   # round 53: BOUND/PULL, e.g. body/none (TOUCH_PULLS)
    cls.touch_pull = pull or cls.touch_pull
    for case in sys.argv[3:]:
        t0 = time.time()
        kind, *args = case.split(":")
        print(f"{engine} {bound} {case_line(engine, kind, args)} [{time.time() - t0:.0f} s]", flush=True)


if __name__ == "__main__":
    main()
