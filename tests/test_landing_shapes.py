"""Issue 67 (round 52's review; docs/contact.md "Round 52: one balance carried with the body"): the grid contact's
landing on a slope by Coulomb's impulse law over a family of bodies built apart from the bound's own scene: the jelly
slab, cube, hexagonal prism (size 1.5), disc and bar across the slope of ``tests/test_slide_shapes.py``
(``gasp_core.testing.slide_shapes.landing_error``), thrown at 1.6 m/s along a 30 degree slope (mu 0.4) and 1 m/s at
it, n_grid 24, 32 and 48, both engines. Two-sided: the landing frame's friction impulse within ``SLIDE_TOL`` (2.5 %)
of ``mu`` times its normal impulse, so a 5 % bias fails.

Measured (lead, round 52; warp_mpm and taichi_mpm the same digits at n_grid 24 and 32) under the default ``touch_bound
= "body"``: slab -0.07 / -0.07 %, cube +0.14 / +1.01, hex +0.78 / -0.14, disc -0.12 / -0.12, bar across +0.99 / +0.92
(n_grid 24 / 32); at n_grid 48 slab -0.07, cube +0.51, disc -0.12, and the hexagonal prism +6.07 % and the bar +3.98 %
(warp_mpm): strict xfails, the body's debt still owed at the landing frame's end (as ``tests/test_landed_slide.py``'s
n_grid 48 landings). The catch: round 51's ``"debt"`` (a balance per column) reads +2.8 to +14.1 % on the family at
n_grid 24 and 32; the cube at n_grid 24 (+13.60 %) must fail. About 3-8 s a case (slow).

Round 53 (docs/contact.md "Round 53: a pull's debt refunded at once"): ``touch_pull = "refund"`` (the default) returns
the body's debt along the slip at once: the n_grid 48 prism and bar pass (MISSES emptied; figures in the docs); the
second catch selects round 52's ``"both"``: the hexagonal prism at n_grid 48 (+6.07 %) must fail.
"""
from __future__ import annotations

import pytest
from slopes import ENGINES

from gasp_core.testing.slide_shapes import landing_error

SLIDE_TOL = 0.025
SHAPES = [("slab", 1.0), ("cube", 1.0), ("hex", 1.5), ("disc", 1.0), ("bar_across", 1.0)]
#: (shape, n_grid) -> why it misses (round 52's prism and bar at n_grid 48 pass since round 53's refund).
MISSES: dict = {}


def _cases():
    for shape, size in SHAPES:
        for n in (24, 32, 48):
            why = MISSES.get((shape, n))
            yield pytest.param(shape, size, n, marks=[pytest.mark.xfail(strict=True, reason=why)] if why else [],
                               id=f"{shape}-{n}")


def _bound(engine, monkeypatch, bound, attr="touch_bound"):
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.grid import GridUpdate as cls
    else:
        from gasp_warp_mpm.engine import WarpMPMEngine as cls
    monkeypatch.setattr(cls, attr, bound)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("shape, size, n_grid", list(_cases()))
def test_a_body_lands_on_a_slope_by_coulombs_impulse_law(engine, shape, size, n_grid):
    err = landing_error(engine, shape, size, n_grid)
    assert abs(err) < SLIDE_TOL, f"{engine}, {shape} x{size}, n_grid {n_grid}: {100 * err:+.2f} % off"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_landing_family_catches_round_51s_column_debt(engine, monkeypatch):
    _bound(engine, monkeypatch, "debt")
    err = landing_error(engine, "cube", 1.0, 24)
    assert abs(err) >= SLIDE_TOL, f"{engine}: round 51's debt landed the cube at {100 * err:+.2f} % off"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_landing_family_catches_round_52s_pull(engine, monkeypatch):
    _bound(engine, monkeypatch, "both", "touch_pull")   # round 52: a pull's debt paid after the landing's frame
    err = landing_error(engine, "hex", 1.5, 48)
    assert abs(err) >= SLIDE_TOL, f"{engine}: round 52's pull landed the prism at {100 * err:+.2f} % off"
