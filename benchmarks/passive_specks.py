"""The passive surface points left away from the material (issue 66, "What a user sees", round 37): per frame, the
passive points further than 1 ``dx`` from every material point (:mod:`gasp_core.testing.specks`), with the passive
gather of the engines before round 38 (by the B-spline weight alone, renormalised over the nodes with mass), the two
mass-weighted variants measured in round 37, round 38's spanned gather and round 39's (its mean read at the
material's centroid, the rule since; :data:`GATHERS`, :func:`rule`), on a
family: the brittle ball with a skin of passive points landing at 2, 4, 7 and 10 m/s (n_grid 32, 20 frames), a pulled
dog-bone built through a scene (``benchmarks/user_tension.py``'s ``dogbone_2to1`` at n_grid 24, one set box from t =
0), the oblique 1.5:1 dog-bone at 45 deg (``benchmarks/user_oblique.py``, n_grid 48) and
``examples/donut_shatter.toml`` (its own grid, ``--donut-frames`` frames).

Run: ``python benchmarks/passive_specks.py --engine taichi_mpm`` (and ``warp_mpm``; ``--only``
``ball,dogbone,oblique,oblique2,donut``, ``--gather``, ``--mirror new,old``: the set box's ghost rule, :func:`mirror`;
``--image new,old``: its image gradient, :func:`image`),
one engine per process; rows are added to
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
OBLIQUE2_FRAMES = 1200   # the 2:1 at 45 deg, n_grid 48: as long (a set box pulled specimen past its break)


#: the gathers measured: (by mass, the fit read at the point, the gradient along the spanned directions only, where
#: the mean is read: ``grid_tables.PASSIVE_MEAN_AT``)
GATHERS = {"before": (False, False, False, "weights"), "mass": (True, False, False, "weights"),
           "mass_at_point": (True, True, False, "weights"), "spanned": (True, True, True, "weights"),
           "material": (True, True, True, "material"), "unspanned": (True, True, True, "unspanned")}


@contextlib.contextmanager
def rule(engine: str, gather: str):
    """The engine's passive gather ``gather`` (:data:`GATHERS`): ``before``, the rule (by the B-spline weight alone,
    renormalised over the nodes with mass); ``mass``, weighted by the nodes' mass, the mean read at the weights'
    centroid; ``mass_at_point``, weighted by mass, the least-squares fit read at the point; ``spanned``, weighted by
    mass, the mean at the centroid plus the fitted gradient along the directions the material spans, read at the
    point (``grid_tables.PASSIVE_SPANNED``, round 38); ``material``, the same with the mean read at the material's
    centroid (the nodes by their mass alone), ``unspanned``, round 38's moved there along the directions the material
    does not span (round 39, the rule; ``grid_tables.PASSIVE_MEAN_AT``)."""
    from gasp_core.mpm import grid_tables
    if gather not in GATHERS:
        raise ValueError(f"--gather: one of {sorted(GATHERS)}, got {gather!r}")
    by_mass, at_point, spanned, mean_at = GATHERS[gather]
    old_spanned = grid_tables.PASSIVE_SPANNED, grid_tables.PASSIVE_MEAN_AT
    grid_tables.PASSIVE_SPANNED, grid_tables.PASSIVE_MEAN_AT = spanned, mean_at
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.transfers import Transfers as T
        old = T.PASSIVE_BY_MASS, T.PASSIVE_AT_POINT
        T.PASSIVE_BY_MASS, T.PASSIVE_AT_POINT = by_mass, at_point
        try:
            yield
        finally:
            T.PASSIVE_BY_MASS, T.PASSIVE_AT_POINT = old
            grid_tables.PASSIVE_SPANNED, grid_tables.PASSIVE_MEAN_AT = old_spanned
    else:
        from gasp_warp_mpm import kernels, transfers
        old = transfers.PASSIVE_BY_MASS, transfers.PASSIVE_AT_POINT

        def clear():
            transfers.build_g2p_passive.cache_clear()
            transfers.build_spanned_inverse.cache_clear()
            kernels.build_kernels.cache_clear()
        transfers.PASSIVE_BY_MASS, transfers.PASSIVE_AT_POINT = by_mass, at_point
        clear()
        try:
            yield
        finally:
            transfers.PASSIVE_BY_MASS, transfers.PASSIVE_AT_POINT = old
            grid_tables.PASSIVE_SPANNED, grid_tables.PASSIVE_MEAN_AT = old_spanned
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


def oblique_setup(engine: str, name: str = "dogbone_1.5to1"):
    """``user_oblique``'s dog-bone ``name`` at 45 deg, n_grid 48, ramped set box (the 1.5:1: round 36's material
    bursts by the pulled grip at frames 627-628 and 848)."""
    _user_tension()
    import user_oblique as uo
    ps, _ = uo.prepare(uo.SPECIMENS[name], 48, engine, "45")
    return ps.setup


@contextlib.contextmanager
def rule_switch(engine: str, flag: str, which: str, option: str, caches=()):
    """Run with ``grid_tables.<flag>`` on (``which == "new"``) or off (``"old"``), the kernel builders named in
    ``caches`` (``(module, function)`` of ``gasp_warp_mpm``) cleared on the way in and out so warp_mpm rebuilds with
    it (taichi_mpm reads the flag when it builds). Raises ``ValueError`` naming ``option`` on another ``which``."""
    import importlib

    from gasp_core.mpm import grid_tables
    if which not in ("new", "old"):
        raise ValueError(f"{option}: 'new' or 'old', got {which!r}")
    old = getattr(grid_tables, flag)

    def clear():
        if engine == "warp_mpm":
            for mod, fn in caches:
                getattr(importlib.import_module(f"gasp_warp_mpm.{mod}"), fn).cache_clear()
    setattr(grid_tables, flag, which == "new")
    clear()
    try:
        yield
    finally:
        setattr(grid_tables, flag, old)
        clear()


def mirror(engine: str, which: str):
    """The set box's ghost rule: ``new``, image nodes by mass (``grid_tables.MIRROR_BY_MASS``, round 37); ``old``,
    any image node with mass at full weight (the rule before)."""
    return rule_switch(engine, "MIRROR_BY_MASS", which, "--mirror", [("held", "build_mirror")])


def image(engine: str, which: str):
    """A set box's point's image gradient: ``new``, the image's nodes by mass against their mirror node
    (``grid_tables.IMAGE_BY_MASS``, round 40); ``old``, every image node with mass at full weight (the rule before)."""
    return rule_switch(engine, "IMAGE_BY_MASS", which, "--image",
                       [("held_rule", "build_image_C"), ("held_rule", "build_held_g2p"), ("transfers", "build_g2p"),
                        ("kernels", "build_kernels")])


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
    if "oblique2" in only:
        yield "dogbone_2to1 45 deg n_grid 48", lambda: oblique_setup(engine, "dogbone_2to1"), OBLIQUE2_FRAMES
    if "donut" in only:
        yield "donut_shatter", lambda: donut_setup(engine), donut_frames


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", required=True)
    ap.add_argument("--only", default="ball,dogbone,oblique,donut")
    ap.add_argument("--donut-frames", type=int, default=10)
    ap.add_argument("--gather", default="before,mass,mass_at_point,spanned", help="the gathers to run (GATHERS)")
    ap.add_argument("--mirror", default="new", help="the set box's ghost rules to run: new, old (mirror)")
    ap.add_argument("--image", default="new", help="the set box's image gradient rules to run: new, old (image)")
    a = ap.parse_args()
    rows = json.loads(OUT.read_text()) if OUT.exists() else []
    runs = [(g, m, i) for g in a.gather.split(",") for m in a.mirror.split(",") for i in a.image.split(",")]
    for name, build, n_frames in cases(a.engine, set(a.only.split(",")), a.donut_frames):
        for gather, mir, img in runs:
            t0 = time.perf_counter()
            with rule(a.engine, gather), mirror(a.engine, mir), image(a.engine, img):
                r = speck_run(a.engine, build(), n_frames)
            row = {"case": name, "engine": a.engine, "gather": gather, "mirror": mir, "image": img, "frames": n_frames,
                   "specks": r["specks"],
                   "specks_1.5": r["specks_1.5"], "specks_3": r["specks_3"],
                   "farthest_dx": [round(f, 2) for f in np.asarray(r["farthest"]) / r["dx"]],
                   "vmax_cells": [round(v * r["dt"] / r["dx"], 3) for v in r["vmax"]],
                   "n_passive": r["n_passive"], "wall_s": round(time.perf_counter() - t0, 1)}
            print(json.dumps(row), flush=True)
            rows = [x for x in rows if _key(x) != (name, a.engine, gather, mir, img)]
            rows.append(row)
            OUT.write_text(json.dumps(rows, separators=(",", ":")))
    write_md(rows)


def _key(r: dict) -> tuple:
    """A row's case, engine, gather, set box ghost rule and image rule (rows before round 37's and round 40's fixes:
    the old rules)."""
    return r["case"], r["engine"], r["gather"], r.get("mirror", "old"), r.get("image", "old")


def write_md(rows: list[dict]) -> None:
    lines = ["# Passive surface points away from the material (issue 66, rounds 37 to 39)", "",
             "`python benchmarks/passive_specks.py` (docstring). Specks: passive points further than 1 dx from every "
             "material point, per frame (every 5th frame shown, or a tenth of the run's, and the last); farthest: "
             "the largest such distance over the passive points at the last frame, in dx. `before`: the gather by "
             "the B-spline weight alone, "
             "renormalised over the nodes with mass (the rule); `mass`: weighted by the nodes' mass, the mean read at "
             "the weights' centroid; `mass_at_point`: weighted by mass, the fit read at the point (round 37; neither "
             "adopted, docs/fracture.md \"Round 37\"); `spanned`: weighted by mass, the mean at the centroid plus "
             "the fitted gradient along the directions the material spans, read at the point (round 38, "
             "`grid_tables.PASSIVE_SPANNED`, docs/fracture.md \"Round 38\"); `material`: the same with the mean "
             "read at the material's centroid, the nodes by their mass alone; `unspanned`: round 38's moved there "
             "along the directions the material does not span (round 39, the rule, `grid_tables.PASSIVE_MEAN_AT`, "
             "docs/fracture.md \"Round 39\"). "
             "Set box rule: `old`, the ghost nodes take any image node "
             "with mass at full weight (and every row without a set box); `new`, by its mass over the ghost's "
             "(`--mirror`, round 37's fix). Image rule: `old`, a set box's point near its face gathers its image "
             "gradient from every image node with mass at full weight; `new`, each by its mass over its mirror node's "
             "(`--image`, round 40, `grid_tables.IMAGE_BY_MASS`). Fastest: the material points' largest speed over "
             "the run, in cells a substep.", "",
             "| case | engine | gather | set box rule | image rule | passive points | specks at frames 0, 5, 10, ... "
             "and last | peak | farthest at the last / over the run (dx) | fastest | s |", "|" + "---|" * 11]
    for r in sorted(rows, key=_key):
        s = r["specks"]
        step = max(5, (len(s) - 1) // 10)
        shown = s[::step] + ([s[-1]] if (len(s) - 1) % step else [])
        lines.append(f"| {r['case']} | {r['engine']} | {r['gather']} | {_key(r)[3]} | {_key(r)[4]} | "
                     f"{r['n_passive']} | {' / '.join(str(x) for x in shown)} | {max(s)} | {r['farthest_dx'][-1]} / "
                     f"{max(r['farthest_dx'])} | {max(r['vmax_cells'])} | {r['wall_s']} |")
    (RESULTS / "passive_specks.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
