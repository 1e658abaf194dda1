"""Round 72 (issue 67 item 2, ``docs/rigid.md`` "Round 72: a cylinder rolling on a soft body"): a rigid solid
cylinder on a jelly slab under the option ``roll_contact`` (its exact capped cylinder, ``roll_contact.cylinder_shape``
and ``cylinder_patch``), on either engine; the cylinder lies on its side, its axis along y (across the motion).

Scenes (``roll_neighbours.slab_setup``: the 32 x 16 x 3 cm jelly slab, E 1e5 Pa, nu 0.3, rho 1000, on the ground;
the cylinder rho 1000, radius ``R``, length ``L``; frames of 1/240 s):

* ``flat``: rolling without slip at 0.5 m/s along +x on the flat slab (mu 0.5, the slab on a frictionless ground as
  round 70's ball), 0.2 s: its speed at the end over the first frame's, less 1 (rolling keeps it: ``lost``), ``w R /
  v`` at the end (1: no slip), and the slab's rolling resistance ``c_rr = -a (1 + I / M R^2) / g`` from the fitted
  deceleration (0.05 s to the end; ``I`` the lattice's).
* ``slope``: from rest on the slab tilted ``--theta`` degrees (gravity turned about y; the slab held by a ground of
  friction 1), 0.2 s: the fitted acceleration relative to the slab (0.05 s to the end) against rolling without slip,
  ``g sin / (1 + I / M R^2)`` (2/3 g sin for a solid cylinder, here the lattice's ``I``) where ``mu >= tan / (1 + M
  R^2 / I)`` (1/3 tan for a solid cylinder), else Coulomb's slip ``g (sin - mu cos)`` (``w R`` then grows at ``mu g cos
  M R^2 / I``: ``w_slope``); ``err`` the ratio less 1, ``err_rr`` the same against the closed form less the slab's own
  rolling resistance (``c_rr`` from ``flat``, the same grid and body: ``- c_rr g cos / (1 + I / M R^2)``), ``wR_over_v``
  at the end.
* ``rest``: at rest on the flat slab (ground of friction 1), ``--rest-T`` s at 1/120 s frames: statics, the slab's
  support over the cylinder's weight (``1 + dP_z / (M g T)`` over the second half), the deepest slab point inside the
  cylinder over the second half (dx; its exact shape at the body's pose, ``depth``), the centre's drop from its start
  (dx), its height's travel over the last 0.3 s (``z_mm``) and its farthest sway along x from its start (``sway_mm``:
  a cylinder at rest on a flat face is in neutral equilibrium for rolling; the start's kick rocks it in the lattice's
  well, module figures in the docs).

* ``yaw``: lying on the frictionless slab (the slab on a ground of friction 1), spun about the vertical at 10 rad/s
  for 0.2 s (1/240 s frames; it turns about 115 degrees): the contact's axis must turn with the body (``R e0``). The
  angle turned, the deepest slab point inside the exact cylinder at its pose (dx, over the run) and the centre's
  largest drop (dx).

    python benchmarks/studies/roll_cylinder.py --engine warp_mpm taichi_mpm --scene flat slope rest \\
        --n-grid 32 48 --body 3,6 4.5,6 3,9

Round 73 (``docs/rigid.md`` "Round 73"): ``--body R,0`` is the ball of radius ``R`` in the same scenes (its lattice's
``I``, its exact sphere for ``depth``); ``--rest-x0`` the body's start along x (mm) in ``rest``, which also gives
``a0`` (its mean acceleration along x over the first 0.05 s), ``x_mid_mm`` and ``x_amp_mm`` (the middle and half-range
of its x over the second half, from the start).

``--set NAME=VALUE`` sets a constant of ``gasp_core.mpm.roll_contact`` (else ``rigid_sdf``): the broken variants
``CYLINDER=0`` (round 71's fallback, the band), ``CYL_AXIS=1`` (a wrong axis), ``CYL_TURN=0`` (the axis turned the
wrong way), ``SURFACE_ARM=0`` (the arm at the patch); ``--roll 0`` the option off.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from roll_neighbours import G, _engine, _spin, rolling, slab_setup  # noqa: E402


def _shape(L: float) -> str:
    """The body's ``roll_neighbours.body_points`` shape: a cylinder ``L`` long; round 73: ``L`` 0 a ball."""
    return "ball" if L == 0.0 else f"cyl{100.0 * L:g}"


def k_ratio(n_grid: int, R: float, L: float) -> float:
    """``I / M R^2`` about the cylinder's axis (y) of its lattice (1/2 for a solid cylinder; round 73: ``L`` 0 the
    ball's, 2/5 for a solid ball)."""
    from roll_neighbours import body_points
    x, _ = body_points(_shape(L), np.zeros(3), R, 0.48 / n_grid / 2)
    x = x - x.mean(0)
    return float(np.mean(x[:, 0] ** 2 + x[:, 2] ** 2)) / R ** 2


def _fit(t, v, t0: float = 0.05) -> float:
    t, v = np.asarray(t), np.asarray(v)
    return float(np.polyfit(t[t >= t0], v[t >= t0], 1)[0])


def flat(engine: str, n_grid: int = 32, R: float = 0.03, L: float = 0.06, mu: float = 0.5, T: float = 0.2,
         roll: bool = True, v0: float = 0.5) -> dict:
    """The ``flat`` scene's figures (module notes)."""
    r = rolling(engine, n_grid, [(_shape(L), R, (-0.08, 0.0), v0, 1.0)], roll, T, mu=mu, ground_mu=0.0)[0]
    k = k_ratio(n_grid, R, L)
    return {"lost": r["v"][-1] / r["v"][0] - 1.0, "wR_over_v": r["wR"][-1] / r["v"][-1],
            "c_rr": -_fit(r["t"], r["v"]) * (1.0 + k) / G, "v_end": r["v"][-1]}


def slope(engine: str, n_grid: int = 32, R: float = 0.03, L: float = 0.06, mu: float = 0.5, theta: float = 20.0,
          T: float = 0.2, roll: bool = True, c_rr: float = 0.0, width: float = 0.16) -> dict:
    """The ``slope`` scene's figures (module notes); ``c_rr`` the slab's rolling resistance (``flat``'s); ``width`` the
    slab's (m; round 82: under 9 cm a cylinder 18 cm long is the larger body, the rigid field B)."""
    k = k_ratio(n_grid, R, L)
    th = np.radians(theta)
    rolls = mu >= np.tan(th) / (1.0 + 1.0 / k)
    closed = G * np.sin(th) / (1.0 + k) if rolls else G * (np.sin(th) - mu * np.cos(th))
    r = rolling(engine, n_grid, [(_shape(L), R, (-0.06, 0.0), 0.0, 0.0)], roll, T, width, mu=mu, theta=theta)[0]
    a = _fit(r["t"], r["v"])
    net = closed - (c_rr * G * np.cos(th) / (1.0 + k) if rolls else 0.0)
    out = {"rolls": bool(rolls), "a": a, "closed": float(closed), "err": a / closed - 1.0, "err_rr": a / net - 1.0,
           "wR_over_v": r["wR"][-1] / r["v"][-1]}
    if not rolls:
        w_closed = mu * G * np.cos(th) / k
        w = _fit(r["t"], r["wR"])
        out.update(w_slope=w, w_closed=float(w_closed), w_err=w / w_closed - 1.0)
    return out


def cyl_distance(x: np.ndarray, c: np.ndarray, e: np.ndarray, R: float, h: float) -> np.ndarray:
    """The signed distance (m, negative inside) of points ``x`` (N, 3) to the solid capped cylinder (centre ``c``, unit
    axis ``e``, radius ``R``, half-length ``h``; round 73: ``h`` 0 the ball of radius ``R``)."""
    y = x - c
    if h == 0.0:   # round 73: a ball (``L`` 0)
        return np.linalg.norm(y, axis=1) - R
    z = y @ e
    dr = np.linalg.norm(y - np.outer(z, e), axis=1) - R
    dz = np.abs(z) - h
    return np.where((dr > 0.0) & (dz > 0.0), np.hypot(dr, dz), np.maximum(dr, dz))


def _kabsch(X0: np.ndarray, X: np.ndarray) -> np.ndarray:
    """The rotation taking the centred points ``X0`` to ``X``."""
    U, _, Vt = np.linalg.svd(X0.T @ X)
    d = np.sign(np.linalg.det(U @ Vt))
    return (U @ np.diag([1.0, 1.0, d]) @ Vt).T


def rest(engine: str, n_grid: int = 32, R: float = 0.03, L: float = 0.06, T: float = 0.6, roll: bool = True,
         x0: float = 0.0) -> dict:
    """The ``rest`` scene's figures (module notes); round 73: ``x0`` (m) the body's start along x (0: the slab's
    points symmetric about it), and ``a0`` (m/s^2) its mean acceleration along x over the first 0.05 s (``2 (x - x0) /
    t^2``), ``x_mid_mm`` the middle of its sway over the second half from ``x0`` (where it rocks about), ``x_amp_mm``
    its half-range there."""
    s = slab_setup(n_grid, [(_shape(L), R, (x0, 0.0), 0.0, 0.0)], frame_dt=1.0 / 120.0, ground_mu=1.0)
    body = np.asarray(s.body_id)
    m = np.broadcast_to(np.asarray(s.p_vol, float), body.shape) * 1000.0
    q, M = body == 0, float(m[body == 0].sum())
    X0 = np.asarray(s.x, float)[q]
    c0 = m[q] @ X0 / M
    e0 = np.array([0.0, 1.0, 0.0])
    dx = s.dx
    e = _engine(engine, s, roll)
    rows = []
    for f in range(round(T / s.frame_dt)):
        e.step_frame()
        x, v = e.positions().astype(float), e.velocities().astype(float)
        c = m[q] @ x[q] / M
        ax = _kabsch(X0 - c0, x[q] - c) @ e0
        rows.append({"t": (f + 1) * s.frame_dt, "c": c, "pz": float(m[q] @ v[q, 2]),
                     "depth": float(-cyl_distance(x[body == 1], c, ax, R, L / 2).min())})
    e.close()
    half = [r for r in rows if r["t"] > T / 2 - 1e-9]
    last = [r for r in rows if r["t"] > T - 0.3 - 1e-9]
    dT = half[-1]["t"] - half[0]["t"]
    xs = np.array([r["c"][0] for r in half])
    r6 = rows[5]
    return {"support": 1.0 + (half[-1]["pz"] - half[0]["pz"]) / (M * G * dT),
            "a0": 2.0 * float(r6["c"][0] - c0[0]) / r6["t"] ** 2,
            "x_mid_mm": 1e3 * float(0.5 * (xs.max() + xs.min()) - c0[0]),
            "x_amp_mm": 1e3 * float(0.5 * (xs.max() - xs.min())),
            "depth": max(r["depth"] for r in half) / dx, "drop": float(c0[2] - rows[-1]["c"][2]) / dx,
            "z_mm": 1e3 * float(max(abs(r["c"][2] - last[0]["c"][2]) for r in last)),
            "sway_mm": 1e3 * float(max(abs(r["c"][0] - c0[0]) for r in rows))}


def yaw(engine: str, n_grid: int = 32, R: float = 0.03, L: float = 0.06, wz: float = 10.0, T: float = 0.2,
        roll: bool = True) -> dict:
    """The ``yaw`` scene's figures (module notes)."""
    s = slab_setup(n_grid, [(_shape(L), R, (0.0, 0.0), 0.0, 0.0)], mu=0.0, ground_mu=1.0)
    body = np.asarray(s.body_id)
    q = body == 0
    x = np.asarray(s.x, float)
    m = np.broadcast_to(np.asarray(s.p_vol, float), body.shape) * 1000.0
    c0 = m[q] @ x[q] / m[q].sum()
    v = np.zeros_like(x)
    v[q] = np.cross([0.0, 0.0, wz], x[q] - c0)
    C = np.asarray(s.C, float).copy()
    C[q] = np.array([[0.0, -wz, 0.0], [wz, 0.0, 0.0], [0.0, 0.0, 0.0]])
    e = _engine(engine, s.replace(v=v, C=C), roll)
    depth, drop, turned = -np.inf, 0.0, 0.0
    for _ in range(round(T / s.frame_dt)):
        e.step_frame()
        xx = e.positions().astype(float)
        c = m[q] @ xx[q] / m[q].sum()
        ax = _kabsch(x[q] - c0, xx[q] - c) @ np.array([0.0, 1.0, 0.0])
        depth = max(depth, float(-cyl_distance(xx[body == 1], c, ax, R, L / 2).min()))
        drop = max(drop, float(c0[2] - c[2]))
        turned = float(np.degrees(np.arctan2(-ax[0], ax[1])) % 360.0)
    e.close()
    return {"turned_deg": turned, "depth": depth / s.dx, "drop": drop / s.dx}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--engine", nargs="+", default=["warp_mpm"])
    ap.add_argument("--scene", nargs="+", default=["flat", "slope", "rest"])
    ap.add_argument("--n-grid", nargs="+", type=int, default=[32])
    ap.add_argument("--body", nargs="+", default=["3,6"], help="R,L in cm (round 73: L 0, a ball of radius R)")
    ap.add_argument("--mu", nargs="+", type=float, default=[0.5, 0.05])
    ap.add_argument("--theta", type=float, default=20.0)
    ap.add_argument("--rest-T", type=float, default=0.6)
    ap.add_argument("--rest-x0", nargs="+", type=float, default=[0.0], help="rest: the body's start along x (mm)")
    ap.add_argument("--roll", type=int, default=1)
    ap.add_argument("--set", nargs="*", default=[])
    a = ap.parse_args()
    from gasp_core.mpm import rigid_sdf
    from gasp_core.mpm import roll_contact as roll
    for kv in a.set:
        k, v = kv.split("=")
        setattr(roll if hasattr(roll, k) else rigid_sdf, k, float(v) if "." in v else int(v))
    for eng in a.engine:
        for ng in a.n_grid:
            for b in a.body:
                R, L = (float(u) / 100.0 for u in b.split(","))
                tag = f"{eng} n_grid {ng} R {100 * R:g} cm " + (f"L {100 * L:g} cm" if L else "ball")
                c_rr = 0.0
                if "flat" in a.scene:
                    r = flat(eng, ng, R, L, roll=bool(a.roll))
                    c_rr = r["c_rr"]
                    print(tag, "flat", {k: round(v, 4) for k, v in r.items()}, flush=True)
                if "slope" in a.scene:
                    for mu in a.mu:
                        r = slope(eng, ng, R, L, mu, a.theta, roll=bool(a.roll), c_rr=c_rr)
                        print(tag, f"slope mu {mu:g}", {k: (round(v, 4) if isinstance(v, float) else v)
                                                         for k, v in r.items()}, flush=True)
                if "yaw" in a.scene:
                    r = yaw(eng, ng, R, L, roll=bool(a.roll))
                    print(tag, "yaw", {k: round(v, 4) for k, v in r.items()}, flush=True)
                if "rest" in a.scene:
                    for x0 in a.rest_x0:
                        r = rest(eng, ng, R, L, a.rest_T, roll=bool(a.roll), x0=x0 / 1e3)
                        print(tag, "rest" + (f" x0 {x0:g} mm" if x0 else ""), {k: round(v, 4) for k, v in r.items()},
                              flush=True)


if __name__ == "__main__":
    main()
