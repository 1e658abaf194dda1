"""Round 93 (issue 67 items 2 and 4, a round body on a curved convex rigid body; ``docs/rigid.md`` "Round 93: a ball
over a dome"): a rigid ball released at rest 20 degrees from the top of a rigid dome rolls down its side and leaves
it where Newton says.

Round 91 took a round body's contact normal with a rigid body that is not round from the body's support table (the
separating axis over its table's rows within 20 degrees of the touching nodes' normal,
``gasp_core.mpm.rigid_support.round_normal``); round 92 the hollow's from its outer points. A table's rows are 268
directions, about 12 degrees apart: on a box they hold its face normals, but on a curved convex face the chosen row is
the nearest one, up to half a spacing off the surface's normal (a NumPy probe on this dome: up to 7.5 degrees, 4.3 on
average along the ball's path).

**The scene:** a dome, a sphere of radius ``DOME_R`` 0.2 m whose centre lies 5 cm above the ground, cut flat there (a
boulder or a mound scanned as a rigid body, 0.25 m tall, its base 0.39 m across, ten times the ball's density, lying on
a ground of friction 1; the ball leaves it, and flies 5 mm clear of it, well above the ground), its fill a lattice at ``dx / 2`` with its Gaussians on its sphere (Fibonacci or
scan-like, as :mod:`roll_bowl92`'s hollow); ``test_rolling``'s ball (R 5 cm) released at rest with its centre 20
degrees from the top, ``L = DOME_R + R`` from the sphere's centre. The closed form (:func:`reference`): while it
touches, ``L theta'' = g sin theta - f / m`` with the normal force ``N = m (g cos theta - L theta'^2)``; it rolls
(``f = k m g sin theta / (1 + k)``) while ``|f| <= mu N`` and then slips (``f = mu N`` against the contact's slip, the
spin ``I omega' = f R``); it leaves when ``N`` reaches 0 (rolling throughout: ``cos theta = 2 cos theta_0 / (3 + k)``,
56.4 degrees for ``k = 0.4``; sliding ``k = 0``: 51.2), then flies. Judged on the time the ball's centre takes to
reach 40 degrees (``t1``, on the dome throughout), its speed there (``v1``) and the time it is ``DELTA`` (5 mm)
farther than ``L`` from the dome's centre (``t_off``: it has left), linear between frames, each against the
reference; ``sink`` (the centre's least distance less ``L`` before 40 degrees, m; negative: into the dome) is
reported. ``--shape mound``: a low cap of a 1 m sphere, the ball from 3 to 12 degrees, judged on ``v1`` alone: near
the top the slope is 3 degrees, so a scan's sampling noise in the normal there (0.4-0.6 degrees rms) moves the start
and every time after it (``t1`` is reported), while the speed at 12 degrees is the energy's, whatever the start.

``--body cylinder``: ``roll_family88``'s solid cylinder (R 5 cm, 15 cm long) lying across the path instead; on a
sphere it touches at its middle, so the closed form is the same with its ``k`` (a disc on a circle).

``python benchmarks/studies/roll_dome93.py --engine warp_mpm --out benchmarks/results/roll_dome93_warp.json``
(refused if the file exists); ``--dome-rule 0``: round 91's table rows on the dome (the broken variant).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import roll_family88 as RF  # noqa: E402
import test_rolling as rl  # noqa: E402

#: The ball's radius (m), the density ratio, the box (m), frames a second, the distance past ``L`` (m) of ``t_off``.
BALL_R, DENSITY_RATIO, BOX, FPS, DELTA = 0.05, 10.0, 0.6, 120, 0.005
#: The shapes (:func:`use`): the sphere's radius (m) and centre (m), the block it is cut from (m), the release angle
#: and the judged one ``THETA1`` (degrees from the top), seconds run, and whether ``t_off`` is judged. The dome's
#: sphere is cut flat 5 cm under its centre; the mound is a low cap of a 1 m sphere on a block 0.56 m square (its top
#: 15 cm up, the cap meeting the block's sides 3 cm or more above the ground): a ball 3 degrees from its top reaches 12
#: degrees (a 21 % slope) before the cap's edge.
SHAPES = {"dome": dict(DOME_R=0.2, DOME_C=np.array([0.22, 0.3, 0.05]), BLOCK_LO=np.array([0.02, 0.1, 0.0]),
                       BLOCK_HI=np.array([0.42, 0.5, 0.26]), THETA0=20.0, THETA1=40.0, RUN_T=0.45, OFF=True),
          "mound": dict(DOME_R=1.0, DOME_C=np.array([0.2, 0.3, -0.85]), BLOCK_LO=np.array([0.02, 0.02, 0.0]),
                        BLOCK_HI=np.array([0.58, 0.58, 0.15]), THETA0=3.0, THETA1=12.0, RUN_T=0.95, OFF=False)}
DOME_R = DOME_C = BLOCK_LO = BLOCK_HI = THETA0 = THETA1 = RUN_T = OFF = None
#: Round 95: the seed of the scan-like sampling of the dome's Gaussians (``roll_family88.scan_sphere``).
SCAN_SEED = 1


def use(shape: str) -> None:
    """Set the module's shape constants to :data:`SHAPES`' ``shape`` ("dome" or "mound")."""
    globals().update(SHAPES[shape])


use("dome")
#: Two-sided tolerance of each time.
TOL = 0.02


def family() -> list[tuple[int, str, float]]:
    """``(n_grid, sampling, mu)``: the ball's Gaussians and the dome's sampled alike; mu 0.5 (rolls, then slips near
    the edge) and 0 (slides)."""
    return [(n, s, mu) for n in (32, 48) for s in ("fibonacci", "scan") for mu in (rl.ROLL_MU, 0.0)]


def dome_points(s: float, sampling: str) -> np.ndarray:
    """The dome's points (m), spacing ``s``: its fill (a lattice inside the sphere, half a spacing in, and the block)
    and, unless ``sampling`` is "fill", its Gaussians on the sphere above the ground at the ball's areal density, on a
    Fibonacci sphere or scan-like (at random, jittered a quarter spacing along the normal)."""
    from gasp_core.testing.helpers import box_points
    x, _ = box_points(BLOCK_LO, BLOCK_HI, s)
    x = x[np.linalg.norm(x - DOME_C, axis=1) <= DOME_R - s / 2]
    if sampling == "fill":
        return x
    n = int(round(rl.N_SHELL * (DOME_R / 0.1) ** 2))
    if sampling == "scan":
        shell = RF.scan_sphere(DOME_C, DOME_R, n, seed=SCAN_SEED)
    else:
        shell = DOME_C + DOME_R * rl.fibonacci_sphere(n)
    # The block's sides and the ground bound the Gaussians, its top does not (round 95): the mound's block is as high
    # as its cap, and its top cut the scan's outward-jittered Gaussians within 5.6 cm of the cap's top, a flat there.
    inside = np.all(shell > BLOCK_LO, axis=1) & np.all(shell[:, :2] < BLOCK_HI[:2], axis=1)
    return np.concatenate([shell[inside], x])


def dome_centre(n_grid: int) -> np.ndarray:
    """The dome's sphere's centre (m) as set: :data:`DOME_C` raised by half the fill's spacing, so that the lattice's
    surface (half a spacing beyond its lowest points) rests on the ground rather than in it."""
    return DOME_C + np.array([0.0, 0.0, BOX / n_grid / 4])


def setup(n_grid: int, sampling: str, mu: float, body: str = "ball"):
    """``(SimSetup, k)``: body 0 the ball (its Gaussians first; ``body`` "cylinder": ``roll_family88``'s solid
    cylinder of the same radius, 15 cm long, its axis along y, across the path), body 1 the dome
    (:func:`dome_points`)."""
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    dx = BOX / n_grid
    x, vol, n_render = RF.body(body, BALL_R, n_grid, sampling)
    k = RF.inertia_share(x, vol, BALL_R)
    t0 = math.radians(THETA0)
    centre = dome_centre(n_grid) + (DOME_R + BALL_R) * np.array([math.sin(t0), 0.0, math.cos(t0)])
    x = x - (vol[:, None] * x).sum(0) / vol.sum() + centre
    xs = dome_points(dx / 2, sampling) + dome_centre(n_grid) - DOME_C
    mats = [Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0 * r, friction=mu)
            for r in (1.0, DENSITY_RATIO)]
    lo = np.array([0.0, 0.0, -3 * dx])
    s = SimSetup(x=np.concatenate([x, xs]), v=0.0, p_vol=np.r_[vol, np.full(len(xs), (dx / 2) ** 3)],
                 body_id=np.r_[np.zeros(len(x), int), np.ones(len(xs), int)], materials=mats,
                 gravity=np.array([0.0, 0.0, -rl.G]), domain_lo=lo, domain_hi=lo + BOX, n_grid=n_grid,
                 frame_dt=1.0 / FPS, boundaries=[Boundary("ground", height=0.0, friction=1.0)])
    s.n_render = n_render
    return s, k


def reference(k: float, mu: float, dt: float = 1.0e-5) -> dict:
    """The closed form's ``t1`` and ``t_off`` (s) and the angle it leaves at (degrees), by RK4 of the equations in
    the module notes (``k`` the ball's ``I / (m R^2)``; mu 0: it slides, its spin never changes)."""
    L, g = DOME_R + BALL_R, rl.G

    def rhs(s):
        th, w, om = s   # angle, its rate, the ball's spin (rolling: om R = L w)
        N = g * math.cos(th) - L * w * w   # per unit mass
        slip = L * w - BALL_R * om
        if mu > 0.0 and abs(slip) < 1e-9 and abs(k * g * math.sin(th) / (1 + k)) <= mu * N:
            f = k * g * math.sin(th) / (1 + k)
        else:
            f = mu * N * (math.copysign(1.0, slip) if abs(slip) >= 1e-9 else 1.0)
        return np.array([w, (g * math.sin(th) - f) / L, f * BALL_R / (k * BALL_R ** 2) if k > 0 else 0.0]), N

    s, t, out = np.array([math.radians(THETA0), 0.0, 0.0]), 0.0, {}
    while True:
        k1, N = rhs(s)
        if N <= 0.0:
            break
        k2, _ = rhs(s + dt / 2 * k1)
        k3, _ = rhs(s + dt / 2 * k2)
        k4, _ = rhs(s + dt * k3)
        s_new = s + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        if mu > 0.0 and abs(L * s_new[1] - BALL_R * s_new[2]) < 1e-6 * L * max(s_new[1], 1e-9):
            s_new[2] = L * s_new[1] / BALL_R   # rolling: hold the constraint against round-off
        if "t1" not in out and s_new[0] >= math.radians(THETA1):
            f = (math.radians(THETA1) - s[0]) / (s_new[0] - s[0])
            out["t1"] = t + dt * f
            out["v1"] = L * (s[1] + f * (s_new[1] - s[1]))   # the centre's speed there
        s, t = s_new, t + dt
    out["leave_deg"] = math.degrees(s[0])
    p = L * np.array([math.sin(s[0]), math.cos(s[0])])
    v = L * s[1] * np.array([math.cos(s[0]), -math.sin(s[0])])
    tf = np.linspace(0.0, 0.3, 300001)   # free flight until DELTA past L
    P = p[None, :] + v[None, :] * tf[:, None] + np.outer(tf * tf / 2, [0.0, -g])
    i = int(np.argmax(np.linalg.norm(P, axis=1) >= L + DELTA))
    out["t_off"] = t + tf[i]
    return out


def figures(engine: str, s) -> dict:
    """``t1``, ``t_off`` (s; module notes, linear between frames, inf where never reached), ``sink`` (m) and
    ``dome`` (the dome's largest point speed, m/s), the ball's centre read relative to the dome's sphere's centre
    (moved with the dome's mass centre)."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    b, m = np.asarray(s.body_id), np.asarray(s.p_mass, np.float64)
    mb, md = m[b == 0], m[b == 1]
    x0 = np.asarray(s.x, np.float64)
    c0 = dome_centre(s.n_grid) - (md[:, None] * x0[b == 1]).sum(0) / md.sum()
    L = DOME_R + BALL_R
    e = build_engine(get_engine(engine), s)
    th, dist, speed, dome = [math.radians(THETA0)], [L], [0.0], 0.0
    for _ in range(round(RUN_T * FPS)):
        e.step_frame()
        X, V = e.positions().astype(np.float64), e.velocities().astype(np.float64)
        d = (mb[:, None] * X[b == 0]).sum(0) / mb.sum() - ((md[:, None] * X[b == 1]).sum(0) / md.sum() + c0)
        u = (mb[:, None] * V[b == 0]).sum(0) / mb.sum() - (md[:, None] * V[b == 1]).sum(0) / md.sum()
        th.append(math.atan2(d[0], d[2]))
        dist.append(float(np.linalg.norm(d[[0, 2]])))
        speed.append(float(np.linalg.norm(u[[0, 2]])))
        dome = max(dome, float(np.abs(V[b == 1]).max()))
    e.close()
    th, dist, t = np.array(th), np.array(dist) - L, np.arange(len(th)) / FPS
    i1 = np.flatnonzero(th >= math.radians(THETA1))

    def first(y, level):
        i = np.flatnonzero(y >= level)
        if not len(i) or i[0] == 0:
            return math.inf
        j = i[0]
        return float(t[j - 1] + (t[j] - t[j - 1]) * (level - y[j - 1]) / (y[j] - y[j - 1]))

    before = th < math.radians(THETA1)
    v1 = math.inf
    if len(i1) and i1[0] > 0:   # the centre's speed as it passes THETA1, linear between frames
        j = i1[0]
        f = (math.radians(THETA1) - th[j - 1]) / (th[j] - th[j - 1])
        v1 = speed[j - 1] + f * (speed[j] - speed[j - 1])
    return {"t1": first(th, math.radians(THETA1)), "t_off": first(dist, DELTA), "v1": v1,
            "sink": float(dist[before].min()), "dome": dome}


def row(engine: str, n_grid: int, sampling: str, mu: float, shape: str = "dome", body: str = "ball") -> dict:
    use(shape)
    s, k = setup(n_grid, sampling, mu, body)
    t0 = time.time()
    fig = figures(engine, s)
    want = reference(k if mu > 0 else 0.0, mu)
    err = {q: fig[q] / want[q] - 1.0 for q in (("t1", "t_off", "v1") if OFF else ("v1",))}
    bad = [f"{q} {100 * e:+.2f} %" for q, e in err.items() if not abs(e) <= TOL]
    return {"engine": engine, "shape": shape, "body": body, "n_grid": n_grid, "sampling": sampling, "mu": mu, "k": k, **fig,
            "want": want, "err": err, "problem": "; ".join(bad) or None, "wall_s": time.time() - t0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--shape", default="dome", help="dome (the ball leaves it) or mound (a low cap of a 1 m sphere)")
    ap.add_argument("--body", default="ball", help="ball, or cylinder (a solid one across the path: the same closed "
                                                   "form with its k, as a disc on a circle)")
    ap.add_argument("--dome-rule", type=int, default=None,
                    help="gasp_core.mpm.rigid_support.CURVED (0: round 91's table rows on a curved face, the broken variant)")
    ap.add_argument("--only", default=None, help="n_grid,sampling,mu: one case (sampling fibonacci, scan or fill)")
    ap.add_argument("--seed", type=int, default=SCAN_SEED, help="round 95: the seed of the dome's or mound's scan-like "
                                                                 "Gaussians (SCAN_SEED)")
    ap.add_argument("--out", default=None, help="a new JSON file for the rows (refused if it exists)")
    a = ap.parse_args(argv)
    globals()["SCAN_SEED"] = a.seed
    if a.dome_rule is not None:
        import gasp_core.mpm.rigid_support as rs
        rs.CURVED = a.dome_rule
    out = RF.new_out(ap, a.out)
    cases = family() if a.only is None else [(int(a.only.split(",")[0]), a.only.split(",")[1],
                                             float(a.only.split(",")[2]))]
    rows = []
    for case in cases:
        rows.append(row(a.engine, *case, shape=a.shape, body=a.body))
        r = rows[-1]
        w, judged = r["want"], ", ".join(f"{q} {100 * e:+.2f} %" for q, e in r["err"].items())
        print(f"{a.engine} {a.body} on the {a.shape} n_grid {r['n_grid']} {r['sampling']} mu {r['mu']}: t1 {r['t1']:.4f} s (want "
              f"{w['t1']:.4f}), v1 {r['v1']:.4f} m/s (want {w['v1']:.4f}), t_off {r['t_off']:.4f} s (want "
              f"{w['t_off']:.4f}; leaves at {w['leave_deg']:.1f} deg); judged {judged}; sink {1e3 * r['sink']:+.2f} "
              f"mm, dome {r['dome']:.4f} m/s; {r['problem'] or 'ok'} ({r['wall_s']:.0f} s)", flush=True)
    RF.write_rows(out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
