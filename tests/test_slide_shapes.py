"""Issue 67, round 51: slides and sticks over a family of shapes, not one block (docs/contact.md "Round 51: slides
over a family of shapes"; ``gasp_core.testing.slide_shapes``, ``benchmarks/slide_shapes.py``).

Every other slope test uses one block (6 x 6 x 2 cells of fill). Here the bodies a neighbour would build: a thin wide
slab (12 x 12 x 2 cm), a cube (7.5 cm), a bar along the slope (18 x 6 x 4 cm) and one across it (6 x 18 x 4), a flat
disc (radius 6, height 3 cm, axis normal to the ground) and a hexagonal prism on its face (circumradius 6, height 3),
each at sizes 1 and 1.5 (2.4 to 14 cells across, 0.8 to 6 cells tall), and the bundled donut lying flat (the real
capture's closed mesh, ``examples/data/donut_mesh.ply``, 20.5 x 20.5 x 8.6 cm, at sizes 0.7 and 1), rigid (``model =
"rigid"``, E 1e10 Pa, rho 700) and jelly (E 1e5 Pa, nu 0.3, rho 1000), on ``contact = "particle"`` and ``"grid"``,
n_grid 24 and 32, both MPM engines.
None can tip: ``(h / w) max(tan theta, mu)`` is at most 0.7 over the family (``test_no_body_of_the_family_can_tip``).

Cases: a slide (30 degrees, mu 0.3: Coulomb's ``a = g (sin - mu cos)`` = 2.3563 m/s^2, within ``SLIDE_TOL`` 2.5 %
either way, the slope tests' tolerance: a 5 % bias fails) and a stick (30 degrees, mu 0.7, ``tan theta / mu`` 0.82:
under 1 mm in 1 s after a 0.1 s settle), measured as ``tests/test_elastic_slope.py`` measures.

Where the family fails on main it is kept as a strict xfail with the figure measured (``MISSES``; both engines gave the
same figures to the digits shown):

* **A rigid body on the grid contact sinks into the ground**, whatever its shape, on a slope and on a flat ground
  alike (there the 7.5 cm cube's centroid falls 36.9 mm in 1.1 s, its lowest points 30.6 mm under the plane; the 2 cm
  slab's 9.9 mm): so no stick case holds. In the second after the settle its centroid moves about 3.7 mm per cm of its
  height (the 2 cm slab 7.4-7.7 mm, almost all of it down; the 4 cm bars 14.7-22 mm, the 7.5 cm cube 27.8-29.4 mm, the
  11.25 cm cube 47.9-53.4 mm, tilting forward as it digs in; ``tests/test_rigid_slope.py``'s own 6 x 6 x 2 block 18.5
  mm at 30 degrees, mu 0.7, and 19.1 mm at 15 degrees, mu 0.4; the donut 20.1-28.6 mm), and its slide reads low by
  about 0.3 % per cm of height (the 11.25 cm cube -3.2 / -3.5 %, the donut at size 1 -3.2 / -3.3 %, beyond the
  tolerance). The likely cause: the grid rule stops only the nodes at the plane, the rigid sum then gives the body its
  points' mean velocity, and the points above the base keep gravity's step, so the body sinks until enough of it lies
  in the held layers (the sink slows with time and grows with height: rigid slabs of one, two and four point layers
  end 0.40, 5.96 and 18.84 mm under the plane on a flat ground, ``benchmarks/slide_shapes.py --sink``; the jelly's
  stress carries its weight to the base in the same step and it does not sink). The rigid tests run the particle
  contact only (the default for a solid), where every shape meets Coulomb; a rigid body takes the grid contact where
  the scene's ``contact`` is ``"grid"`` (``docs/rigid.md`` "Limits").
* **The tall jelly cube (11.25 cm) on the particle contact slips at 30 degrees, mu 0.7**: 2.77 mm at n_grid 24 (its base
  slips during the release's ringing, then stops at 0.8 s) and 6.56 mm at n_grid 32 (a steady 7.5 mm/s over the whole
  second): likely the release's ringing that round 46 found on the grid contact (``tests/test_grid_hold.py``), here
  on the particle contact, largest on the tallest body: the same cube with ``viscosity`` 50 Pa s holds (0.33 / 0.32
  mm, both engines).

``test_the_checks_catch_broken_engines``: on the disc (rigid, particle contact) and the hexagonal prism (jelly, grid
contact), n_grid 24: an engine that ignores mu (0.4 always) or brakes at a rest speed (0.1 m/s) fails the slide, one
whose friction is halved fails the stick, and Coulomb's figure 5 % high or low fails the slide.

Default tier: three warp_mpm cases and warp_mpm's catches (under 5 s each); the family (448 cases) and taichi_mpm's
catches are slow.
"""
from __future__ import annotations

import pytest
from slopes import ENGINES, engine_param, rest_brake

from gasp_core.testing import slide_shapes as S

SLIDE_TOL = 0.025
STICK_MM = 1.0
SLIDE = (30.0, 0.3)
STICK = (30.0, 0.7)
GRIDS = (24, 32)
CONTACTS = ("particle", "grid")
#: (shape, size, material, contact, n_grid, (theta, mu)) -> the figure measured on main (both engines).
MISSES = {
    **{(shape, size, "rigid", "grid", n, STICK): f"sinks: its centroid moves {mm} mm in 1 s after the settle"
       for (shape, size, n), mm in {
        ("slab", 1.0, 24): 7.67, ("slab", 1.0, 32): 7.43, ("slab", 1.5, 24): 11.10, ("slab", 1.5, 32): 11.08,
        ("cube", 1.0, 24): 27.76, ("cube", 1.0, 32): 29.38, ("cube", 1.5, 24): 47.93, ("cube", 1.5, 32): 53.44,
        ("bar_along", 1.0, 24): 14.80, ("bar_along", 1.0, 32): 14.74, ("bar_along", 1.5, 24): 22.11,
        ("bar_along", 1.5, 32): 21.43, ("bar_across", 1.0, 24): 14.80, ("bar_across", 1.0, 32): 14.74,
        ("bar_across", 1.5, 24): 22.12, ("bar_across", 1.5, 32): 21.61, ("disc", 1.0, 24): 11.10,
        ("disc", 1.0, 32): 11.08, ("disc", 1.5, 24): 16.69, ("disc", 1.5, 32): 16.52, ("hex", 1.0, 24): 11.10,
        ("hex", 1.0, 32): 11.08, ("hex", 1.5, 24): 16.69, ("hex", 1.5, 32): 16.52, ("donut", 0.7, 24): 20.62,
        ("donut", 0.7, 32): 20.09, ("donut", 1.0, 24): 28.62, ("donut", 1.0, 32): 27.17}.items()},
    ("cube", 1.5, "rigid", "grid", 24, SLIDE): "sinks and digs in: a -3.46 % off Coulomb",
    ("cube", 1.5, "rigid", "grid", 32, SLIDE): "sinks and digs in: a -3.23 % off Coulomb",
    ("donut", 1.0, "rigid", "grid", 24, SLIDE): "sinks and digs in: a -3.28 % off Coulomb",
    ("donut", 1.0, "rigid", "grid", 32, SLIDE): "sinks and digs in: a -3.21 % off Coulomb",
    ("cube", 1.5, "jelly", "particle", 24, STICK): "slips 2.77 mm in 1 s after the settle (the release's ringing)",
    ("cube", 1.5, "jelly", "particle", 32, STICK): "slips 6.56 mm in 1 s after the settle (a steady 7.5 mm/s)",
}
#: Default tier: (shape, size, material, contact, n_grid, case) on warp_mpm, each under 5 s.
DEFAULT = [("disc", 1.0, "rigid", "particle", 24, SLIDE), ("hex", 1.0, "jelly", "grid", 24, STICK),
           ("bar_across", 1.0, "jelly", "particle", 24, SLIDE)]


def check(theta: float, mu: float, fig: float) -> str | None:
    return S.problem(theta, mu, fig, SLIDE_TOL, STICK_MM)


def _family():
    for shape in S.SHAPES:
        for size in S.sizes(shape):
            for mat in S.MATERIALS:
                for contact in CONTACTS:
                    for n in GRIDS:
                        for case in (SLIDE, STICK):
                            k = (shape, size, mat, contact, n, case)
                            why = MISSES.get(k)
                            marks = [pytest.mark.xfail(strict=True, reason=why)] if why else []
                            yield pytest.param(*k, marks=marks, id="-".join(map(str, (*k[:5], *case))))


def _run(engine, shape, size, mat, contact, n, case):
    fig = S.measure(engine, shape, size, mat, contact, n, *case)
    problem = check(*case, fig)
    assert problem is None, f"{engine}: {shape} x{size:g} {mat}, contact {contact}, n_grid {n}: {problem}"


def test_no_body_of_the_family_can_tip():
    for shape in S.SHAPES:
        for size in S.sizes(shape):
            for case in (SLIDE, STICK):
                assert S.tip_margin(shape, *case, size) < 1.0, (shape, size, case)


@pytest.mark.parametrize("shape,size,mat,contact,n,case", DEFAULT,
                         ids=["-".join(map(str, (*k[:5], *k[5]))) for k in DEFAULT])
def test_a_shape_slides_and_sticks_as_coulomb_says(shape, size, mat, contact, n, case):
    _run("warp_mpm", shape, size, mat, contact, n, case)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("shape,size,mat,contact,n,case", list(_family()))
def test_the_family_slides_and_sticks_as_coulomb_says(engine, shape, size, mat, contact, n, case):
    _run(engine, shape, size, mat, contact, n, case)


#: (shape, material, contact) of the catches, n_grid 24, size 1.
CATCH_BODIES = [("disc", "rigid", "particle"), ("hex", "jelly", "grid")]


@pytest.mark.parametrize("shape,mat,contact", CATCH_BODIES)
@pytest.mark.parametrize("engine", [engine_param("taichi_mpm", [pytest.mark.slow]), engine_param("warp_mpm")])
def test_the_checks_catch_broken_engines(engine, shape, mat, contact):
    def fig(case, **kw):
        return S.measure(engine, shape, 1.0, mat, contact, 24, *case, **kw)
    caught = {
        "ignores mu (0.4 always)": check(*SLIDE, fig(SLIDE, spoil=S.friction_spoil(value=0.4))),
        "never sticks (friction halved)": check(*STICK, fig(STICK, spoil=S.friction_spoil(factor=0.5))),
        "brakes at a rest speed (0.1 m/s)": check(*SLIDE, fig(SLIDE, output=lambda c: rest_brake(c, S.FPS, 0.1))),
        "5 % high": check(*SLIDE, 1.05 * S.closed_form(*SLIDE)),
        "5 % low": check(*SLIDE, 0.95 * S.closed_form(*SLIDE)),
    }
    missed = [k for k, v in caught.items() if v is None]
    assert not missed, f"{engine}, {shape} {mat} {contact}: the checks miss {missed}"
