"""Round 45 (issue 67 items 5 and 3): the figures of ``tests/test_snow_contact.py``, snow against a jelly ball and on
slopes (``gasp_core.testing.snow``; docs/contact.md "Round 45: snow against a solid and on slopes").

    python benchmarks/snow_checks.py ball --engines warp_mpm,taichi_mpm --grids 32,48 --radii 0.05,0.04
    python benchmarks/snow_checks.py slope --engines warp_mpm,taichi_mpm --grids 24,48

``ball``: per engine, grid and ball radius (m), with the two-field contact and with one field, the deepest snow point
below the ball's surface along its normals (dx; negative: a gap), the same from the ball's centroid (``R`` minus the
nearest snow point's distance), the ball's turn (degrees). ``slope``: per engine, grid, angle (15, 30, 45 degrees) and
ground friction (0.2, 0.4, 0.6; ``--cases 30:0.65,45:1.05`` for others), the acceleration's error against Coulomb's
(%) where it slides, the travel in 1 s after the settle (mm) where it sticks. Each line is printed as it ends and
appended to ``benchmarks/results/snow_checks.md`` (``--out``).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))


def _ball(engine: str, n: int, r: float, fields: bool) -> str:
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing import sand_ball as S
    from gasp_core.testing import snow as W
    from gasp_core.testing.kit import run_trace
    s = W.ball_setup(n, r, {"threads": 1, "contact_fields": fields})
    t = time.time()
    tr = run_trace(get_engine(engine), s, 36)
    b = np.asarray(s.body_id)
    dx = S.SIDE / n
    d = W.surface_depth_dx(tr.x[0], tr.x[-1], b, r, dx)
    xb = tr.x[-1][b == 1]
    rr = np.linalg.norm(tr.x[-1][b == 0] - xb.mean(0), axis=1)
    return (f"| ball | {engine} | n{n} R {r:g} | {'two fields' if fields else 'one field'} | depth {d:+.3f} dx "
            f"(centroid {(r - rr.min()) / dx:+.3f}) | turn {S.rotation_deg(tr.x[0][b == 1], xb):.2f} deg | "
            f"{time.time() - t:.0f} s |")


def _slope(engine: str, n: int, theta: float, mu: float) -> str:
    import test_snow_contact as T
    from slopes import closed_form, slides
    t = time.time()
    f = T.slope_figure(engine, theta, mu, n)
    what = (f"a {f:.4f} m/s^2, {100 * (f / closed_form(theta, mu) - 1):+.4f} %" if slides(theta, mu)
            else f"travel {f:.4f} mm in 1 s")
    return f"| slope | {engine} | n{n} | {theta:g} deg, mu {mu:g} | {what} | {time.time() - t:.0f} s |"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("what", choices=["ball", "slope"])
    p.add_argument("--engines", default="warp_mpm,taichi_mpm")
    p.add_argument("--grids", default="")
    p.add_argument("--radii", default="0.05,0.04")
    p.add_argument("--cases", default="")
    p.add_argument("--out", default=str(ROOT / "benchmarks/results/snow_checks.md"))
    a = p.parse_args()
    grids = [int(g) for g in (a.grids or ("32,48" if a.what == "ball" else "24,48")).split(",")]
    cases = ([tuple(float(v) for v in c.split(":")) for c in a.cases.split(",")] if a.cases else
             [(th, mu) for th in (15, 30, 45) for mu in (0.2, 0.4, 0.6)])
    for e in a.engines.split(","):
        for n in grids:
            if a.what == "ball":
                lines = (_ball(e, n, float(r), f) for r in a.radii.split(",") for f in (True, False))
            else:
                lines = (_slope(e, n, th, mu) for th, mu in cases)
            for line in lines:
                print(line, flush=True)
                with open(a.out, "a") as fh:
                    fh.write(line + "\n")


if __name__ == "__main__":
    main()
