"""Issue 67 round 65 (lead, found and not fixed): a rigid ball rolling along a soft slab.

A rigid ball (radius ``R``, jelly rho 1000, friction ``mu``) given rolling without slip at ``v0`` along +x (its
points' velocities ``v0 + w x r`` with ``w R = v0``, and APIC's ``C`` the cross-product matrix of ``w``, as the
scene's ``angular_velocity`` sets it: ``gasp_core.prepare.assembly``) on a 32 x 16 x 3 cm slab (``--slab elastic``:
jelly E 1e5 Pa, nu 0.3; ``rigid``: the same slab rigid) lying on a frictionless ground. An elastic slab returns what
the ball's front presses into it at the ball's back: the ball should roll on as on the rigid slab (Hertz's sink of
a 3 cm ball's weight into E 1e5 Pa is 1.2 mm, 0.08 dx at n_grid 32), and a frictionless contact, whose forces pass
through a ball's centre, cannot change its spin.

Printed per case: the ball's speed ``v`` and spin ``w R`` (m/s; from its points' momentum and angular momentum about
its centre) at the start and after ``T`` s, and the rise of its centre (mm; over its height after the first frame).

    python benchmarks/studies/ball_roll_soft.py --engine warp_mpm --n-grid 32 --mu 0.5 --slab elastic

Round 66: ``--points 1`` takes the rigid collider's contact by the soft points against the ball's shape
(``gasp_core.mpm.rigid_sdf.POINT_CONTACT``; warp_mpm), ``--set NAME=VALUE`` a constant of ``rigid_sdf`` (a broken
variant: ``REACT_POINTS=0``, ``BIAS=0``, ``FRICTION_CAP=0``).

Round 67: ``--set GRID_PASSES=4`` the contact as a constraint of the grid (``PATCH=0.25`` the points as patches,
``STIFFNESS=1 BIAS=1`` their compliance), ``--seat`` the ball set with its contact's skin on the slab's top points
(no drop at the start), ``--E`` the slab's Young's modulus.

Round 70: ``--roll`` the engine option ``roll_contact`` (``gasp_core.mpm.roll_contact``: the ball's exact sphere, the
soft points' patches, friction one impulse a patch; warp_mpm). Round 71: the option is on by default; without
``--roll`` this study sets it off (the band, or with ``--points 1`` the point contact), as its figures were taken.

Figures: ``docs/rigid.md`` ("Round 65: a ball rolling on a soft slab", "Round 66: the point contact on a ball",
"Round 67: the point contact as a constraint of the grid").
"""
from __future__ import annotations

import argparse

import numpy as np

SIDE = 0.48


def roll_setup(n_grid: int, R: float = 0.03, v0: float = 0.5, mu: float = 0.5, slab: str = "elastic",
               spin: float = 1.0, block: bool = False, seat: bool = False, E: float = 1.0e5):
    """The scene of the module notes (body 0 the ball, body 1 the slab); ``spin`` the given ``w R / v0`` (1: rolling,
    0: thrown sliding); ``block``: a third body, a rigid 4 x 4 x 3 cm block resting on the slab's far end (round
    65: three bodies take the many-body solve, ``gasp_core.mpm.rigid_pairs``)."""
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    from gasp_core.testing.helpers import box_points, sphere_points
    dx = SIDE / n_grid
    c0 = np.array([-0.08, 0.0, 0.03 + R])
    xb, pvb = sphere_points(c0, R, dx / 2)
    if seat:   # round 67: the ball's contact surface (its shape's skin) on the slab's top points, not its points
        c0[2] -= seat_drop(xb - c0, R, dx)
        xb, pvb = sphere_points(c0, R, dx / 2)
    xs, pvs = box_points([-0.12, -0.08, 0.0], [0.20, 0.08, 0.03], dx / 2)
    w = np.array([0.0, spin * v0 / R, 0.0])
    parts = [xb, xs] + ([box_points([0.12, -0.02, 0.03], [0.16, 0.02, 0.06], dx / 2)[0]] if block else [])
    x = np.concatenate(parts)
    v = np.zeros_like(x)
    v[:len(xb)] = np.array([v0, 0.0, 0.0]) + np.cross(w, xb - c0)
    C = np.zeros((len(x), 3, 3))
    C[:len(xb)] = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    mats = [Material("jelly", model="rigid", E=1.0e5, nu=0.3, rho=1000.0, friction=mu),
            Material("jelly", model=slab, E=E, nu=0.3, rho=1000.0, friction=mu)]
    mats += mats[:1] if block else []
    lo = np.array([-0.20, -SIDE / 2, -3 * dx])
    s = SimSetup(x=x, v=v, p_vol=np.r_[np.full(len(xb), pvb), np.full(len(x) - len(xb), pvs)],
                 body_id=np.concatenate([np.full(len(p), k) for k, p in enumerate(parts)]), materials=mats,
                 gravity=np.array([0.0, 0.0, -9.81]), domain_lo=lo, domain_hi=lo + SIDE, n_grid=n_grid,
                 frame_dt=1.0 / 240.0, boundaries=[Boundary("ground", height=0.0, friction=0.0)], C=C)
    s.n_render = 0
    return s


def seat_drop(X0: np.ndarray, R: float, dx: float) -> float:
    """Round 67: how far (m) the ball given by its points ``X0`` (about its centre) falls at the start before its
    point contact's skin (``rigid_sdf.SKIN`` cells beyond its shape, ``rigid_sdf.body_sdf``) meets the slab's top
    points (half a spacing, ``dx / 4``, under the slab's top; the ball set ``R`` above it)."""
    from gasp_core.mpm.rigid_sdf import SKIN, body_sdf, sdf_read
    sdf = body_sdf(X0, dx)
    zs = np.linspace(X0[:, 2].min() - dx, X0[:, 2].min(), 401)
    ph = np.array([sdf_read(sdf, np.array([0.0, 0.0, z]))[0] for z in zs])
    z_skin = float(zs[np.argmin(np.abs(ph - SKIN * dx))])
    return R + z_skin + dx / 4


def ball_state(X: np.ndarray, V: np.ndarray, R: float) -> tuple[np.ndarray, float, float]:
    """The ball's centre (3,) m, its speed along x (m/s) and its spin about y times ``R`` (m/s) from its points
    (equal masses)."""
    c = X.mean(0)
    r = X - c
    L = np.cross(r, V - V.mean(0)).sum(0)
    inertia = np.sum(r * r) * np.eye(3) - r.T @ r
    return c, float(V.mean(0)[0]), float(np.linalg.solve(inertia, L)[1] * R)


def measure_roll(engine: str, n_grid: int, R: float = 0.03, v0: float = 0.5, mu: float = 0.5,
                 slab: str = "elastic", T: float = 0.2, spin: float = 1.0, block: bool = False,
                 seat: bool = False, E: float = 1.0e5, options: dict | None = None) -> dict:
    """``{"v": (first frame, last), "spin": (first, last) (w R, m/s), "rise": mm}`` of :func:`roll_setup` run for
    ``T`` s on ``engine`` (round 70: with the engine ``options``, e.g. ``{"roll_contact": True}``)."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    s = roll_setup(n_grid, R, v0, mu, slab, spin, block, seat, E)
    if options:
        s = s.replace(options={**s.options, **options})
    nb = int(np.sum(np.asarray(s.body_id) == 0))
    e = build_engine(get_engine(engine), s)
    rows = []
    for _ in range(round(T / s.frame_dt)):
        e.step_frame()
        rows.append(ball_state(e.positions().astype(float)[:nb], e.velocities().astype(float)[:nb], R))
    return {"v": (rows[0][1], rows[-1][1]), "spin": (rows[0][2], rows[-1][2]),
            "rise": 1e3 * (rows[-1][0][2] - rows[0][0][2])}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--n-grid", type=int, nargs="+", default=[32])
    ap.add_argument("--mu", type=float, nargs="+", default=[0.5])
    ap.add_argument("--slab", nargs="+", default=["elastic", "rigid"])
    ap.add_argument("--radius", type=float, nargs="+", default=[0.03])
    ap.add_argument("--T", type=float, default=0.2)
    ap.add_argument("--spin", type=float, default=1.0, help="the given w R / v0 (0: thrown sliding)")
    ap.add_argument("--block", action="store_true", help="a third body: a rigid block on the slab's far end")
    ap.add_argument("--seat", action="store_true", help="round 67: the ball set with its contact's skin on the "
                    "slab's top points (no drop at the start; rigid_sdf's shape)")
    ap.add_argument("--E", type=float, default=1.0e5, help="round 67: the elastic slab's Young's modulus (Pa)")
    ap.add_argument("--points", type=int, default=None, help="round 66: rigid_sdf.POINT_CONTACT (1 on, 0 off)")
    ap.add_argument("--set", nargs="*", default=[], help="NAME=VALUE on gasp_core.mpm.rigid_sdf (broken variants)")
    ap.add_argument("--roll", action="store_true", help="round 70: the engine option roll_contact (the exact sphere's "
                    "contact, gasp_core.mpm.roll_contact)")
    a = ap.parse_args()
    from gasp_core.mpm import rigid_sdf
    if a.points is not None:
        rigid_sdf.POINT_CONTACT = bool(a.points)
    for kv in a.set:
        k, val = kv.split("=")
        setattr(rigid_sdf, k, type(getattr(rigid_sdf, k))(float(val)))
    print("| engine | n_grid | R (cm) | slab | mu | v (m/s): start -> end | w R (m/s): start -> end | rise (mm) |")
    print("|---|---|---|---|---|---|---|---|")
    for n in a.n_grid:
        for R in a.radius:
            for slab in a.slab:
                for mu in a.mu:
                    r = measure_roll(a.engine, n, R, 0.5, mu, slab, a.T, a.spin, a.block, a.seat, a.E,
                                     {"roll_contact": bool(a.roll)})
                    print(f"| {a.engine} | {n} | {100 * R:g} | {slab} | {mu:g} | {r['v'][0]:.3f} -> {r['v'][1]:.3f} "
                          f"| {r['spin'][0]:.3f} -> {r['spin'][1]:.3f} | {r['rise']:+.2f} |", flush=True)


if __name__ == "__main__":
    main()
