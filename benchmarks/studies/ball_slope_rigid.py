"""Round 65 (issue 67 items 2 and 4, branch rollpair): a rigid ball rolling down a rigid slab tilted 20 degrees, and
a rigid block sliding down it, against Coulomb and Newton.

The slope is set by gravity (``g`` tilted ``theta`` about y, towards +x): the 32 x 16 x 3 cm slab (rigid) rests on a
ground of friction 1 (above ``tan theta``: it stays), and on it a ball of radius ``R`` (rho 1000, mu 0.5 for both
bodies) or a 6 x 6 x 3 cm block (mu 0.3 < ``tan theta``) starts at rest. A solid ball rolls without slip at ``a = g
sin theta / (1 + I / (m R^2))`` (``(5/7) g sin theta`` for ``I = 0.4 m R^2``; ``I`` here the engines' own: the
lattice's, plus APIC's ``m dx^2 / 2`` to round 66, ``gasp_core.mpm.rigid.APIC_SPIN``); the block slides at ``g (sin theta - mu cos theta)`` and does not tip (its
spin stays 0). Printed: the body's acceleration along the slope relative to the slab (m/s^2; a line fitted to its
speed from 0.05 to ``T`` s), the closed form, against ``(5/7) g sin theta`` (the ball), the body's spin at ``T``
(rad/s, about y) and, for the ball, ``w R / v`` at ``T`` (``R`` its contact radius: 1 rolling without slip).

    python benchmarks/studies/ball_slope_rigid.py --engine warp_mpm --n-grid 32 48 --radius 0.03 0.045

Figures: ``docs/rigid.md`` ("Round 65: rolling between rigid bodies", "Round 67: the rigid body's own inertia").
"""
from __future__ import annotations

import argparse

import numpy as np

SIDE = 0.48
G = 9.81


def slope_setup(n_grid: int, body: str = "ball", R: float = 0.03, theta: float = 20.0, mu: float = 0.5):
    """The scene of the module notes: body 0 the ball (``body`` "ball", radius ``R``) or the block, body 1 the slab."""
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    from gasp_core.testing.helpers import box_points, sphere_points
    dx = SIDE / n_grid
    if body == "ball":
        xb, pvb = sphere_points([-0.06, 0.0, 0.03 + R], R, dx / 2)
    else:
        xb, pvb = box_points([-0.09, -0.03, 0.03], [-0.03, 0.03, 0.06], dx / 2)
    xs, pvs = box_points([-0.12, -0.08, 0.0], [0.20, 0.08, 0.03], dx / 2)
    th = np.radians(theta)
    mats = [Material("jelly", model="rigid", E=1.0e5, nu=0.3, rho=1000.0, friction=mu) for _ in range(2)]
    lo = np.array([-0.20, -SIDE / 2, -3 * dx])
    s = SimSetup(x=np.concatenate([xb, xs]), v=0.0, p_vol=np.r_[np.full(len(xb), pvb), np.full(len(xs), pvs)],
                 body_id=np.r_[np.zeros(len(xb), int), np.ones(len(xs), int)], materials=mats,
                 gravity=G * np.array([np.sin(th), 0.0, -np.cos(th)]), domain_lo=lo, domain_hi=lo + SIDE,
                 n_grid=n_grid, frame_dt=1.0 / 240.0, boundaries=[Boundary("ground", height=0.0, friction=1.0)])
    s.n_render = 0
    return s


def closed_form(s, body: str, theta: float, mu: float) -> float:
    """The acceleration along the slope (m/s^2) of the module notes (the ball's contact radius from its points'
    extent, its inertia the engines' own)."""
    th = np.radians(theta)
    if body != "ball":
        return G * (np.sin(th) - mu * np.cos(th))
    x, pm, b = np.asarray(s.x, float), np.asarray(s.p_mass, float), np.asarray(s.body_id)
    xb, mb = x[b == 0], pm[b == 0]
    r = xb - (xb * mb[:, None]).sum(0) / mb.sum()
    from gasp_core.mpm.rigid import affine_dx
    inertia = float(np.sum(mb * (r[:, 0] ** 2 + r[:, 2] ** 2))) + 0.5 * affine_dx(s.dx) ** 2 * mb.sum()
    R = contact_radius(s)
    return G * np.sin(th) / (1.0 + inertia / (mb.sum() * R * R))


def contact_radius(s) -> float:
    """The ball's (body 0's) radius from its points' extent plus half a spacing, m."""
    xb = np.asarray(s.x, float)[np.asarray(s.body_id) == 0]
    return 0.5 * float(np.ptp(xb[:, 2]) + s.dx / 2)


def measure_slope(engine: str, n_grid: int, body: str = "ball", R: float = 0.03, theta: float = 20.0,
                  mu: float = 0.5, T: float = 0.3) -> dict:
    """``{"a": m/s^2, "closed": m/s^2, "spin": rad/s, "slab": m/s, "roll": w R / v at T}`` of :func:`slope_setup` run for ``T`` s."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    s = slope_setup(n_grid, body, R, theta, mu)
    b = np.asarray(s.body_id)
    e = build_engine(get_engine(engine), s)
    t, u, w, vs = [], [], 0.0, 0.0
    for k in range(round(T / s.frame_dt)):
        e.step_frame()
        X, V = e.positions().astype(float), e.velocities().astype(float)
        vs = float(V[b == 1, 0].mean())
        t.append((k + 1) * s.frame_dt)
        u.append(float(V[b == 0, 0].mean()) - vs)
        r = X[b == 0] - X[b == 0].mean(0)
        L = np.cross(r, V[b == 0] - V[b == 0].mean(0)).sum(0)
        w = float(np.linalg.solve(np.sum(r * r) * np.eye(3) - r.T @ r, L)[1])
    t, u = np.array(t), np.array(u)
    sel = t >= 0.05
    return {"a": float(np.polyfit(t[sel], u[sel], 1)[0]), "closed": closed_form(s, body, theta, mu), "spin": w,
            "slab": vs, "roll": w * contact_radius(s) / u[-1] if body == "ball" else float("nan")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--n-grid", type=int, nargs="+", default=[32])
    ap.add_argument("--radius", type=float, nargs="+", default=[0.03])
    ap.add_argument("--T", type=float, default=0.3)
    ap.add_argument("--apic-spin", type=float, default=None,
                    help="gasp_core.mpm.rigid.APIC_SPIN for this run (1: the engines to round 66)")
    a = ap.parse_args()
    if a.apic_spin is not None:
        import gasp_core.mpm.rigid as core_rigid
        core_rigid.APIC_SPIN = a.apic_spin
    print("| engine | n_grid | body | a (m/s^2) | closed form | error | vs 5/7 g sin | spin at T (rad/s) | w R / v "
          "| slab (m/s) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    five7 = 5.0 / 7.0 * G * np.sin(np.radians(20.0))
    for n in a.n_grid:
        cases = [("ball", R, 0.5) for R in a.radius] + [("block", 0.0, 0.3)]
        for body, R, mu in cases:
            r = measure_slope(a.engine, n, body, R, 20.0, mu, a.T)
            name = f"ball {100 * R:g} cm" if body == "ball" else "block, mu 0.3"
            vs = f"{100 * (r['a'] / five7 - 1):+.2f} %" if body == "ball" else ""
            roll = f"{r['roll']:.4f}" if body == "ball" else ""
            print(f"| {a.engine} | {n} | {name} | {r['a']:.4f} | {r['closed']:.4f} | {100 * (r['a'] / r['closed'] - 1):+.2f} % "
                  f"| {vs} | {r['spin']:+.3f} | {roll} | {r['slab']:+.4f} |", flush=True)


if __name__ == "__main__":
    main()
