"""The passive surface points left away from the material (issue 66, "What a user sees", round 37): per frame, the
passive points further than 1 ``dx`` from every material point (:mod:`gasp_core.testing.specks`), with the passive
gather of the engines (by the B-spline weight alone, renormalised over the nodes with mass) and the two mass-weighted
variants measured in round 37 (:data:`GATHERS`, :func:`rule`), on a family: the brittle ball with a skin of passive
points landing at 2, 4, 7 and 10 m/s (n_grid 32, 20 frames), a pulled dog-bone built through a scene
(``benchmarks/user_tension.py``'s ``dogbone_2to1`` at n_grid 24, one set box from t = 0), the oblique 1.5:1 dog-bone
at 45 deg (``benchmarks/user_oblique.py``, n_grid 48) and ``examples/donut_shatter.toml`` (its own grid,
``--donut-frames`` frames).

Run: ``python benchmarks/passive_specks.py --engine taichi_mpm`` (and ``warp_mpm``; ``--only``
``ball,dogbone,oblique,donut``, ``--gather``), one engine per process; rows are added to
``benchmarks/results/passive_specks.json`` and ``passive_specks.md`` is written from it.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time
from pathlib import Path

import numpy as np

from gasp_core.testing.specks import ball_with_skin, speck_run

RESULTS = Path(__file__).resolve().parent / "results"
OUT = RESULTS / "passive_specks.json"
SPEEDS = (2.0, 4.0, 7.0, 10.0)
BALL_FRAMES = 20
OBLIQUE_FRAMES = 1125   # user_oblique.run_case's for the 1.5:1 at 45 deg, n_grid 48 (docs/fracture.md, round 36)


#: the gathers measured: (by mass, the fit read at the point)
GATHERS = {"before": (False, False), "mass": (True, False), "mass_at_point": (True, True)}


@contextlib.contextmanager
def rule(engine: str, gather: str):
    """The engine's passive gather ``gather`` (:data:`GATHERS`): ``before``, the rule (by the B-spline weight alone,
    renormalised over the nodes with mass); ``mass``, weighted by the nodes' mass, the mean read at the weights'
    centroid; ``mass_at_point``, weighted by mass, the least-squares fit read at the point."""
    by_mass, at_point = GATHERS[gather]
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.transfers import Transfers as T
        old = T.PASSIVE_BY_MASS, T.PASSIVE_AT_POINT
        T.PASSIVE_BY_MASS, T.PASSIVE_AT_POINT = by_mass, at_point
        try:
            yield
        finally:
            T.PASSIVE_BY_MASS, T.PASSIVE_AT_POINT = old
    else:
        from gasp_warp_mpm import kernels, transfers
        old = transfers.PASSIVE_BY_MASS, transfers.PASSIVE_AT_POINT

        def clear():
            transfers.build_g2p_passive.cache_clear()
            kernels.build_kernels.cache_clear()
        transfers.PASSIVE_BY_MASS, transfers.PASSIVE_AT_POINT = by_mass, at_point
        clear()
        try:
            yield
        finally:
            transfers.PASSIVE_BY_MASS, transfers.PASSIVE_AT_POINT = old
            clear()


def dogbone_setup(engine: str, n_grid: int = 24):
    """``user_tension``'s ``dogbone_2to1`` built through its scene (passive surface, one set box from t = 0)."""
    ut = _user_tension()
    sp = next(s for s in ut.tf.FAMILY if s.name == "dogbone_2to1")
    ps, _ = ut.prepare(sp, n_grid, engine)
    return ps.setup


def dogbone_frames() -> int:
    """The frames ``user_tension.run_user_case`` runs the dog-bone at a step start: to the peak and 1.5 times the
    opening ``2 G_f / f_t`` past it."""
    ut = _user_tension()
    tf = ut.tf
    sp = next(s for s in tf.FAMILY if s.name == "dogbone_2to1")
    clamp, pulled = ut.faces(sp, 24)
    t_peak = (tf.FT / tf.E) * float(sp.gauge_w ** 2) * float(np.diff(np.interp([clamp, pulled],
                                                                                 *ut._compliance(sp)))[0]) / tf.PULL
    return int(np.ceil((t_peak + 1.5 * 2 * tf.GF / tf.FT / tf.PULL) / tf.FRAME_DT))


def _user_tension():
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import user_tension as ut
    return ut


def oblique_setup(engine: str):
    """``user_oblique``'s 1.5:1 dog-bone at 45 deg, n_grid 48, ramped set box (round 36's material bursts by the
    pulled grip at frames 627-628 and 848) and the frames ``user_oblique.run_case`` runs it."""
    _user_tension()
    import user_oblique as uo
    sp = uo.SPECIMENS["dogbone_1.5to1"]
    ps, _ = uo.prepare(sp, 48, engine, "45")
    return ps.setup


def donut_setup(engine: str):
    """``examples/donut_shatter.toml`` prepared for ``engine``."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    path = Path(__file__).resolve().parents[1] / "examples" / "donut_shatter.toml"
    return prepare_scene(load_scene(path), engine).setup


def cases(engine: str, only: set[str], donut_frames: int):
    if "ball" in only:
        for v in SPEEDS:
            yield f"ball {v:g} m/s", lambda v=v: ball_with_skin(v, 32), BALL_FRAMES
    if "dogbone" in only:
        yield "dogbone_2to1 n_grid 24", lambda: dogbone_setup(engine), dogbone_frames()
    if "oblique" in only:
        yield "dogbone_1.5to1 45 deg n_grid 48", lambda: oblique_setup(engine), OBLIQUE_FRAMES
    if "donut" in only:
        yield "donut_shatter", lambda: donut_setup(engine), donut_frames


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", required=True)
    ap.add_argument("--only", default="ball,dogbone,oblique,donut")
    ap.add_argument("--donut-frames", type=int, default=10)
    ap.add_argument("--gather", default="before,mass,mass_at_point", help="the gathers to run (GATHERS)")
    a = ap.parse_args()
    rows = json.loads(OUT.read_text()) if OUT.exists() else []
    for name, build, n_frames in cases(a.engine, set(a.only.split(",")), a.donut_frames):
        for gather in a.gather.split(","):
            t0 = time.perf_counter()
            with rule(a.engine, gather):
                r = speck_run(a.engine, build(), n_frames)
            row = {"case": name, "engine": a.engine, "gather": gather, "frames": n_frames, "specks": r["specks"],
                   "specks_1.5": r["specks_1.5"], "specks_3": r["specks_3"],
                   "farthest_dx": [round(f, 2) for f in np.asarray(r["farthest"]) / r["dx"]],
                   "vmax_cells": [round(v * r["dt"] / r["dx"], 3) for v in r["vmax"]],
                   "n_passive": r["n_passive"], "wall_s": round(time.perf_counter() - t0, 1)}
            print(json.dumps(row), flush=True)
            rows = [x for x in rows if (x["case"], x["engine"], x["gather"]) != (name, a.engine, gather)]
            rows.append(row)
            OUT.write_text(json.dumps(rows, indent=1))
    write_md(rows)


def write_md(rows: list[dict]) -> None:
    lines = ["# Passive surface points away from the material (issue 66, round 37)", "",
             "`python benchmarks/passive_specks.py` (docstring). Specks: passive points further than 1 dx from every "
             "material point, per frame (every 5th frame shown, or a tenth of the run's, and the last); farthest: "
             "the largest such distance over the passive points at the last frame, in dx. `before`: the gather by "
             "the B-spline weight alone, "
             "renormalised over the nodes with mass (the rule); `mass`: weighted by the nodes' mass, the mean read at "
             "the weights' centroid; `mass_at_point`: weighted by mass, the fit read at the point (round 37; neither "
             "adopted, docs/fracture.md \"Round 37\").", "",
             "| case | engine | gather | passive points | specks at frames 0, 5, 10, ... and last | peak | "
             "farthest at the last (dx) | s |", "|---|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: (r["case"], r["engine"], r["gather"])):
        s = r["specks"]
        step = max(5, (len(s) - 1) // 10)
        shown = s[::step] + ([s[-1]] if (len(s) - 1) % step else [])
        lines.append(f"| {r['case']} | {r['engine']} | {r['gather']} | {r['n_passive']} | "
                     f"{' / '.join(str(x) for x in shown)} | {max(s)} | {r['farthest_dx'][-1]} | {r['wall_s']} |")
    (RESULTS / "passive_specks.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
