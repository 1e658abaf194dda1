"""The brittle README donut from 1 m, and a ball and a box at the same material (issue 66, "What a user sees": the
brittle README donut from 1 m on the default contact ends in pieces, not dust; docs/fracture.md "The brittle README
donut from 1 m").

Each body lands at 4.43 m/s (``sqrt(2 g h)``, h = 1 m) with the default contact (``contact`` unset: ``auto``) and
the brittle material at the schema's defaults (``E``, ``nu``, ``rho``, ``tensile_strength``, ``fracture_energy`` of
``gasp_core.seam.schema.MATERIAL_PARAMS``) or at the defaults before issue 66's round 31 (``OLD``: f_t 1 kPa, G_f
10 J/m^2). The bodies: ``examples/donut_jelly.toml`` with ``[object.material] name = "brittle"`` thrown down
(``tests/test_brittle_impact_step.py``'s scene, ``n_grid`` set), and the ball R 5 cm and the box 12 x 12 x 5 cm of
``benchmarks/brittle_drop_family.py`` filled as a scene fills them. After ``--frames`` frames (4: the donut's
rebound reaches its domain's top at frame 5) the pieces are counted from the frames alone
(:class:`gasp_core.testing.pieces_count.FramePieces`: rest neighbours within 1.5 fill spacings, a link holds while
within its rest length plus ``dx``, no damage read): ``pieces_1`` (parts of 1 % of the mass or more), ``largest``
(the heaviest part's share of the mass), ``in_pieces`` (the share in those pieces) and ``crumbs`` (the share of the
mass in parts under 0.1 %, the run's debris threshold ``DEBRIS_SHARE``), with the share broken through (``d >= 1``)
and ``swell`` (the cells of ``dx`` its points fill over those at rest). ``README donut placed 1 m up`` (named in
``--bodies`` only: 24 frames, about 2.5 min a run at n_grid 64) is the donut as a user drops it: placed 1 m up at
rest in the default domain (2.19 m across).

    python benchmarks/brittle_readme_donut.py [--engines taichi_mpm,warp_mpm] [--grids 48,64] [--frames 4]
        [--defaults old,new] [--bodies NAME,...] [--append]

Writes ``benchmarks/results/brittle_readme_donut.{json,md}``.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
V = 4.43                                  # m/s: a 1 m drop
OLD = {"tensile_strength": 1.0e3, "fracture_energy": 10.0}     # the defaults before round 31
SHARE, CRUMB = 0.01, 0.001                # a piece: 1 % of the mass; a crumb: under 0.1 % (DEBRIS_SHARE)
PLACED, PLACED_FRAMES = "README donut placed 1 m up", 24   # it lands at frame 14: 10 frames (0.33 s) after


def brittle(defaults: str):
    """The brittle material at the schema's defaults (``"new"``) or at :data:`OLD`'s strength (``"old"``)."""
    from gasp_core.seam.setup import Material
    m = Material("brittle")
    return dataclasses.replace(m, **OLD) if defaults == "old" else m


def donut_setup(engine: str, n_grid: int, material, placed: bool = False, surface: str | None = None):
    """``tests/test_brittle_impact_step.py``'s brittle README donut at ``n_grid``, ``material`` in place; ``placed``:
    not thrown down but placed 1 m up at rest (:func:`placed_setup`); ``surface``: the object's ``surface`` key
    (None: unset, ``"auto"``'s rule)."""
    sys.path.insert(0, str(ROOT / "tests"))
    from test_brittle_impact_step import brittle_donut_scene
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    path = brittle_donut_scene(Path(tempfile.mkdtemp()), strength="")
    text = path.read_text().replace("n_grid = 64", f"n_grid = {n_grid}")
    if placed:
        text = text.replace(f"velocity = [0.0, 0.0, {-V}]\n", "").replace("position = [0.0, 0.0, 0.05]",
                                                                         "position = [0.0, 0.0, 1.0]")
    if surface is not None:
        text = text.replace("alpha = 1.5", f'alpha = 1.5\nsurface = "{surface}"')
    path.write_text(text)
    s = prepare_scene(load_scene(path), engine).setup
    s.materials = [material]
    return s


def filled(splats, n_grid: int, material):
    """The body the ``splats`` enclose, filled with the faces' shares at ``dx / 4^(1/3)`` (the donut scene's
    spacing), landing at :data:`V` on a ground (friction 0.5), the default contact."""
    from brittle_drop_family import HI, LO
    from gasp_core.maps.fill import fill_interior
    from gasp_core.seam.setup import Boundary
    from gasp_core.testing.helpers import make_setup
    dx = (HI[0] - LO[0]) / n_grid
    fr = fill_interior(splats.reshape(-1, 3), dx / 4 ** (1 / 3), splats=splats, surface_mass=False)
    return make_setup(fr.fill_x, fr.p_vol_fill, material, v=(0.0, 0.0, -V), lo=LO, hi=HI, n_grid=n_grid,
                      frame_dt=1 / 30, boundaries=[Boundary("ground", height=0.0, friction=0.5)])


def bodies():
    """The family: name -> ``(engine, n_grid, material) -> SimSetup``."""
    from brittle_drop_family import ball_splats, box_splats
    return {"README donut": donut_setup, PLACED: placed_setup,
            "ball R 5 cm": lambda e, n, m: filled(ball_splats((0.0, 0.0, 0.055), 0.05), n, m),
            "box 12 x 12 x 5 cm": lambda e, n, m: filled(box_splats((-0.06, -0.06, 0.005), (0.06, 0.06, 0.055)), n, m)}


def occupied(x: np.ndarray, dx: float) -> int:
    """Grid cells of side ``dx`` (m) that hold at least one of the points ``x`` (n, 3), m."""
    return len(np.unique(np.floor(np.asarray(x) / dx).astype(np.int64), axis=0))


def placed_setup(engine: str, n_grid: int, material):
    """The README donut as a user drops it from 1 m: ``examples/donut_jelly.toml``'s donut made brittle, placed 1 m
    up at rest (its lowest point 1 m above the ground), the default domain (padding 0.5: 2.19 m across at n_grid
    64, dx 3.4 cm), ``material`` in place; it lands at frame 14 (4.43 m/s)."""
    return donut_setup(engine, n_grid, material, placed=True)


def counted(engine: str, setup, frames: int, cells: bool = True) -> dict:
    """Run ``setup`` ``frames`` frames on ``engine`` as a run does (``gasp_core.run.fragment_run.frames``: with
    ``cells``, a soft brittle body laid out in Grady's cells at its landing, ``gasp_core.run.grady_cells``; without,
    the engine alone, the class before round 102); the pieces from the last frame alone (module notes), and
    ``swell``: the cells of ``dx`` its points occupy over those at rest (pieces that come apart keep theirs; dust
    and a swelling cloud multiply them)."""
    from contextlib import closing
    from gasp_core.run import fragment_run
    from gasp_core.run.pieces import LINK_RADIUS
    from gasp_core.seam.plugins import engines
    from gasp_core.seam.runner import RunStats
    from gasp_core.testing.pieces_count import FramePieces
    mat = setup.p_vol > 0
    m = setup.p_mass[mat]
    ref = FramePieces(setup.x[mat], m, LINK_RADIUS * float(np.cbrt(setup.p_vol[mat].max())), setup.dx)
    info, stats = engines()[engine], RunStats()
    if not cells:   # the engine without the feature: the body runs as one soft body
        caps = dataclasses.replace(info.capabilities, features=info.capabilities.features - {"fracture_cells"})
        info = dataclasses.replace(info, capabilities=caps)
    with closing(fragment_run.frames(info, setup, stats, frames)) as recs:
        for rec in recs:
            x = np.asarray(rec.x, np.float64)
    x, d = x[mat], np.asarray(stats.damage, np.float64)[mat]
    out_cells = [f for f in stats.fragments if f.get("route") == "cells"]
    parts = ref.masses(x) / m.sum()
    return {"pieces_1": int((parts >= SHARE).sum()), "largest": float(parts[0]),
            "in_pieces": float(parts[parts >= SHARE].sum()),
            "swell": occupied(x, setup.dx) / occupied(setup.x[mat], setup.dx),
            "crumbs": float(parts[parts < CRUMB].sum()), "broken_through": float(np.average(d >= 1.0, weights=m)),
            "z_min": float(x[:, 2].min()), "points": int(mat.sum()),
            "cells": out_cells[0]["cells"] if out_cells else 0}


def main(argv=None) -> int:
    from gasp_core.seam.schema import MATERIAL_PARAMS
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", default="taichi_mpm,warp_mpm")
    ap.add_argument("--grids", default="48,64")
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--defaults", default="old,new")
    ap.add_argument("--bodies", default=",".join(b for b in bodies() if b != PLACED),
                    help=f"comma-separated; {PLACED!r} (24 frames, about 2.5 min a run) is left out unless named")
    ap.add_argument("--append", action="store_true", help="keep the rows already in the results file")
    a = ap.parse_args(argv)
    out = ROOT / "benchmarks" / "results" / "brittle_readme_donut"
    rows = json.loads(out.with_suffix(".json").read_text())["rows"] if a.append else []
    for engine in a.engines.split(","):
        for n_grid in (int(g) for g in a.grids.split(",")):
            for defaults in a.defaults.split(","):
                for name in a.bodies.split(","):
                    m = brittle(defaults)
                    r = {"engine": engine, "n_grid": n_grid, "defaults": defaults, "body": name,
                         "tensile_strength": m.tensile_strength, "fracture_energy": m.fracture_energy,
                         **counted(engine, bodies()[name](engine, n_grid, m),
                                   PLACED_FRAMES if name == PLACED else a.frames)}
                    rows.append(r)
                    print(json.dumps(r), flush=True)
    defaults = {k: MATERIAL_PARAMS[k].default for k in ("E", "nu", "rho", "tensile_strength", "fracture_energy")}
    out.with_suffix(".json").write_text(json.dumps({"frames": a.frames, "landing_m_s": V, "defaults": defaults,
                                                    "old": OLD, "rows": rows}, indent=1))
    lines = [f"# The brittle README donut from 1 m, and a ball and a box (`benchmarks/brittle_readme_donut.py`)", "",
             f"Landing at {V} m/s, default contact, {a.frames} frames ({PLACED!r}: {PLACED_FRAMES}); pieces from the "
             f"frames alone. Defaults now: "
             f"{defaults}; old: {OLD}.", "",
             "| engine | n_grid | defaults | body | pieces >= 1 % | largest | in them | crumbs (< 0.1 %) | broken "
             "through | swell |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['engine']} | {r['n_grid']} | {r['defaults']} | {r['body']} | {r['pieces_1']} | "
              f"{r['largest']:.3f} | {r['in_pieces']:.3f} | {r['crumbs']:.3f} | {r['broken_through']:.3f} | "
              f"{r['swell']:.2f} |" for r in rows]
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
