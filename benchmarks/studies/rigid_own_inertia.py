"""Round 67 (issue 67 item 2): the rigid body's own inertia (``gasp_core.mpm.rigid.APIC_SPIN``), the checks that
decide it.

To round 66 the engines' rigid projection gave every point ``C = [w]`` (APIC's affine part), which books each point's
``m dx^2 / 2 w`` of angular momentum, so the body turned with the lattice's inertia plus ``M dx^2 / 2``: a ball of 2
cells' radius rolled 7.3 % slower than ``5/7 g sin``. With ``APIC_SPIN`` 0 the points carry no affine spin
(``C = 0`` after the projection), the grid holds the body's angular momentum in the points' velocities alone and the
body turns with the lattice's inertia. Three checks, each on ``--engine`` and with ``--apic-spin`` (1: the engines to
round 66):

* ``spin``: a rigid 6 x 4 x 2 cm box and a 3 cm ball (rho 1000), no gravity, no ground, n_grid 32, moving at 0.1 m/s
  and spun at 10 rad/s about the box's long axis, its short axis (principal) and ``(1, 2, 3) / |.|`` (the box
  tumbles), for 1 s (60 frames): the relative change of the angular momentum about the centre (the points'
  ``sum m r x v`` plus ``APIC_SPIN M dx^2 / 2 w``: the body's booked; Euler's equations keep it) and of the kinetic
  energy (``(M V^2 + w . L) / 2``), and of ``|w|`` for the principal spins.
* ``thrown``: ``ball_roll_soft.py``'s ball (R 3 and 4.5 cm, n_grid 32 and 48) thrown sliding at 0.5 m/s (mu 0.5) on
  the free rigid slab (frictionless ground), 0.1 s: its speed and ``w R`` against ``J = v0 / (1/m + 1/M + R^2/I)``
  with the lattice's ``I`` (and ``+ M dx^2 / 2`` with ``--apic-spin 1``), and the horizontal momentum of ball and
  slab (kg m/s) relative to the start's.
* ``rest``: the 6 x 6 x 3 cm block and the 3 cm ball on the slab at rest (mu 0.5, the slab on a ground of friction 1),
  0.5 s: the largest speed of their points at the end (m/s) and the ball's drift (mm).

    python benchmarks/studies/rigid_own_inertia.py --engine warp_mpm --check spin thrown rest [--apic-spin 1]

Figures: ``docs/rigid.md`` ("Round 67: the rigid body's own inertia").
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
SIDE = 0.48


def spin_setup(shape: str, axis, n_grid: int = 32, w0: float = 10.0, V: float = 0.1):
    """A rigid box (6 x 4 x 2 cm, long axis x) or ball (R 3 cm) at the domain's centre moving at ``V`` along x and
    spinning at ``w0`` about ``axis``; no gravity, no boundary."""
    from gasp_core.mpm.rigid import skew
    from gasp_core.seam.setup import Material, SimSetup
    from gasp_core.testing.helpers import box_points, sphere_points
    dx = SIDE / n_grid
    c = np.zeros(3)
    if shape == "box":
        x, pv = box_points(c - [0.03, 0.02, 0.01], c + [0.03, 0.02, 0.01], dx / 2)
    else:
        x, pv = sphere_points(c, 0.03, dx / 2)
    w = w0 * np.asarray(axis, float) / np.linalg.norm(axis)
    v = np.array([V, 0.0, 0.0]) + np.cross(w, x - x.mean(0))
    lo = np.full(3, -SIDE / 2)
    s = SimSetup(x=x, v=v, p_vol=pv, body_id=0, materials=[Material("jelly", model="rigid", E=1e5, nu=0.3, rho=1000.0)],
                 gravity=np.zeros(3), domain_lo=lo, domain_hi=lo + SIDE, n_grid=n_grid, frame_dt=1.0 / 60.0,
                 boundaries=[], C=np.broadcast_to(skew(w), (len(x), 3, 3)).copy())
    s.n_render = 0
    return s


def body_momenta(X, V, m, dx_aff: float):
    """``(L about the centre with APIC_SPIN's M dxa^2 / 2 w, w, kinetic energy)`` of one rigid body's points."""
    M = m.sum()
    c = (m[:, None] * X).sum(0) / M
    P = (m[:, None] * V).sum(0)
    r = X - c
    Lp = (m[:, None] * np.cross(r, V - P / M)).sum(0)
    inertia = np.eye(3) * (m * (r * r).sum(1)).sum() - np.einsum("n,ni,nj->ij", m, r, r)
    w = np.linalg.solve(inertia, Lp)
    L = Lp + 0.5 * dx_aff ** 2 * M * w
    return L, w, 0.5 * (P @ P / M + w @ L)


def measure_spin(engine: str, shape: str, axis, T: float = 1.0) -> dict:
    """``{"dL": |L(T) - L(0)| / |L(0)|, "dE": E(T) / E(0) - 1, "dw": |w(T)| / |w(0)| - 1, "dV": ...}`` of
    :func:`spin_setup` (the first frame's values as the start)."""
    from gasp_core.mpm.rigid import affine_dx
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    s = spin_setup(shape, axis)
    m = np.asarray(s.p_mass, float)
    e = build_engine(get_engine(engine), s)
    rows = []
    for _ in range(round(T / s.frame_dt)):
        e.step_frame()
        X, V = e.positions().astype(float), e.velocities().astype(float)
        rows.append(body_momenta(X, V, m, affine_dx(s.dx)) + ((m[:, None] * V).sum(0) / m.sum(),))
    (L0, w0, E0, V0), (L1, w1, E1, V1) = rows[0], rows[-1]
    return {"dL": float(np.linalg.norm(L1 - L0) / np.linalg.norm(L0)), "dE": float(E1 / E0 - 1.0),
            "dw": float(np.linalg.norm(w1) / np.linalg.norm(w0) - 1.0), "w0": float(np.linalg.norm(w0)),
            "dV": float(np.linalg.norm(V1 - V0))}


def thrown_closed(s, v0: float, radius: float) -> tuple[float, float]:
    """``(v, w radius)`` of the ball (body 0) thrown sliding at ``v0`` on the free slab once it rolls, with the
    engines' inertia (the lattice's plus ``APIC_SPIN M dx^2 / 2``)."""
    from gasp_core.mpm.rigid import affine_dx
    x, pm, body = np.asarray(s.x, float), np.asarray(s.p_mass, float), np.asarray(s.body_id)
    xb, mb = x[body == 0], pm[body == 0]
    r = xb - (xb * mb[:, None]).sum(0) / mb.sum()
    m, M = float(mb.sum()), float(pm[body != 0].sum())
    inertia = float(np.sum(mb * (r[:, 0] ** 2 + r[:, 2] ** 2))) + 0.5 * affine_dx(s.dx) ** 2 * m
    R = 0.5 * float(xb[:, 2].max() - xb[:, 2].min() + s.dx / 2)
    J = v0 / (1.0 / m + 1.0 / M + R * R / inertia)
    return v0 - J / m, J * R * radius / inertia


def measure_thrown(engine: str, n_grid: int, R: float, T: float = 0.1) -> dict:
    """``{"v", "wR", "v_closed", "wR_closed", "dP"}`` of the thrown ball (the module notes)."""
    from ball_roll_soft import ball_state, roll_setup
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    s = roll_setup(n_grid, R, 0.5, 0.5, "rigid", 0.0)
    m, b = np.asarray(s.p_mass, float), np.asarray(s.body_id)
    P0 = float(m @ np.asarray(s.v, float)[:, 0]) if np.ndim(s.v) == 2 else 0.0
    e = build_engine(get_engine(engine), s)
    for _ in range(round(T / s.frame_dt)):
        e.step_frame()
    X, V = e.positions().astype(float), e.velocities().astype(float)
    _, v, wR = ball_state(X[b == 0], V[b == 0], R)
    vc, wc = thrown_closed(s, 0.5, R)
    return {"v": v, "wR": wR, "v_closed": vc, "wR_closed": wc, "dP": float(m @ V[:, 0]) - P0, "P0": P0}


def measure_rest(engine: str, body: str, T: float = 0.5) -> dict:
    """``{"vmax": m/s, "drift": mm}`` of ``ball_slope_rigid.slope_setup`` untilted (0 degrees) with ``body`` on it."""
    from ball_slope_rigid import slope_setup
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    s = slope_setup(32, body, 0.03, 0.0, 0.5)
    b = np.asarray(s.body_id)
    e = build_engine(get_engine(engine), s)
    e.step_frame()
    X0 = e.positions().astype(float)[b == 0].mean(0)
    for _ in range(round(T / s.frame_dt) - 1):
        e.step_frame()
    X, V = e.positions().astype(float), e.velocities().astype(float)
    return {"vmax": float(np.linalg.norm(V, axis=1).max()), "drift": 1e3 * float(np.linalg.norm(X[b == 0].mean(0) - X0))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--check", nargs="+", default=["spin", "thrown", "rest"])
    ap.add_argument("--apic-spin", type=float, default=None, help="gasp_core.mpm.rigid.APIC_SPIN (1: to round 66)")
    a = ap.parse_args()
    import gasp_core.mpm.rigid as core_rigid
    if a.apic_spin is not None:
        core_rigid.APIC_SPIN = a.apic_spin
    tag = f"{a.engine}, APIC_SPIN {core_rigid.APIC_SPIN:g}"
    if "spin" in a.check:
        print(f"\n{tag}: free spin, 1 s\n\n| body | axis | w (rad/s) | L change | energy change | |w| change | V change (m/s) |")
        print("|---|---|---|---|---|---|---|")
        for shape, axis in [("box", (1, 0, 0)), ("box", (0, 0, 1)), ("box", (1, 2, 3)), ("ball", (1, 2, 3))]:
            r = measure_spin(a.engine, shape, axis)
            print(f"| {shape} | {axis} | {r['w0']:.4f} | {r['dL']:.2e} | {r['dE']:+.2e} | {r['dw']:+.2e} | {r['dV']:.1e} |",
                  flush=True)
    if "thrown" in a.check:
        print(f"\n{tag}: thrown sliding on the free slab, 0.1 s\n\n| n_grid | R (cm) | v | closed | err | w R | closed "
              "| err | momentum change (kg m/s) | of |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for n in (32, 48):
            for R in (0.03, 0.045):
                r = measure_thrown(a.engine, n, R)
                print(f"| {n} | {100 * R:g} | {r['v']:.4f} | {r['v_closed']:.4f} | {100 * (r['v'] / r['v_closed'] - 1):+.1f} % "
                      f"| {r['wR']:.4f} | {r['wR_closed']:.4f} | {100 * (r['wR'] / r['wR_closed'] - 1):+.1f} % "
                      f"| {r['dP']:+.1e} | {r['P0']:.4f} |", flush=True)
    if "rest" in a.check:
        print(f"\n{tag}: at rest on the slab, 0.5 s\n\n| body | largest speed (m/s) | drift (mm) |\n|---|---|---|")
        for body in ("ball", "block"):
            r = measure_rest(a.engine, body)
            print(f"| {body} | {r['vmax']:.1e} | {r['drift']:.3f} |", flush=True)


if __name__ == "__main__":
    main()
