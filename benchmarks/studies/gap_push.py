"""Round 62 (issue 67/66, ``docs/contact.md`` "Round 62: letting an overlap out"): the gap at rest of two jelly bodies
with the position term that lets a measured overlap out (``gasp_core.mpm.gap_push``), per scene, one engine.

Rows as ``gap_curve.py``'s (``stacked:R:n_grid``: the stacked balls, ``tests/test_stacked_balls.py``'s measure, the
mean over the last 0.5 s of 1 s; ``ball:n_grid``, ``cube:n_grid``, ``cylinder:n_grid``: dropped 1.5 dx on the box, the
mean of the last 5 of ``--frames`` 40), plus ``energy:R:n_grid``: the stacked balls dropped, the kinetic energy (J)
over ``--energy-frames`` (30 = 1 s) with the mean of each third printed (no growth after rest: the last third not above
the second). ``--push 0/1`` (``gap_push.PUSH``), ``--kick 1`` (the broken variant ``gap_push.KICK``: the push made a velocity), ``--beta`` / ``--cap`` (``gap_push.BETA`` / ``CAP``), ``--rule curve
/ sep0.5`` (``gap_touch.CURVATURE`` or round 60's separation), ``--pair-mu``, ``--drop`` (the stacked balls' start above
the touch, dx; 0: touching, no landing) as in ``gap_curve.py``.

``--diag`` (a stacked row): at the last frame, the points that read an overlap (the field's reading,
``gap_push.point_overlap``), the largest, and the five nearest pairs of points across the contact.

Usage: ``python benchmarks/studies/gap_push.py --engine warp_mpm --push 1 --rows stacked:0.05:24 --drop 0``.
"""
import argparse
import dataclasses
import sys
import time

import numpy as np

import gasp_core.mpm.gap_push as GP
import gasp_core.testing.scenes_pairs as P
from gasp_core.seam.plugins import get_engine
from gasp_core.testing.kit import run_trace

sys.path.insert(0, "benchmarks/studies")
from gap_curve import set_rule, stacked  # noqa: E402


def energy(engine, radius, n_grid, frames):
    """The stacked balls dropped (the scene's ``STACK_DROP``): the kinetic energy ``sum m v^2 / 2`` (J) per frame."""
    keep = P.STACK_R, P.N_GRID, P.DX
    P.STACK_R, P.N_GRID, P.DX = radius, n_grid, P.SIDE / n_grid
    try:
        s = dataclasses.replace(P._build_stack(None), options={"threads": 1})
        tr = run_trace(get_engine(engine), s, frames)
        m = np.broadcast_to(np.asarray(s.p_vol, float), (len(s.x),)) * float(s.materials[0].rho)
        return np.array([0.5 * float((m[:, None] * np.asarray(v, float) ** 2).sum()) for v in tr.v])
    finally:
        P.STACK_R, P.N_GRID, P.DX = keep


def diagnose(engine, radius, n_grid):
    """The stacked balls' last frame (1 s): the points that read an overlap (``gap_push.point_overlap`` on volumes
    scattered from the points as P2G does), the largest ``d`` (cells), and the five nearest pairs' distances (dx)."""
    import gasp_core.mpm.gap_touch as G
    from scipy.spatial import cKDTree
    from gasp_core.mpm.fields import field_bodies
    keep = P.STACK_R, P.N_GRID, P.DX
    P.STACK_R, P.N_GRID, P.DX = radius, n_grid, P.SIDE / n_grid
    try:
        s = dataclasses.replace(P._build_stack(None), options={"threads": 1})
        x = np.asarray(run_trace(get_engine(engine), s, round(P.STACK_T * 30)).x[-1], float) / P.DX
    finally:
        P.STACK_R, P.N_GRID, P.DX = keep
    body, in_a = np.asarray(s.body_id), np.asarray(field_bodies(s)).astype(int)
    base = np.floor(x - 0.5).astype(int)
    fx = x - base
    w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]
    vf = np.zeros((2, n_grid, n_grid, n_grid))
    cell = float(np.broadcast_to(s.p_vol, (len(x),))[0]) / (P.SIDE / n_grid) ** 3
    for i in range(3):
        for j in range(3):
            for k in range(3):
                np.add.at(vf, (1 - in_a[body], base[:, 0] + i, base[:, 1] + j, base[:, 2] + k),
                          cell * w[i][:, 0] * w[j][:, 1] * w[k][:, 2])
    prm, tn = GP.push_params(s), G.TABLE_N
    d = np.array([GP.point_overlap(*(lambda b: (b[0], b[1]) if in_a[body[p]] else (b[1], b[0]))(
        vf[:, base[p, 0]:base[p, 0] + 3, base[p, 1]:base[p, 1] + 3, base[p, 2]:base[p, 2] + 3]), fx[p],
        prm[tn + body[p]], prm[:tn], G.CURVATURE)[0] for p in range(len(x))])
    near = np.sort(cKDTree(x[body == 0]).query(x[body == 1])[0])[:5]
    return f"{int((d > 0).sum())} points read an overlap, max d {d.max():+.3f} cell; nearest pairs {np.round(near, 3)} dx"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--rule", default="curve")
    ap.add_argument("--push", type=int, default=1)
    ap.add_argument("--beta", type=float, default=GP.BETA)
    ap.add_argument("--cap", type=float, default=GP.CAP)
    ap.add_argument("--kick", type=int, default=0, help="the broken variant: the push made a velocity (gap_push.KICK,"
                    " warp_mpm)")
    ap.add_argument("--pair-mu", type=float, default=None)
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--energy-frames", type=int, default=30)
    ap.add_argument("--drop", type=float, default=None)
    ap.add_argument("--rows", default="stacked:0.05:24")
    ap.add_argument("--diag", action="store_true", help="a stacked row: the field's overlap reading and the nearest "
                    "pairs at the last frame (diagnose) instead of the gap")
    a = ap.parse_args()
    GP.PUSH, GP.BETA, GP.CAP, GP.KICK = bool(a.push), a.beta, a.cap, bool(a.kick)
    set_rule(a.rule)
    if a.drop is not None:
        P.STACK_DROP = a.drop
    if a.pair_mu is not None:
        import gasp_core.mpm.fields as F
        import gasp_warp_mpm.fields as WF
        F.field_friction = WF.field_friction = lambda setup: a.pair_mu
    from gap_fall import landed
    tag = f"{a.engine} rule {a.rule} push {a.push}{' KICK' if a.kick else ''} beta {a.beta:g} cap {a.cap:g} mu {a.pair_mu} drop {a.drop}"
    for row in a.rows.split(","):
        f = row.split(":")
        t0 = time.time()
        if f[0] == "stacked" and a.diag:
            out = diagnose(a.engine, float(f[1]), int(f[2]))
        elif f[0] == "stacked":
            out = f"gap at rest {stacked(a.engine, float(f[1]), int(f[2])):+.3f} dx"
        elif f[0] == "energy":
            ke = energy(a.engine, float(f[1]), int(f[2]), a.energy_frames)
            th = np.array_split(ke[1:], 3)
            out = "KE thirds " + " ".join(f"{float(t.mean()):.3e}" for t in th) + f" J; last/second {th[2].mean() / max(th[1].mean(), 1e-30):.2f}"
        else:
            out = f"gap at rest {landed(a.engine, f[0], 0.06, int(f[1]), 1.5, a.frames)[0]:+.3f} dx"
        print(f"{tag} {row}: {out} [{time.time() - t0:.0f} s]", flush=True)


if __name__ == "__main__":
    main()
