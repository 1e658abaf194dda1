"""Run on past the break (issue 66, the bending must-show's loose end; docs/fracture.md "The held region"): a brittle
body broken through beside a ``fixed_region`` is a falling piece beside a clamp whose face is now free of traction,
and the run goes on. The family, on the MPM engines:

- the cantilevers of ``benchmarks/bending_family.py`` at depths of 8 and 12 cells at 0.6 ``sigma_max`` (they break
  through at the root face), frames of 1/20 of the first mode's period, in a cube ``MARGIN`` cells past the tip (the
  piece has room to fall);
- the tension bar of ``benchmarks/tension_family.py`` (``bar_L0.5_a0.15``, n_grid 24) hung from its clamp: gravity
  along the bar (+x, from the clamp to the pulled end), the pulled box (``mode = "set"``, ``BAR_PULL`` m/s) acting
  until ``BAR_STOP`` s; with its weight on top of the pull it breaks through at the clamp's face, then falls.

Each runs ``AFTER`` frames (50 the cantilevers, 25 the bar) past the frame a lattice layer across it is broken
through (every point ``d >= 0.9``), or until a point comes within ``EDGE`` cells of the grid's edge (the boundary
nodes would hold the piece).
Measured: ``through_at_cells`` (the rest distance of each layer broken through from the held face, cells; a held
layer's negative), ``diverged`` (the engine's check), ``held_stretch`` (the largest principal stretch of any held point over
the run), ``separated`` (the first frame, once broken through and the pulled box stopped, that a part of 1 % of the
mass or more holding no held point is apart from the rest: the frames alone, the links of
:class:`gasp_core.testing.pieces_count.FramePieces` cut past rest + ``CLEAR`` cells, beyond the reach of two
quadratic stencils, so no grid node is shared), ``piece_share`` (that part's share of the mass), ``accel_over_g``
(its acceleration along gravity: a least-squares parabola through its centre of mass from ``separated`` to the end,
over ``|g|``).

Run: ``python benchmarks/run_on_family.py --engine taichi_mpm`` (and ``--engine warp_mpm``); prints one JSON line a
case and keeps them in ``benchmarks/results/run_on_family.{json,md}`` (the other engine's rows kept). One engine per
process.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bending_family as bf   # noqa: E402
import tension_family as tf   # noqa: E402

AFTER = {"cantilever": 50, "bar": 25}   # frames run past the break
MARGIN = 25            # cells of the cantilevers' cube past the tip
EDGE = 4               # cells: a run stops once a point comes this near the grid's edge
CLEAR = 3.0            # cells: a part is apart once this far past its rest neighbours (two stencils' reach)
BAR, BAR_GRID, BAR_PULL, BAR_STOP, BAR_DT = tf.FAMILY[0], 24, 0.1, 0.05, 0.01
CASES = ("cantilever_h8", "cantilever_h12", "bar_hung")
RESULTS = Path(__file__).resolve().parent / "results"


def cantilever(depth: int, engine: str):
    """The cantilever of ``depth`` cells at 0.6 ``sigma_max``: ``(setup, held face x, gravity axis, t_free)``."""
    c = bf.Case("cantilever", depth, 0.6)
    frames, periods = bf.FRAMES, bf.PERIODS
    bf.FRAMES, bf.PERIODS = 60, 3.0
    try:
        st, axis, face, n = bf.build(c, engine, margin=MARGIN)
    finally:
        bf.FRAMES, bf.PERIODS = frames, periods
    return st, face, 2, 0.0


def bar_hung(engine: str):
    """The tension bar hung from its clamp and pulled until ``BAR_STOP``: ``(setup, clamp face x, gravity axis,
    t_free)``."""
    from gasp_core.colliders.model import Impulse
    st, layer, lx, clamp, pulled = tf.build(BAR, BAR_GRID, engine)
    st.v = np.asarray(st.v, float) * (BAR_PULL / tf.PULL)
    st.gravity = np.array([bf.G, 0.0, 0.0])
    st.frame_dt = BAR_DT
    st.impulses = [Impulse("box", (BAR_PULL, 0, 0), 0.0, BAR_STOP, lo=(pulled, 0, 0), hi=(tf.SIZE,) * 3, mode="set")]
    return st, clamp, 0, BAR_STOP


def build_case(name: str, engine: str):
    """The case ``name`` (:data:`CASES`)."""
    if name == "bar_hung":
        return bar_hung(engine)
    return cantilever(int(name.split("_h")[1]), engine)


def accel(t: np.ndarray, s: np.ndarray) -> float:
    """Twice the quadratic coefficient of the least-squares parabola through ``s(t)``: the acceleration (m/s^2)."""
    return float(2 * np.polyfit(t - t[0], s, 2)[0])


def falling_part(fp, x: np.ndarray, held: np.ndarray) -> np.ndarray | None:
    """The points of the heaviest part at positions ``x`` (:class:`~gasp_core.testing.pieces_count.FramePieces`'
    links) holding no held point and at least 1 % of the mass, or None while there is none."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    a, b = fp.pairs[:, 0], fp.pairs[:, 1]
    hold = np.linalg.norm(x[a] - x[b], axis=1) <= fp.reach
    n = len(fp.mass)
    lab = connected_components(coo_matrix((np.ones(int(hold.sum())), (a[hold], b[hold])), shape=(n, n)),
                               directed=False)[1]
    m = np.bincount(lab, weights=fp.mass)
    m[np.unique(lab[held])] = 0.0
    k = int(np.argmax(m))
    return lab == k if m[k] >= 0.01 * fp.mass.sum() else None


def run_case(name: str, engine: str, build_fn=build_case) -> dict:
    """Case ``name`` on ``engine``: the figures of the module's notes."""
    from gasp_core.errors import EngineDivergence
    from gasp_core.mpm.points import held_codes
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    from gasp_core.testing.pieces_count import FramePieces
    st, face, g_axis, t_free = build_fn(name, engine)
    x0 = np.asarray(st.x, np.float64)
    dx, s = st.dx, st.dx / 2
    held = held_codes(x0, st.boundaries, dx) > 0
    axis = 0                                            # the long axis: the cantilever's and the bar's x
    mass = np.asarray(st.p_vol, np.float64) * st.materials[0].rho
    layer = np.round((x0[:, axis] - x0[:, axis].min()) / s).astype(int)
    nl = int(layer.max()) + 1
    count = np.bincount(layer, minlength=nl)
    parts = FramePieces(x0, mass, 1.5 * s, CLEAR * dx)
    g = float(np.linalg.norm(st.gravity))
    through, diverged, stretch, sep, piece, down, k, where, edge = None, None, 1.0, None, None, [], 0, [], None
    cpu = time.process_time()
    e = build_engine(engines()[engine], st)
    try:
        for k in range(1, 400):
            try:
                e.step_frame()
            except EngineDivergence as err:
                diverged = str(err).split(" (likely")[0]
                break
            d = np.asarray(e.damage(), np.float64)
            x = np.asarray(e.positions(), np.float64)
            F = np.asarray(e.to_setup_order(e.get_state()["F"]), np.float64)
            Fh = F[held]
            stretch = max(stretch, float(np.linalg.svd(Fh, compute_uv=False).max()) if np.isfinite(Fh).all()
                          else float("inf"))
            down.append(x[:, g_axis] * np.sign(st.gravity[g_axis]))
            nb = np.bincount(layer, d >= bf.BROKEN, nl)
            if through is None and np.any(nb == count):
                through = k
                rest = np.bincount(layer, x0[:, axis], nl) / count
                where = sorted({round(float(o), 2) for o in (rest[nb == count] - face) / dx})
            if sep is None and through is not None and k * st.frame_dt >= t_free:
                piece = falling_part(parts, x, held)
                sep = None if piece is None else k
            if through is not None and k >= through + AFTER[name.split("_")[0]]:
                break
            lo, hi = np.asarray(st.domain_lo) + EDGE * dx, np.asarray(st.domain_hi) - EDGE * dx
            if through is not None and np.any((x < lo) | (x > hi)):   # the grid's edge is near: stop there
                edge = k
                break
    finally:
        e.close()
    a = None
    if sep is not None and diverged is None and k - sep >= 4:
        com = np.array([np.average(z[piece], weights=mass[piece]) for z in down[sep - 1:k]])
        a = accel(np.arange(sep, k + 1) * st.frame_dt, com)
    return {"case": name, "engine": engine, "points": len(x0), "n_grid": st.n_grid, "frame_dt": st.frame_dt,
            "through_frame": through, "through_at_cells": where, "frames_run": k, "stopped_at_edge": edge,
            "diverged": diverged,
            "held_stretch": stretch, "separated_frame": sep,
            "piece_share": None if piece is None else float(mass[piece].sum() / mass.sum()),
            "accel_over_g": None if a is None else a / g, "seconds_cpu": round(time.process_time() - cpu, 1)}


def failures(r: dict, stretch_max: float = 1.25, g_tol: float = 0.05) -> list[str]:
    """What is wrong with one run: it diverged, did not break, a held point stretched past ``stretch_max``, the
    piece did not separate, or its fall is off ``g`` by more than ``g_tol`` (two-sided)."""
    bad = [f"{r['case']} on {r['engine']}: diverged at {r['diverged']}"] if r["diverged"] else []
    if r["through_frame"] is None:
        bad.append(f"{r['case']} on {r['engine']}: never broke through")
    if not r["held_stretch"] <= stretch_max:
        bad.append(f"{r['case']} on {r['engine']}: a held point stretched {r['held_stretch']:.4g}")
    if r["accel_over_g"] is None:
        bad.append(f"{r['case']} on {r['engine']}: the piece did not separate (frame {r['separated_frame']})")
    elif abs(r["accel_over_g"] - 1) > g_tol:
        bad.append(f"{r['case']} on {r['engine']}: the piece falls at {r['accel_over_g']:.3f} g")
    return bad


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="taichi_mpm")
    ap.add_argument("--only", default="", help="comma-separated case names")
    a = ap.parse_args()
    out = RESULTS / "run_on_family.json"
    rows = json.loads(out.read_text()) if out.exists() else []
    for name in (a.only.split(",") if a.only else CASES):
        r = {**run_case(name, a.engine), "failures": []}
        r["failures"] = failures(r)
        print(json.dumps(r), flush=True)
        rows = [x for x in rows if (x["case"], x["engine"]) != (name, a.engine)] + [r]
        out.write_text(json.dumps(rows, indent=1))   # each case kept as it comes, the other engine's rows kept
    keys = ("case", "engine", "through_frame", "held_stretch", "separated_frame", "accel_over_g", "failures")
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(str(x.get(k)) for k in keys) + " |" for x in rows]
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
