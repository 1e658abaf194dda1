"""Round 61 (issue 67/66, ``docs/contact.md`` "Round 61: a touch that reads the curvature"): the gap at rest of two
jelly bodies on the particle contact under the touch by geometry's rules, per scene, one engine.

Rules: ``curve`` (``gasp_core.mpm.gap_touch.CURVATURE``: the level at half a point spacing plus the smoothing's
curvature shift, no separation), ``sep0.5`` (round 60: the half-space level at ``(0.5 + SEPARATION)`` spacings,
SEPARATION 0.5), ``sep0`` (the same at SEPARATION 0). Scenes: ``stacked`` (``gasp_core.testing.scenes_pairs``'s
``stacked_gap``: two balls in a frictionless tube, the gap over the last 0.5 s of 1 s, ``tests/test_stacked_balls.py``'s
measure) at a radius and n_grid; ``ball`` / ``cube`` / ``cylinder`` on the box (``gasp_core.testing.helpers.
body_over_box``, dropped 1.5 dx, the gap at rest the mean of the last 5 of ``--frames`` 40: ``gap_fall.landed``).
Gaps are the lattices' surfaces' (``surface_gap``: nearest points less half of each one's spacing), in dx.

Usage: ``python benchmarks/studies/gap_curve.py --engine warp_mpm --rules curve,sep0.5 --rows
stacked:0.05:24,ball:32,cube:32`` (a stacked row ``stacked:R:n_grid``, a body row ``shape:n_grid``); ``--pair-mu
0``: the two fields' contact frictionless; ``--drop 0``: the stacked balls start with their lattices' surfaces
touching (the scene's ``STACK_DROP``, 1.5 dx; round 61's "the stacked balls' sink").
"""
import argparse
import dataclasses
import time

import numpy as np

import gasp_core.mpm.gap_touch as G
import gasp_core.testing.scenes_pairs as P
from gasp_core.seam.plugins import get_engine
from gasp_core.testing.kit import run_trace


def stacked(engine, radius, n_grid):
    """The stacked balls' gap at rest (dx) at ``radius`` (m) and ``n_grid`` (the scene's module globals patched)."""
    keep = P.STACK_R, P.N_GRID, P.DX
    P.STACK_R, P.N_GRID, P.DX = radius, n_grid, P.SIDE / n_grid
    try:
        s = dataclasses.replace(P._build_stack(None), options={"threads": 1})
        tr = run_trace(get_engine(engine), s, round(P.STACK_T * 30))
        (c,) = P._eval_stack(None, tr)
        return c.figures["signed"]
    finally:
        P.STACK_R, P.N_GRID, P.DX = keep


def set_rule(rule):
    G.CURVATURE = rule == "curve"
    G.SEPARATION = 0.5 if rule == "sep0.5" else 0.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--rules", default="curve,sep0.5")
    ap.add_argument("--pair-mu", type=float, default=None, help="the pair's Coulomb coefficient instead of "
                    "gasp_core.mpm.fields.field_friction's (0.5 for the jelly pairs)")
    ap.add_argument("--frames", type=int, default=40, help="the bodies on the box: frames after the drop (the "
                    "jelly ball at n_grid 48 bounces for about 25)")
    ap.add_argument("--rows", default="stacked:0.05:24,stacked:0.05:32,stacked:0.075:24,ball:32,ball:48,cube:32,"
                                      "cube:48,cylinder:32")
    ap.add_argument("--drop", type=float, default=None, help="the stacked balls: the top ball's start above the "
                    "touch, dx (the scene's STACK_DROP, 1.5)")
    a = ap.parse_args()
    if a.drop is not None:
        P.STACK_DROP = a.drop
    if a.pair_mu is not None:   # the contact's friction between the two fields (both engines read it at allocation)
        import gasp_core.mpm.fields as F
        import gasp_warp_mpm.fields as WF
        F.field_friction = WF.field_friction = lambda setup: a.pair_mu
    import sys
    sys.path.insert(0, "benchmarks/studies")
    from gap_fall import landed
    for row in a.rows.split(","):
        f = row.split(":")
        for rule in a.rules.split(","):
            set_rule(rule)
            t0 = time.time()
            if f[0] == "stacked":
                gap = stacked(a.engine, float(f[1]), int(f[2]))
            else:
                gap = landed(a.engine, f[0], 0.06, int(f[1]), 1.5, a.frames)[0]
            print(f"{a.engine} {row} rule {rule}: gap at rest {gap:+.3f} dx [{time.time() - t0:.0f} s]", flush=True)


if __name__ == "__main__":
    main()
