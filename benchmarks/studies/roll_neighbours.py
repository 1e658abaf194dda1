"""Round 71 (issue 67 items 2 and 4, ``docs/rigid.md`` "Round 71: roll_contact on neighbours' scenes"): round 70's
engine option ``roll_contact`` (``gasp_core.mpm.roll_contact``) on scenes it was not tuned on, each with the option
on and off, on either engine.

Scenes (jelly E 1e5 Pa, nu 0.3, rho 1000 unless said; a cube domain of 0.48 m; the ground at 0):

* ``rest``: a 6 cm jelly cube resting on a rigid ball (R 4.5 cm, rho ``--rho-ball``) that rests on a frictionless
  ground (``soft_on_round.py``'s ``jelly_on_ball``; frames of 1/60 s, 1 s). Figures: the gap's settle (0 to 0.3 s) and
  drift (0.3 to 1 s, dx, as ``tests/test_soft_on_rigid_rest.py``); the deepest jelly point inside the sphere over the
  last 0.5 s (dx); the two bodies' mass centres' travel over the last 0.3 s (mm); statics: the ground's reaction over
  the system's weight, ``1 + dP_z / (W T)`` over 0.5-1 s, and the ball's contact force on the jelly over its weight,
  the same of the jelly alone (each 1 at rest); Hertz's dent of the jelly's face under its weight on the ball (dx, to
  set against the settle).
* ``two``: two rigid balls on one jelly slab (32 x 24 x 3 cm, held by a ground of friction 1; ``ball_roll_soft.py``'s
  scene widened; frames of 1/240 s, 0.1 s as round 70's thrown ball): R 3 cm at y -6 cm rolling without slip at 0.5 m/s along +x (its speed and
  ``w R`` at the end over the first frame's: rolling on a flat slab keeps both), R 4.5 cm at y +6 cm thrown sliding
  at 0.5 m/s with no spin (its speed and ``w R`` at the end over Coulomb's rolling ``v0 / (1 + M R^2 / I)``, 5/7 v0);
  each against the same ball alone on the same slab (the cross-talk between the two pairs' patches).
* ``slope``: a round rigid body (``--shape`` ball or cyl: a cylinder along y, length 6 cm) starting at rest on the
  jelly slab (32 x 16 x 3 cm) lying on a ground of friction 1, gravity tilted ``--theta`` degrees about y (towards
  +x): the body's acceleration along the slope relative to the slab (a line fitted to its speed from 0.05 s to T),
  against rolling without slip, ``g sin theta / (1 + I / (M R^2))`` with the engine's own ``I`` (from its points:
  5/7 g sin theta for a ball, 2/3 for a cylinder), and ``w R / v`` at the end.
* ``drop``: a rigid ball (R 3 cm) dropped from ``--height`` (its lowest point above the slab's face) onto the jelly
  slab on a frictionless ground (frames of 1/240 s, 0.4 s): the mechanical energy (both bodies' kinetic with the
  slab's APIC part left out, and ``m g z``; the slab's stored energy left out, so this can only fall if no energy is
  made) over its start, the highest rebound of the ball's lowest point above the slab's face after the first
  contact over the drop height, the deepest slab point inside the sphere (dx).

    python benchmarks/studies/roll_neighbours.py --engine warp_mpm taichi_mpm --scene rest two slope drop --roll 1 0

``--set NAME=VALUE`` sets a constant of ``gasp_core.mpm.roll_contact`` or else ``gasp_core.mpm.rigid_sdf`` (a broken
variant: ``EXACT=0``, ``FALLBACK=0``, ``STIFFNESS=0``, ``SURFACE_ARM=0``, ``BIAS=4``).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

SIDE = 0.48
G = 9.81


def cylinder_points(c, R: float, L: float, spacing: float) -> tuple[np.ndarray, float]:
    """Lattice points inside a cylinder of radius ``R`` and length ``L`` along y, centred on ``c``; ``p_vol`` its
    volume over their number."""
    from gasp_core.testing.helpers import box_points
    c = np.asarray(c, float)
    x, _ = box_points(c - [R, L / 2, R], c + [R, L / 2, R], spacing)
    x = x[(x[:, 0] - c[0]) ** 2 + (x[:, 2] - c[2]) ** 2 <= R * R]
    return x, np.pi * R * R * L / len(x)


def body_points(shape: str, c, R: float, spacing: float) -> tuple[np.ndarray, float]:
    """A rigid body's points: ``ball`` (radius R), ``cyl`` (radius R, length 6 cm along y; ``cylL``: L cm), ``ellipsoid`` (semi-axes
    R, R, 0.7 R), ``cube`` (side 2 R)."""
    from gasp_core.testing.helpers import box_points, sphere_points
    c = np.asarray(c, float)
    if shape == "ball":
        return sphere_points(c, R, spacing)
    if shape.startswith("cyl"):   # round 72: "cyl9" a cylinder 9 cm long (roll_cylinder.py)
        return cylinder_points(c, R, float(shape[3:]) / 100.0 if len(shape) > 3 else 0.06, spacing)
    if shape == "ellipsoid":
        x, _ = box_points(c - R, c + R, spacing)
        q = (x - c) / [R, R, 0.7 * R]
        x = x[(q * q).sum(1) <= 1.0]
        return x, 4.0 / 3.0 * np.pi * 0.7 * R ** 3 / len(x)
    return box_points(c - R, c + R, spacing)


def slab_setup(n_grid: int, bodies: list, mu: float = 0.5, theta: float = 0.0, width: float = 0.16,
               frame_dt: float = 1.0 / 240.0, E: float = 1.0e5, slab: bool = True, ground_mu: float | None = None):
    """Rigid bodies (``(shape, R, (x, y), v0, spin)``: set ``R`` above the slab's face, rolling along +x at ``v0`` with
    ``w R = spin v0``) on a 32 x ``width`` x 3 cm jelly slab (the last body) on the ground; gravity tilted ``theta``
    degrees about y (the ground's friction ``ground_mu``; None: 1 where tilted, else 0). ``slab`` False: no slab, the
    bodies on the ground."""
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    from gasp_core.testing.helpers import box_points
    dx = SIDE / n_grid
    top = 0.03 if slab else 0.0
    parts, vs, Cs, vols = [], [], [], []
    for shape, R, (px, py), v0, spin in bodies:
        c0 = np.array([px, py, top + R])
        x, pv = body_points(shape, c0, R, dx / 2)
        w = np.array([0.0, spin * v0 / R, 0.0])
        parts.append(x)
        vs.append(np.array([v0, 0.0, 0.0]) + np.cross(w, x - c0))
        Cs.append(np.broadcast_to(np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]]),
                                  (len(x), 3, 3)))
        vols.append(np.full(len(x), pv))
    mats = [Material("jelly", model="rigid", E=1.0e5, nu=0.3, rho=1000.0, friction=mu) for _ in bodies]
    if slab:
        xs, pvs = box_points([-0.12, -width / 2, 0.0], [0.20, width / 2, 0.03], dx / 2)
        parts.append(xs)
        vs.append(np.zeros_like(xs))
        Cs.append(np.zeros((len(xs), 3, 3)))
        vols.append(np.full(len(xs), pvs))
        mats.append(Material("jelly", model="elastic", E=E, nu=0.3, rho=1000.0, friction=mu))
    th = np.radians(theta)
    lo = np.array([-0.20, -SIDE / 2, -3 * dx])
    s = SimSetup(x=np.concatenate(parts), v=np.concatenate(vs), p_vol=np.concatenate(vols),
                 body_id=np.concatenate([np.full(len(p), k) for k, p in enumerate(parts)]), materials=mats,
                 gravity=G * np.array([np.sin(th), 0.0, -np.cos(th)]), domain_lo=lo, domain_hi=lo + SIDE,
                 n_grid=n_grid, frame_dt=frame_dt, C=np.concatenate(Cs),
                 boundaries=[Boundary("ground", height=0.0,
                                      friction=(1.0 if theta else 0.0) if ground_mu is None else ground_mu)])
    s.n_render = 0
    return s


def _engine(engine: str, s, roll: bool):
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    s = s.replace(options={**s.options, "roll_contact": bool(roll)})   # round 71: on by default, off set explicitly
    return build_engine(get_engine(engine), s)


def _spin(X, V, m, axis: int = 1) -> float:
    """A rigid body's angular velocity about ``axis`` from its points (masses ``m``)."""
    c = m @ X / m.sum()
    r = X - c
    L = (m[:, None] * np.cross(r, V - m @ V / m.sum())).sum(0)
    inertia = (m * (r * r).sum(1)).sum() * np.eye(3) - (m[:, None] * r).T @ r
    return float(np.linalg.solve(inertia, L)[axis])


def rest(engine: str, n_grid: int = 32, roll: bool = True, rho_ball: float = 3000.0) -> dict:
    """The ``rest`` scene's figures (module notes)."""
    from soft_on_round import R_BALL, round_setup
    s = round_setup("jelly_on_ball", n_grid, rho_ball=rho_ball)
    dx, body = s.dx, np.asarray(s.body_id)
    m = np.broadcast_to(np.asarray(s.p_vol, float), body.shape) * np.where(body == 1, rho_ball, 1000.0)
    x0 = np.asarray(s.x, float)
    e = _engine(engine, s, roll)
    start = x0[body == 0, 2].min() - x0[body == 1, 2].max()
    rows = []
    for f in range(60):
        e.step_frame()
        x, v = e.positions().astype(float), e.velocities().astype(float)
        c = m[body == 1] @ x[body == 1] / m[body == 1].sum()
        rows.append({"t": (f + 1) / 60, "gap": x[body == 0, 2].min() - x[body == 1, 2].max(),
                     "depth": float(R_BALL - np.linalg.norm(x[body == 0] - c, axis=1).min()),
                     "cj": m[body == 0] @ x[body == 0] / m[body == 0].sum(), "cb": c,
                     "pj": float(m[body == 0] @ v[body == 0, 2]), "pb": float(m[body == 1] @ v[body == 1, 2])})
    e.close()
    at = {round(r["t"], 4): r for r in rows}
    r0, r3, r5, r7, r1 = at[0.3], at[0.3], at[0.5], at[0.7], at[1.0]
    mj, W = float(m[body == 0].sum()), float(m.sum()) * G
    T = r1["t"] - r5["t"]
    return {"settle": (r0["gap"] - start) / dx, "drift": (r1["gap"] - r3["gap"]) / dx,
            "depth": max(r["depth"] for r in rows if r["t"] > 0.5) / dx,
            "jelly_mm": 1e3 * float(np.linalg.norm(r1["cj"] - r7["cj"])),
            "ball_mm": 1e3 * float(np.linalg.norm(r1["cb"] - r7["cb"])),
            "ground": 1.0 + (r1["pj"] + r1["pb"] - r5["pj"] - r5["pb"]) / (W * T),
            "on_jelly": 1.0 + (r1["pj"] - r5["pj"]) / (mj * G * T),
            "ball_z": (float(r1["cb"][2]) - R_BALL) / dx, "hertz": hertz(mj * G, R_BALL, 1.0e5, 0.3) / dx}


def hertz(F: float, R: float, E: float, nu: float) -> float:
    """Hertz's dent (m) of a flat elastic body (``E``, ``nu``) pressed by a rigid sphere of radius ``R`` with force
    ``F``: ``(9 F^2 / (16 E*^2 R))^(1/3)``, ``E* = E / (1 - nu^2)``."""
    Es = E / (1.0 - nu * nu)
    return float((9.0 * F * F / (16.0 * Es * Es * R)) ** (1.0 / 3.0))


def rolling(engine: str, n_grid: int, bodies: list, roll: bool, T: float = 0.2, width: float = 0.16,
            mu: float = 0.5, theta: float = 0.0, ground_mu: float | None = None) -> list[dict]:
    """Each rigid body's ``{"v": (first frame, last), "wR": (first, last), "t", "vs"}`` (along x, relative to the
    slab's mean; the spin about y times ``R``) on :func:`slab_setup`."""
    s = slab_setup(n_grid, bodies, mu=mu, theta=theta, width=width, ground_mu=ground_mu)
    body = np.asarray(s.body_id)
    m = np.broadcast_to(np.asarray(s.p_vol, float), body.shape) * 1000.0
    e = _engine(engine, s, roll)
    nb = len(bodies)
    out = [{"t": [], "v": [], "wR": []} for _ in range(nb)]
    for f in range(round(T / s.frame_dt)):
        e.step_frame()
        x, v = e.positions().astype(float), e.velocities().astype(float)
        vs = float(m[body == nb] @ v[body == nb, 0] / m[body == nb].sum())
        for k, (_shape, R, *_rest) in enumerate(bodies):
            q = body == k
            out[k]["t"].append((f + 1) * s.frame_dt)
            out[k]["v"].append(float(m[q] @ v[q, 0] / m[q].sum()) - vs)
            out[k]["wR"].append(_spin(x[q], v[q], m[q]) * R)
    e.close()
    return out


def keeps(r: dict) -> tuple[float, float]:
    """A rolling body's speed and ``w R`` at the end over the first frame's, less 1."""
    return r["v"][-1] / r["v"][0] - 1.0, r["wR"][-1] / r["wR"][0] - 1.0


TWO = [("ball", 0.03, (-0.08, -0.06), 0.5, 1.0), ("ball", 0.045, (-0.08, 0.06), 0.5, 0.0)]


def thrown_closed_form(n_grid: int, R: float, v0: float = 0.5) -> float:
    """A ball thrown sliding at ``v0`` with no spin on a slab held still (the ground's friction): once it rolls, ``v =
    w R = v0 / (1 + M R^2 / I)`` (Coulomb's, the angular momentum about the contact point; ``I`` its lattice's about
    y; 5/7 v0 for a solid ball: ``I / M R^2`` = 2/5)."""
    from gasp_core.testing.helpers import sphere_points
    x, _ = sphere_points(np.zeros(3), R, SIDE / n_grid / 2)
    k2 = float(np.mean(x[:, 0] ** 2 + x[:, 2] ** 2))
    return v0 / (1.0 + k2 / (R * R))


def two(engine: str, n_grid: int = 32, roll: bool = True, T: float = 0.1) -> dict:
    """The ``two`` scene's figures (the slab held by a ground of friction 1): the rolling ball's (R 3 cm) speed and
    ``w R`` at the end over the first frame's, less 1; the thrown ball's (R 4.5 cm, no spin at the start) over the
    rolling closed form (:func:`thrown_closed_form`), less 1; and each ball's end speed and spin over the same ball's
    alone on the same slab, less 1 (the cross-talk)."""
    both = rolling(engine, n_grid, TWO, roll, T, width=0.24, ground_mu=1.0)
    out = {}
    for k, b in enumerate(TWO):
        alone = rolling(engine, n_grid, [b], roll, T, width=0.24, ground_mu=1.0)[0]
        if b[4]:
            dv, dw = keeps(both[k])
        else:
            v = thrown_closed_form(n_grid, b[1], b[3])
            dv, dw = both[k]["v"][-1] / v - 1.0, both[k]["wR"][-1] / v - 1.0
        out[f"R{100 * b[1]:g}"] = {"v": dv, "wR": dw, "x_v": both[k]["v"][-1] / alone["v"][-1] - 1.0,
                                   "x_wR": both[k]["wR"][-1] / alone["wR"][-1] - 1.0}
    return out


def slope(engine: str, n_grid: int = 32, roll: bool = True, shape: str = "ball", R: float = 0.03,
          theta: float = 20.0, T: float = 0.2) -> dict:
    """The ``slope`` scene's figures: the fitted acceleration, the closed form of rolling without slip with the
    body's own inertia about its axis, their ratio less 1, and ``w R / v`` at the end."""
    from gasp_core.seam.setup import SimSetup  # noqa: F401
    s = slab_setup(n_grid, [(shape, R, (-0.06, 0.0), 0.0, 0.0)], theta=theta)
    body = np.asarray(s.body_id)
    X = np.asarray(s.x, float)[body == 0]
    r = X - X.mean(0)
    k2 = float(np.mean(r[:, 0] ** 2 + r[:, 2] ** 2))   # I_yy / M of the lattice
    closed = G * np.sin(np.radians(theta)) / (1.0 + k2 / R ** 2)
    res = rolling(engine, n_grid, [(shape, R, (-0.06, 0.0), 0.0, 0.0)], roll, T, theta=theta)[0]
    t, v = np.asarray(res["t"]), np.asarray(res["v"])
    sel = t >= 0.05
    a = float(np.polyfit(t[sel], v[sel], 1)[0])
    return {"a": a, "closed": closed, "err": a / closed - 1.0, "sphere_57": 5.0 / 7.0 * G * np.sin(np.radians(theta)),
            "wR_over_v": res["wR"][-1] / res["v"][-1]}


def drop(engine: str, n_grid: int = 32, roll: bool = True, height: float = 0.05, R: float = 0.03,
         T: float = 0.4, E: float = 1.0e5) -> dict:
    """The ``drop`` scene's figures (module notes)."""
    s = slab_setup(n_grid, [("ball", R, (0.04, 0.0), 0.0, 0.0)], mu=0.5, E=E)
    x = np.asarray(s.x, float)
    body = np.asarray(s.body_id)
    x[body == 0, 2] += height
    v = np.zeros_like(x)
    s = s.replace(x=x, v=v, C=np.zeros((len(x), 3, 3)))
    dx = s.dx
    m = np.broadcast_to(np.asarray(s.p_vol, float), body.shape) * 1000.0
    E0 = float(m @ (G * x[:, 2]))
    e = _engine(engine, s, roll)
    Es, depth, touched, rebound = [], -np.inf, False, -1.0
    for f in range(round(T / s.frame_dt)):
        e.step_frame()
        xx, vv = e.positions().astype(float), e.velocities().astype(float)
        Es.append(float(0.5 * m @ (vv * vv).sum(1) + m @ (G * xx[:, 2])))
        c = m[body == 0] @ xx[body == 0] / m[body == 0].sum()
        depth = max(depth, float(R - np.linalg.norm(xx[body == 1] - c, axis=1).min()))
        h = float(c[2] - R - 0.03)
        touched = touched or h < 0.25 * dx
        if touched:
            rebound = max(rebound, h) if vv[body == 0, 2].mean() > 0 or rebound >= 0 else rebound
    e.close()
    return {"E_max": max(Es) / E0 - 1.0, "E_end": Es[-1] / E0 - 1.0, "rebound": rebound / height,
            "depth": depth / dx}


def same_bits(engine: str, shape: str, n_grid: int = 32, frames: int = 12) -> dict:
    """A non-spherical rigid body (``shape``) rolling on the jelly slab with the option on and off: the largest
    difference of positions after ``frames`` frames (m; 0: the same bits) and whether the option gave it the point
    contact (``rigid_sdf.point_data``'s ``on``)."""
    from gasp_core.mpm.rigid_pairs import pair_data
    b = [(shape, 0.03, (-0.08, 0.0), 0.5, 1.0)]
    s = slab_setup(n_grid, b)
    pts = pair_data(s.replace(options={"roll_contact": True}))[2]["points"]
    xs = []
    for roll in (False, True):
        e = _engine(engine, s, roll)
        for _ in range(frames):
            e.step_frame()
        xs.append(e.positions().astype(float))
        e.close()
    return {"diff": float(np.abs(xs[0] - xs[1]).max()), "on": int(np.asarray(pts["on"]).any()),
            "sphere": float(np.asarray(pts["sphere"]).max())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--engine", nargs="+", default=["warp_mpm"])
    ap.add_argument("--scene", nargs="+", default=["rest", "two", "slope", "drop"])
    ap.add_argument("--roll", type=int, nargs="+", default=[1, 0])
    ap.add_argument("--n-grid", type=int, nargs="+", default=[32])
    ap.add_argument("--rho-ball", type=float, default=3000.0)
    ap.add_argument("--shape", nargs="+", default=["ball", "cyl"])
    ap.add_argument("--theta", type=float, default=20.0)
    ap.add_argument("--height", type=float, default=0.05)
    ap.add_argument("--T", type=float, default=None, help="two: the run's length (s; 0.1)")
    ap.add_argument("--set", nargs="*", default=[], help="NAME=VALUE on gasp_core.mpm.roll_contact (else rigid_sdf)")
    a = ap.parse_args()
    from gasp_core.mpm import rigid_sdf, roll_contact
    for kv in a.set:
        k, val = kv.split("=")
        mod = roll_contact if hasattr(roll_contact, k) else rigid_sdf
        setattr(mod, k, type(getattr(mod, k))(float(val)))
    fmt = lambda d: " | ".join(f"{k} {v:+.4f}" if isinstance(v, float) else f"{k} {v}" for k, v in d.items())  # noqa
    for engine in a.engine:
        for n in a.n_grid:
            for scene in a.scene:
                for roll in a.roll:
                    tag = f"| {engine} | {n} | {scene} | roll {roll} |"
                    if scene == "rest":
                        print(tag, fmt(rest(engine, n, bool(roll), a.rho_ball)), flush=True)
                    elif scene == "two":
                        for k, d in two(engine, n, bool(roll), a.T or 0.1).items():
                            print(tag, k, "|", fmt(d), flush=True)
                    elif scene == "slope":
                        for shape in a.shape:
                            print(tag, shape, "|", fmt(slope(engine, n, bool(roll), shape, theta=a.theta)),
                                  flush=True)
                    elif scene == "drop":
                        print(tag, fmt(drop(engine, n, bool(roll), a.height)), flush=True)
                    elif scene == "bits" and roll:
                        for shape in a.shape:
                            print(tag, shape, "|", fmt(same_bits(engine, shape, n)), flush=True)


if __name__ == "__main__":
    main()
