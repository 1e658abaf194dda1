"""Round 66 (softtop): the point contact (``gasp_core.mpm.rigid_sdf.POINT_CONTACT``) with a round rigid body under
or beside a soft one, on against off (round 63's node band).

Scenes (jelly E 1e5 Pa, nu 0.3, rho 1000; a cube domain of 0.48 m; frames of 1/60 s; a frictionless ground at 0;
the bodies' friction the default; at rest at t = 0 unless said):

* ``jelly_on_ball``: a 6 cm jelly cube (body 0) resting on a rigid ball of radius 4.5 cm (body 1) on the ground;
* ``jball_on_ball``: a jelly ball of radius 3 cm (body 0) resting on the same rigid ball;
* ``ball_beside``: the rigid ball (body 0) on the ground thrown at 0.5 m/s along +x into a 6 cm jelly cube (body 1)
  resting on the ground 5 mm ahead (a side contact).

Printed: for the two resting scenes the gap (body 0's lowest point less body 1's highest) its settle from the start
to 0.3 s and its drift from 0.3 to 1.0 s (dx; ``tests/test_soft_on_rigid_rest.py``'s measure, holds within 0.1 dx
each); for the side contact the deepest jelly point inside the ball's radius over the run (dx), the ball's speed
and the cube's at the end (m/s).

    python benchmarks/studies/soft_on_round.py --engine warp_mpm --points 1 0 --case jelly_on_ball

Round 67: ``--set NAME=VALUE`` a constant of ``gasp_core.mpm.rigid_sdf`` (``GRID_PASSES=4``: the contact as a
constraint of the grid; broken variants).

Figures: ``docs/rigid.md`` ("Round 66: the point contact under a soft body (softtop)", "Round 67: the point contact
as a constraint of the grid").
"""
from __future__ import annotations

import argparse

import numpy as np

SIDE = 0.48
R_BALL = 0.045
T0, T1 = 0.3, 1.0


def round_setup(case: str, n_grid: int = 32, E: float = 1.0e5, rho_ball: float = 1000.0, v0: float = 0.5):
    """The scene ``case`` of the module notes."""
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    from gasp_core.testing.helpers import box_points, sphere_points
    dx = SIDE / n_grid
    a = 0.06
    if case == "ball_beside":
        parts = [sphere_points([-0.08, 0.0, R_BALL], R_BALL, dx / 2), box_points([-0.03, -0.03, 0.0],
                                                                                 [0.03, 0.03, a], dx / 2)]
        models = ("rigid", "elastic")
    else:
        top = 2 * R_BALL
        upper = (box_points([-a / 2, -a / 2, top], [a / 2, a / 2, top + a], dx / 2) if case == "jelly_on_ball"
                 else sphere_points([0.0, 0.0, top + 0.03], 0.03, dx / 2))
        parts = [upper, sphere_points([0.0, 0.0, R_BALL], R_BALL, dx / 2)]
        models = ("elastic", "rigid")
    x = np.concatenate([p for p, _ in parts])
    v = np.zeros_like(x)
    if case == "ball_beside":
        v[:len(parts[0][0])] = [v0, 0.0, 0.0]
    rhos = [rho_ball if m == "rigid" else 1000.0 for m in models]
    mats = [Material("jelly", model=m, E=E, nu=0.3, rho=r) for m, r in zip(models, rhos)]
    lo = np.array([-0.20, -SIDE / 2, -3 * dx])
    s = SimSetup(x=x, v=v, p_vol=np.concatenate([np.full(len(p), pv) for p, pv in parts]),
                 body_id=np.concatenate([np.full(len(p), k) for k, (p, _) in enumerate(parts)]), materials=mats,
                 gravity=np.array([0.0, 0.0, -9.81]), domain_lo=lo, domain_hi=lo + SIDE, n_grid=n_grid,
                 frame_dt=1.0 / 60.0, boundaries=[Boundary("ground", height=0.0, friction=0.0)])
    s.n_render = 0
    return s


def measure(engine: str, case: str, n_grid: int = 32, E: float = 1.0e5, rho_ball: float = 1000.0,
            v0: float = 0.5, roll: bool = False) -> dict:
    """The figures of the module notes for ``case`` on ``engine`` (the switch as it stands; round 71: the engine option
    ``roll_contact``, on by default, set to ``roll``: off, the contacts this study measured)."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    s = round_setup(case, n_grid, E, rho_ball, v0)
    s = s.replace(options={**s.options, "roll_contact": bool(roll)})
    dx = s.dx
    body = np.asarray(s.body_id)
    x0 = np.asarray(s.x, float)
    e = build_engine(get_engine(engine), s)
    out = {}
    if case == "ball_beside":
        depth = 0.0
        for _ in range(round(0.5 / s.frame_dt)):
            e.step_frame()
            x = e.positions().astype(float)
            c = x[body == 0].mean(0)
            depth = max(depth, float(R_BALL - np.linalg.norm(x[body == 1] - c, axis=1).min()))
        vv = e.velocities().astype(float)
        out.update(depth=depth / dx, v_ball=float(vv[body == 0, 0].mean()), v_cube=float(vv[body == 1, 0].mean()),
                   x_ball=float(c[0]))
    else:
        start = x0[body == 0, 2].min() - x0[body == 1, 2].max()
        gaps = {}
        for f in range(round(T1 / s.frame_dt)):
            e.step_frame()
            t = round((f + 1) * s.frame_dt, 6)
            if abs(t - T0) < 1e-6 or abs(t - T1) < 1e-6:
                x = e.positions().astype(float)
                gaps[t] = x[body == 0, 2].min() - x[body == 1, 2].max()
        out.update(settle=(gaps[T0] - start) / dx, drift=(gaps[T1] - gaps[T0]) / dx,
                   ball_z=float(e.positions().astype(float)[body == 1, 2].mean() - x0[body == 1, 2].mean()) / dx)
    e.close()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--case", nargs="+", default=["jelly_on_ball", "jball_on_ball", "ball_beside"])
    ap.add_argument("--points", type=int, nargs="+", default=[1, 0])
    ap.add_argument("--n-grid", type=int, default=32)
    ap.add_argument("--rho-ball", type=float, default=1000.0)
    ap.add_argument("--v0", type=float, default=0.5, help="ball_beside: the ball's speed (m/s)")
    ap.add_argument("--set", nargs="*", default=[], help="NAME=VALUE on gasp_core.mpm.rigid_sdf (round 67: "
                    "GRID_PASSES=4, the grid's constraint; broken variants)")
    a = ap.parse_args()
    from gasp_core.mpm import rigid_sdf
    for kv in a.set:
        k, val = kv.split("=")
        setattr(rigid_sdf, k, type(getattr(rigid_sdf, k))(float(val)))
    for case in a.case:
        for p in a.points:
            rigid_sdf.POINT_CONTACT = bool(p)
            r = measure(a.engine, case, a.n_grid, rho_ball=a.rho_ball, v0=a.v0)
            print(f"| {a.engine} | {case} | rho_ball {a.rho_ball:g} | v0 {a.v0:g} | points {p} | "
                  + " | ".join(f"{k} {v:+.3f}" for k, v in r.items()) + " |", flush=True)


if __name__ == "__main__":
    main()
