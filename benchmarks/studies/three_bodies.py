"""Round 61 (issue 67 item 4, ``docs/contact.md`` "Round 61: a field per body by colouring"): three soft bodies on the
particle contact, coloured into the two fields (``gasp_core.mpm.colouring``) or, with ``--before``, in one shared
field (the rule before). Prints per case the figures ``tests/test_three_bodies.py`` checks and the seconds a frame.

    python benchmarks/studies/three_bodies.py --engine warp_mpm [--before] [--cases stack,slide,fall] [--grids 24,32]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from gasp_core.seam import build_engine, get_engine
from gasp_core.testing import scenes_three as S

#: The stack's figures: the gaps averaged over the last this many seconds of ``STACK_T``.
STACK_T, STACK_AVG_T = 1.0, 0.5
#: The slide's run, s (the slide is over at about 0.1 s), and its frames a second.
SLIDE_T = 0.3


def stack_gaps(engine: str, shape: str, n_grid: int, n: int = 3) -> tuple[list[float], float]:
    """``([gap 0-1, gap 1-2] in dx, seconds a frame)``: the stacked bodies' interfaces' gaps averaged over the last
    ``STACK_AVG_T`` s (``n`` 2: the two-body stack, one gap)."""
    s = S.stack3(shape, n_grid, n)
    e = build_engine(get_engine(engine), s)
    frames = round(STACK_T * 30)
    keep = round(STACK_AVG_T * 30)
    body = np.asarray(s.body_id)
    gaps = []
    t0 = time.perf_counter()
    for f in range(frames):
        e.step_frame()
        if f >= frames - keep:
            gaps.append(S.surface_gaps(e.positions().astype(float), body, s.p_vol, [(k, k + 1) for k in range(n - 1)]))
    sec = (time.perf_counter() - t0) / frames
    e.close()
    return list(np.mean(gaps, 0) / s.dx), sec


def slide(engine: str, n_grid: int, friction=None, options=None) -> tuple[float, float, float, float]:
    """``(d / d0 - 1, v_lower / v_f - 1, the middle block's slide on the bottom one in mm, seconds a frame)``: the top
    block's slide on the two below against ``V0^2 / (2 mu g (1 + m1 / (m2 + m3)))`` (the lower two move as one:
    the middle one's friction on the bottom one, at most ``mu m1 g m3 / (m2 + m3)``, is within ``mu (m1 + m2) g``),
    and their common final velocity ``V0 m1 / (m1 + m2 + m3)``."""
    from gasp_core.mpm import fields
    s = S.slide3(n_grid, friction, options=options)
    pm = np.asarray(s.p_mass, float)
    body = np.asarray(s.body_id)
    m = np.array([pm[body == b].sum() for b in range(3)])
    mu = fields.combine_friction(*(fields.body_friction(x) for x in s.materials[:2]))
    v0 = 0.5
    d0 = v0 ** 2 / (2 * mu * S.G * (1 + m[0] / (m[1] + m[2])))
    vf = v0 * m[0] / m.sum()
    e = build_engine(get_engine(engine), s)
    fps = round(1 / s.frame_dt)
    X = [np.asarray(s.x, float)]
    t0 = time.perf_counter()
    for _ in range(round(SLIDE_T * fps)):
        e.step_frame()
        X.append(e.positions().astype(float))
    sec = (time.perf_counter() - t0) / (len(X) - 1)
    e.close()
    X = np.array(X)
    c = np.array([(X[:, body == b, 0] * pm[body == b]).sum(1) / m[b] for b in range(3)])   # (3, frames)
    low = (c[1] * m[1] + c[2] * m[2]) / (m[1] + m[2])
    sep = c[0] - low
    k = round(0.1 * fps)
    v2 = (low[-1] - low[-1 - k]) * fps / k
    mid = (c[1] - c[2])[-1] - (c[1] - c[2])[0]
    return float((sep[-1] - sep[0]) / d0 - 1), float(v2 / vf - 1), 1000 * float(mid), sec


def fall(engine: str, gap_cells: float, n_grid: int, factor: int = 1) -> tuple[float, float, float]:
    """``(v_z of body 1 / (-g t) - 1, v_z of body 2 / (-g t) - 1, seconds a frame)`` after one frame (1/30 s) at
    ``factor`` times the default substeps."""
    from gasp_core.mpm.grid_engine import grid_substeps
    s = S.fall3(gap_cells, n_grid)
    if factor != 1:
        s.options["n_substeps"] = grid_substeps(s) * factor
    e = build_engine(get_engine(engine), s)
    t0 = time.perf_counter()
    e.step_frame()
    sec = time.perf_counter() - t0
    v = np.asarray(e.velocities(), float)
    e.close()
    body = np.asarray(s.body_id)
    g = -S.G * s.frame_dt
    return float(v[body == 1, 2].mean() / g - 1), float(v[body == 2, 2].mean() / g - 1), sec


def land(engine: str, n_grid: int = 32, frames: int = 60, pair: bool = False) -> tuple[float, float, float]:
    """``(the ball's gap over the slab, the cube's, in dx, seconds a frame)`` averaged over the last 15 frames of
    ``frames`` (``scenes_three.land3``: the ball dropped from out of reach onto the slab beside the cube); ``pair``:
    without the cube (two bodies, the same measure; the cube's gap then nan)."""
    s = S.land3(n_grid)
    if pair:
        keep = np.asarray(s.body_id) != 1
        s = S.SimSetup(x=s.x[keep], v=s.v[keep], p_vol=np.asarray(s.p_vol)[keep],
                       body_id=np.where(np.asarray(s.body_id)[keep] == 2, 1, 0), materials=s.materials[:2],
                       gravity=s.gravity, domain_lo=s.domain_lo, domain_hi=s.domain_hi, n_grid=s.n_grid,
                       boundaries=s.boundaries, frame_dt=s.frame_dt)
    e = build_engine(get_engine(engine), s)
    body = np.asarray(s.body_id)
    pairs = [(0, 1)] if pair else [(0, 2), (0, 1)]
    rows = []
    t0 = time.perf_counter()
    for _ in range(frames):
        e.step_frame()
        rows.append(S.surface_gaps(e.positions().astype(float), body, s.p_vol, pairs))
    sec = (time.perf_counter() - t0) / frames
    e.close()
    g = np.mean(rows[-15:], 0) / s.dx
    return float(g[0]), float(g[1]) if not pair else float("nan"), sec


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--before", action="store_true", help="the rule before: one shared field (COLOUR False)")
    ap.add_argument("--cases", default="stack,slide,fall,land")
    ap.add_argument("--static", action="store_true", help="the colouring made once at build (RECOLOUR False)")
    ap.add_argument("--grids", default="")
    ap.add_argument("--largest-in-b", action="store_true", help="each component's largest body in B whatever slides "
                    "(SPEED_TIE infinite: the orientation by speed off)")
    ap.add_argument("--pairs", action="store_true", help="the stacks of two bodies too (the same measure)")
    a = ap.parse_args()
    from gasp_core.mpm import colouring
    colouring.COLOUR = not a.before
    colouring.RECOLOUR = not a.static
    if a.largest_in_b:
        colouring.SPEED_TIE = float("inf")
    cases = a.cases.split(",")
    grids = [int(g) for g in a.grids.split(",") if g]
    if "stack" in cases:
        for shape in ("ball", "cube"):
            for ng in grids or (24, 32):
                for n in (2, 3) if a.pairs else (3,):
                    g, sec = stack_gaps(a.engine, shape, ng, n)
                    print(f"stack {a.engine} {shape} x{n} n_grid {ng}: gaps {' '.join(f'{x:+.3f}' for x in g)} dx, "
                          f"{sec:.2f} s/frame", flush=True)
    if "slide" in cases:
        for ng, mu in ((48, None), (32, 0.3)) if not grids else [(g, None) for g in grids]:
            r = slide(a.engine, ng, mu)
            print(f"slide {a.engine} n_grid {ng} mu {mu}: d {100 * r[0]:+.1f} %, v_low {100 * r[1]:+.1f} %, "
                  f"middle on bottom {r[2]:+.2f} mm, {r[3]:.2f} s/frame", flush=True)
    if "fall" in cases:
        for gap in (0.3, 1.0):
            for ng in grids or (32,):
                r = fall(a.engine, gap, ng)
                print(f"fall {a.engine} gap {gap} dx n_grid {ng}: v_z {100 * r[0]:+.2f} %, {100 * r[1]:+.2f} %, "
                      f"{r[2]:.2f} s/frame", flush=True)


    if "land" in cases:
        for pair in (False, True) if a.pairs else (False,):
            r = land(a.engine, pair=pair)
            print(f"land {a.engine} n_grid 32{' (no cube)' if pair else ''}: ball {r[0]:+.3f} dx, cube {r[1]:+.3f} dx, "
                  f"{r[2]:.2f} s/frame", flush=True)


if __name__ == "__main__":
    main()
