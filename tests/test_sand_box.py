"""Sand in a closed box of ``walls`` keeps its volume and stays inside the walls' planes, on both MLS-MPM engines
(issue 67 item 5; :mod:`gasp_core.testing.scenes_sand_box` gives the scenes and the known answer).

A column (6 x 6 x 12 cells, and 12 x 12 x 24 on a grid twice as fine) and a slab (24 x 6 x 6 cells) of sand
(E 3.5e5 Pa, nu 0.3, 32 deg) fill the walls' planes on four sides; under its weight switched on at once the top rings
between 0 and ``2 u`` (0.50 % of ``H`` for the columns, 0.25 % for the slab): over 0.3 s its largest sink is ``2 u``
within 4 % and no point passes a wall's plane by 0.02 cells. Measured (round 32, both engines alike to 4 digits):
0.490 %, 0.483 % and 0.253 % of ``H`` (-1.8 %, -3.2 %, +1.2 %); no point past a plane. Catch: the walls' grid rule
before round 32 (the node layer on each plane free, the points held a cell behind it) lets the blocks sink 11.0 %,
6.2 % and 8.4 % of ``H`` (``test_the_check_catches_the_walls_before``).
"""
from __future__ import annotations

import numpy as np
import pytest

from gasp_core.mpm import points as core_points
from gasp_core.seam import build_engine, get_engine
from gasp_core.seam.plugins import engines
from gasp_core.testing.scenes_sand_box import BOXES, N_FRAMES, box_setup, measure, problems

ENGINES = [n for n in ("taichi_mpm", "warp_mpm") if n in engines() and engines()[n].unavailable_reason() is None]


def run(engine: str, name: str) -> list[str]:
    """:func:`problems` of the block ``name`` over :data:`N_FRAMES` frames on ``engine``."""
    s = box_setup(name)
    e = build_engine(get_engine(engine), s)
    xs = [np.asarray(s.x, np.float64)]
    for _ in range(N_FRAMES):
        e.step_frame()
        xs.append(e.positions().astype(np.float64))
    return problems(measure(xs, s), s)


@pytest.mark.parametrize("engine", ENGINES)
def test_a_sand_column_in_a_closed_box_keeps_its_volume(engine):
    assert not run(engine, "column"), engine


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in BOXES if n != "column"])
@pytest.mark.parametrize("engine", ENGINES)
def test_sand_in_closed_boxes_keeps_its_volume(engine, name):
    assert not run(engine, name), (engine, name)


def _walls_before(monkeypatch):
    """The walls' grid rule before round 32: wall nodes strictly behind the planes (3 cells, not 3.5), and the points'
    hold a cell behind each plane (``passive_bounds`` then)."""
    import gasp_core.mpm.contact as contact
    old_cells = contact.wall_grid_cells
    monkeypatch.setattr(contact, "wall_grid_cells", lambda c: 3.0 if c == "grid" else old_cells(c))
    new_bounds = core_points.passive_bounds

    def old_bounds(setup, contact_model="grid"):
        lo, hi = new_bounds(setup, contact_model)
        if contact_model == "grid" and any(b.kind == "walls" for b in setup.boundaries):
            lo, hi = lo - setup.dx, hi + setup.dx   # a domain of whole cells, no ground: a cell behind each plane
        return lo, hi
    monkeypatch.setattr(core_points, "passive_bounds", old_bounds)
    for mod in ("gasp_taichi_mpm.grid", "gasp_warp_mpm.engine", "gasp_taichi_mpm.engine"):
        m = pytest.importorskip(mod)
        if hasattr(m, "wall_grid_cells"):
            monkeypatch.setattr(m, "wall_grid_cells", contact.wall_grid_cells)
        if hasattr(m, "passive_bounds"):
            monkeypatch.setattr(m, "passive_bounds", old_bounds)


@pytest.mark.parametrize("engine", ENGINES)
def test_the_check_catches_the_walls_before(engine, monkeypatch):
    _walls_before(monkeypatch)
    assert run(engine, "column"), engine
