"""The brittle README donut from 1 m on the default contact ends in pieces, not dust (issue 66, "What a user sees";
docs/fracture.md, "The brittle README donut from 1 m").

``examples/donut_jelly.toml`` with ``[object.material] name = "brittle"`` (every other key at the schema's
defaults) thrown down at 4.43 m/s (``tests/test_brittle_impact_step.py``'s scene), ``contact`` unset, at the
README's ``n_grid`` 64 and at 48, on both MLS-MPM engines. After 4 frames (the rebound reaches the domain's top at
frame 5) its parts are counted from the frames alone (``benchmarks/brittle_readme_donut.py``:
:class:`gasp_core.testing.pieces_count.FramePieces`, a gap of at least ``dx``, no damage read). **Pieces, not dust:**

- at least 2 parts of 1 % of the mass or more (it broke: the landing is 5.1 times the strength);
- at least 95 % of the mass in those parts (dust, the mass in smaller parts, at most 5 %);
- its points fill at most twice the grid cells they filled at rest (``swell``: pieces that come apart keep the
  cells they fill, give or take the landing's squash and the cells between them; a cloud of grains multiplies them,
  which the count of parts alone misses when the grains drift apart by less than ``dx`` each).

Round 102: a run lays the donut out in Grady's cells at its landing (``gasp_core.run.grady_cells``) and the engines
part them; it ends in 3 pieces at n_grid 48 and 64 on both engines (the pieces line, met). Before, measured
(docs/fracture.md), with the crack band ``dx`` (round 31): one piece at n_grid 48 and 64 (9.5 and 6.2 % of
it broken through), 0.999 and 0.994 of the mass in it, swell 1.24 and 1.21: not dust, but not in pieces either (the
two-piece line is a strict xfail); in the band ``1.5 dx`` of before it was 2 and 4 pieces, 0.94 and 0.87 of the mass
in the largest, 3.2 and 3.1 % in crumbs, swell 1.55 and 1.44. Catch: at the defaults before round 31 (f_t 1 kPa, G_f 10 J/m^2) the same
landing is dust (23-25 % in crumbs, the largest 0.32-0.35, swell 2.2-2.3), which the check refuses; the check itself
refuses a dust-like, a whole, a 6 %-dust and a swollen body on known part masses (default tier).

The donut as a user drops it, placed 1 m up with the default domain (2.19 m across at n_grid 64: dx 3.4 cm, 45 grid
cells of solid): until round 34 the surface rule simulated its skin as material there (under ``MIN_SOLID_CELLS``, 64),
all of its mass on its 136 872 skin points, and it was broken through everywhere at the landing and filled 71 times
the cells it filled at rest 10 frames later (the catch below; 116 at the old defaults), while the count of parts
called it one piece. Since round 34 a brittle body with a closed fill takes the passive surface over its interior
fill at any n_grid (``gasp_core.prepare.surface.surface_rule``): its 351 fill points end as one cracked piece (16 %
broken through, 0.99 times the cells), on both engines alike, in 6-8 s against 63 s for the cloud; not dust (slow
test, both engines), but not in pieces (the strict xfail). At n_grid 48 (186 fill points) it is one piece 87 % broken
through that fills 2.08 times its cells (not checked: over the swell limit). At n_grid 80 and 96 (87 and 150 cells,
round 31's figures) the same drop ended as one cracked piece (swell 1.84 and 1.70). ``prepare`` warns about a brittle
body under 64 cells of solid, naming the n_grid that gives them (``gasp_core.prepare.surface.brittle_skin_warning``:
a coarse body, or a shell where it has no interior point): checked on the placed donut at n_grid 64 (warned, n_grid =
72) and 80 (silent), and on rule records (default tier).
"""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from gasp_testing import needs_package

ROOT = Path(__file__).resolve().parents[1]
FRAMES = 4
MIN_PIECES, MIN_IN_PIECES, MAX_SWELL = 2, 0.95, 2.0


def not_dust(r: dict, min_pieces: int = MIN_PIECES) -> list[str]:
    """What keeps a run's row (``benchmarks/brittle_readme_donut.counted``: ``pieces_1``, ``in_pieces``) from
    reading as pieces (module notes); empty when it does. ``min_pieces`` 1: not dust, whole or in pieces."""
    bad = []
    if r["pieces_1"] < min_pieces:
        bad.append(f"{r['pieces_1']} parts of 1 % or more (at least {MIN_PIECES}: it lands at 5 times its strength)")
    if r["in_pieces"] < MIN_IN_PIECES:
        bad.append(f"{r['in_pieces']:.3f} of the mass in them (at least {MIN_IN_PIECES}: the rest is dust)")
    if r["swell"] > MAX_SWELL:
        bad.append(f"its points fill {r['swell']:.2f} times the cells they filled at rest (at most {MAX_SWELL})")
    return bad


def row(parts, swell: float = 1.0) -> dict:
    """A row of part masses (kg, any order) and ``swell`` as ``counted`` gives it."""
    p = np.sort(np.asarray(parts, float))[::-1] / np.sum(parts)
    return {"pieces_1": int((p >= 0.01).sum()), "in_pieces": float(p[p >= 0.01].sum()), "swell": swell}


def test_the_check_refuses_dust_and_a_whole_body_and_takes_pieces():
    assert not not_dust(row([0.87, 0.06, 0.03, 0.01] + [0.03 / 300] * 300))      # the new defaults' donut
    assert not_dust(row([0.35, 0.2, 0.15, 0.06] + [0.24 / 3000] * 3000))          # the old: 24 % crumbs
    assert not_dust(row([1.0]))                                                    # whole: not broken
    assert not_dust(row([0.9, 0.04] + [0.06 / 600] * 600))                        # 6 % dust
    assert not_dust(row([0.98, 0.02], swell=70.0))                                  # the cage: one "piece"


def run(engine: str, n_grid: int, defaults: str, placed: bool = False, surface: str | None = None,
        cells: bool = True) -> dict:
    """``benchmarks/brittle_readme_donut.counted`` as a run goes (``cells``: Grady's cells laid at the landing)."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import brittle_readme_donut as bd
    setup = bd.donut_setup(engine, n_grid, bd.brittle(defaults), placed=placed, surface=surface)
    return bd.counted(engine, setup, bd.PLACED_FRAMES if placed else FRAMES, cells)


@pytest.mark.slow
@pytest.mark.parametrize("n_grid", [48, 64])
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
def test_the_brittle_readme_donut_from_1_m_is_not_dust(engine, n_grid):
    needs_package(f"gasp_{engine}")
    r = run(engine, n_grid, "new")
    assert not not_dust(r, 1), (not_dust(r, 1), r)


@pytest.mark.slow
@pytest.mark.parametrize("n_grid", [48, 64])
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
def test_the_brittle_readme_donut_from_1_m_ends_in_pieces(engine, n_grid):
    """Round 102 (``docs/fracture.md`` "Round 102: Grady's cells in the engines"): laid out in Grady's cells at its
    landing (4 cells, 8.8 and 11.8 grid cells across) it ends in 3 pieces at n_grid 48 and 64, 0.997 and 0.991 of the
    mass in them, the largest 0.46 and 0.49, swell 1.08 and 1.10, both engines alike. Before (rounds 31-101) it was
    one cracked piece: the cracks arrest when the squash ends (round 45)."""
    needs_package(f"gasp_{engine}")
    r = run(engine, n_grid, "new")
    assert not not_dust(r), (not_dust(r), r)


@pytest.mark.slow
def test_catch_an_engine_whose_cells_never_part_leaves_the_donut_whole(monkeypatch):
    """The pieces line's catch: with the cells' contact off (``tests/test_grady_cells.py``'s broken engine) the
    donut is one piece."""
    needs_package("gasp_warp_mpm")
    from test_grady_cells import _glued
    _glued(monkeypatch, "warp_mpm")
    r = run("warp_mpm", 48, "new")
    assert not_dust(r) and r["pieces_1"] == 1, r


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
def test_catch_at_the_old_defaults_it_is_dust(engine):
    """The check's catch on an engine without Grady's cells (the class before round 102): at the old defaults the
    landing is dust (24.8 % in crumbs, swell 2.48 on warp_mpm at n_grid 48). Laid out in cells it is 10 pieces."""
    needs_package(f"gasp_{engine}")
    r = run(engine, 48, "old", cells=False)
    assert not_dust(r), r


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
def test_the_donut_placed_1_m_up_in_the_default_domain_is_not_dust(engine):
    """The surface rule gives a brittle body its interior fill under a passive skin at any n_grid (round 34)."""
    needs_package(f"gasp_{engine}")
    r = run(engine, 64, "new", placed=True)
    assert not not_dust(r, 1), (not_dust(r, 1), r)


@pytest.mark.slow
def test_catch_the_placed_donut_as_a_material_skin_is_a_cloud():
    """Its catch: the representation before round 34 (``surface = "material"``: no interior point, all of its mass on
    its 136 872 skin points) is broken through everywhere and fills about 71 times the cells it filled at rest, on an
    engine without Grady's cells (round 102: laid out in 3 cells it stays whole, 4 % broken through)."""
    needs_package("gasp_taichi_mpm")
    r = run("taichi_mpm", 64, "new", placed=True, surface="material", cells=False)
    assert not_dust(r, 1) and r["swell"] > 10 * MAX_SWELL, r


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="not met: placed 1 m up in the default domain (dx 3.4 cm, the donut 2.3 crack "
                                       "bands tall, 351 fill points under a passive skin) it ends as one cracked "
                                       "piece (16 % broken through, 0.99 times the cells at rest; docs/fracture.md); "
                                       "round 102: laid out in Grady's cells at its landing (4 cells of 2.3 grid "
                                       "cells, under Grady's 2.25) still one piece at frame 24 (4 % broken through)")
def test_the_donut_placed_1_m_up_in_the_default_domain_ends_in_pieces():
    needs_package("gasp_taichi_mpm")
    r = run("taichi_mpm", 64, "new", placed=True)
    assert not not_dust(r), (not_dust(r), r)


def test_the_skin_warning_names_coarse_brittle_bodies_only():
    from gasp_core.prepare.surface import brittle_skin_warning
    rule = {"surface": "material", "fill_method": "six-ray", "solid_cells": 43.4, "material": "brittle",
            "n_surface_points": 136872, "n_fill_points": 0}
    msg = brittle_skin_warning("donut", rule, 64)
    assert "43.4 grid cells" in msg and "136872 surface points" in msg and "n_grid = 73" in msg, msg
    coarse = brittle_skin_warning("donut", {**rule, "surface": "passive", "n_fill_points": 261}, 64)
    assert "261 fill points" in coarse and "breaks coarsely" in coarse and "n_grid = 73" in coarse, coarse
    assert not brittle_skin_warning("donut", {**rule, "surface": "passive", "solid_cells": 87.0}, 80)   # resolved
    assert not brittle_skin_warning("donut", {**rule, "material": "sand"}, 64)
    assert not brittle_skin_warning("donut", {**rule, "fill_method": "shell-open"}, 64)  # the open-fill warning's
    assert not brittle_skin_warning("donut", None, 64)                                   # surface set by the scene


@pytest.mark.parametrize("n_grid, warned", [(64, True), (80, False)])
def test_prepare_warns_of_the_placed_donuts_skin_at_64_not_80(n_grid, warned):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import brittle_readme_donut as bd
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        bd.donut_setup("taichi_mpm", n_grid, bd.brittle("new"), placed=True)
    said = [str(w.message) for w in caught if "a brittle body of" in str(w.message)]
    assert bool(said) == warned, said
    assert not warned or "n_grid = 72" in said[0], said
