"""Round 91 (issue 67 item 4, body on body; ``docs/rigid.md`` "Round 91: the normal of a round body's contact"): two
rigid balls in an oblique frictionless impact, against the closed form of an inelastic impact along the line of
centres.

Ball 1 (``roll_family88``'s ball, radius ``R``) slides at ``V0`` along x on a frictionless ground and strikes ball 2
at rest, their centres ``b`` apart across the path (the impact parameter). Without friction between them the impulse
lies along the line of centres at contact, at ``phi = asin(b / 2R)`` to the path, so the struck ball leaves along it
(the billiard player's rule), and the pair law's impact is inelastic along it (``rigid_friction.pair_contact``): the
struck ball's speed is ``m_1 / (m_1 + m_2) V0 cos phi``. Judged two-sided: its direction within :data:`TOL` of
``phi`` and its speed within :data:`TOL` of the closed form; momentum along x and y kept.
The family: ``b / R`` 0.5, 1 and 1.5; n_grid 24, 32 and 48 in a 0.48 m box; R 0.05 m, and 0.1 m at n_grid 32; the
struck ball as dense, and three times as dense.

``python benchmarks/studies/roll_impact91.py --engine warp_mpm --out benchmarks/results/roll_impact91_warp.json``
(refused if the file exists); ``--round-normal 0``: the touching nodes' normal (round 90's, the broken variant).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import roll_family88 as RF  # noqa: E402

SIDE, FPS, V0, RHO = 0.48, 60, 1.0, 700.0
#: Two-sided, relative: the struck ball's direction against ``phi`` and its speed against the closed form.
TOL = 0.04


def family() -> list[tuple[float, int, float, float]]:
    """``(R m, n_grid, b / R, density ratio of the struck ball)``."""
    rows = [(0.05, n, b, 1.0) for n in (24, 32, 48) for b in (0.5, 1.0, 1.5)]
    return rows + [(0.1, 32, b, 1.0) for b in (0.5, 1.0, 1.5)] + [(0.05, 32, b, 3.0) for b in (0.5, 1.0, 1.5)]


def setup(radius: float, n_grid: int, b_over_r: float, ratio: float):
    """``SimSetup``: ball 1 (body 0) at ``V0`` along x, ball 2 (body 1) at rest ``b`` across, both resting on a
    frictionless ground, the balls frictionless with each other."""
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    x, vol, _ = RF.body("ball", radius, round(n_grid * 0.6 / SIDE), "fibonacci")
    x = x - (vol[:, None] * x).sum(0) / vol.sum()
    b, z = b_over_r * radius, radius + 0.0005
    lift = np.array([0.0, 0.0, z])
    x1, x2 = x + lift + [-2.2 * radius, -b / 2, 0.0], x + lift + [0.0, b / 2, 0.0]
    mats = [Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=RHO * r, friction=0.0) for r in (1.0, ratio)]
    lo = np.array([-SIDE / 2, -SIDE / 2, -3 * SIDE / n_grid])
    v = np.zeros((2 * len(x), 3))
    v[:len(x), 0] = V0
    return SimSetup(x=np.concatenate([x1, x2]), v=v, p_vol=np.r_[vol, vol],
                    body_id=np.r_[np.zeros(len(x), int), np.ones(len(x), int)], materials=mats,
                    gravity=np.array([0.0, 0.0, -9.81]), domain_lo=lo, domain_hi=lo + SIDE, n_grid=n_grid,
                    frame_dt=1.0 / FPS, boundaries=[Boundary("ground", height=0.0, friction=0.0)])


def row(engine: str, radius: float, n_grid: int, b_over_r: float, ratio: float) -> dict:
    """The run's figures and verdict: ``angle`` and ``phi`` (degrees), ``speed`` and ``want`` (m/s), ``p`` (the
    total momentum over the start's, along x and y) and ``problem`` (None: within :data:`TOL`)."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    s = setup(radius, n_grid, b_over_r, ratio)
    bid, m = np.asarray(s.body_id), np.asarray(s.p_mass, np.float64)
    M = [m[bid == i].sum() for i in (0, 1)]
    t0 = time.time()
    e = build_engine(get_engine(engine), s)
    for _ in range(round(0.15 * FPS)):   # the impact at about 0.02 s; its balls apart by 0.15 s
        e.step_frame()
    V = e.velocities().astype(np.float64)
    e.close()
    v = [(m[bid == i][:, None] * V[bid == i]).sum(0) / M[i] for i in (0, 1)]
    phi = float(np.degrees(np.arcsin(b_over_r / 2.0)))
    angle = float(np.degrees(np.arctan2(v[1][1], v[1][0])))
    speed, want = float(np.hypot(v[1][0], v[1][1])), M[0] / (M[0] + M[1]) * V0 * float(np.cos(np.radians(phi)))
    p = (M[0] * v[0] + M[1] * v[1]) / (M[0] * V0)
    bad = [f"{name} {got:.4g} against {ref:.4g} ({100 * (got / ref - 1):+.2f} %)"
           for name, got, ref in (("angle", angle, phi), ("speed", speed, want)) if abs(got / ref - 1.0) > TOL]
    if abs(p[0] - 1.0) > 1e-3 or abs(p[1]) > 1e-3:
        bad.append(f"momentum {p[:2].round(4).tolist()}")
    return {"engine": engine, "R": radius, "n_grid": n_grid, "b_over_R": b_over_r, "density_ratio": ratio,
            "angle": angle, "phi": phi, "speed": speed, "want": want, "p": p.tolist(),
            "problem": "; ".join(bad) or None, "wall_s": time.time() - t0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--round-normal", type=int, default=1, help="gasp_core.mpm.rigid_pairs.ROUND_NORMAL (0: the "
                                                                   "nodes' normal, round 90's, the broken variant)")
    ap.add_argument("--out", default=None, help="a new JSON file for the rows (refused if it exists)")
    a = ap.parse_args(argv)
    import gasp_core.mpm.rigid_pairs as rp
    rp.ROUND_NORMAL = a.round_normal
    out = RF.new_out(ap, a.out)
    rows = []
    for case in family():
        rows.append(row(a.engine, *case))
        r = rows[-1]
        print(f"{a.engine} R {r['R']} n_grid {r['n_grid']} b/R {r['b_over_R']} rho x{r['density_ratio']}: angle "
              f"{r['angle']:.2f} (phi {r['phi']:.2f}), speed {r['speed']:.4f} (want {r['want']:.4f}); "
              f"{r['problem'] or 'ok'}", flush=True)
    RF.write_rows(out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
