"""Issue 67 round 50 (lead): the released jelly block of ``tests/test_grid_hold.py`` at 45 degrees, mu 0.95
(``tan theta / mu`` 1.05), on the grid contact, fitted over three windows (s) under the touch rules of rounds 48
(``touch_share`` False), 49 (``touch_credit`` False) and 50 (both True): whether round 50's restored slide holds
after ``tests/test_grid_hold.py``'s window 0.05-0.3 s. Prints the relative error of each fitted acceleration against
``g (sin theta - mu cos theta)`` and the centroid's rise (mm) at the last frame. warp_mpm (taichi_mpm reads the
same switches on ``gasp_taichi_mpm.grid.GridUpdate``). Quoted in docs/contact.md ("Round 50: a slide after a landing").

Usage: ``python benchmarks/studies/slide_windows.py --n 48``
"""
from __future__ import annotations

import argparse
import math

import numpy as np

WINDOWS = [(0.05, 0.3), (0.1, 0.35), (0.2, 0.45)]
RULES = [("round 48", False, False, "credit"), ("round 49", True, False, "credit"), ("round 50", True, True, "credit"),
         ("round 51", True, True, "debt")]


def main() -> None:
    from gasp_warp_mpm.engine import WarpMPMEngine as C

    from gasp_core.testing.grid_hold import landed_trace
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=48)
    n = ap.parse_args().n
    r = math.radians(45.0)
    a_c = 9.81 * (math.sin(r) - 0.95 * math.cos(r))
    for name, share, credit, bound in RULES:
        C.touch_share, C.touch_credit, C.touch_bound = share, credit, bound
        t, c = landed_trace("warp_mpm", n, 45.0, 0.95, 0.0)
        out = []
        for lo, hi in WINDOWS:
            sel = (t >= lo - 1e-9) & (t <= hi + 1e-9)
            a = 2.0 * float(np.polyfit(t[sel], c[sel, 0], 2)[0])
            out.append(f"{lo}-{hi} s: {100 * (a / a_c - 1):+.1f} %")
        print(f"n_grid {n}, {name}: " + ", ".join(out) + f"; rise {1e3 * (c[-1, 2] - c[0, 2]):+.3f} mm", flush=True)


if __name__ == "__main__":
    main()
