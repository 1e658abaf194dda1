"""Issue 67 item 3: an elastic (jelly, E 1e5 Pa) block on a slope slides and sticks as Coulomb says, on both MPM
engines and both contact models (``[engine.options] contact = "particle"`` and ``"grid"``, ``docs/contact.md``).

The scene is ``tests/test_rigid_slope.py``'s (6 x 6 x 2 cells of fill, 15 x 15 x 5 cm at n_grid 24, on a flat ground
of friction ``mu``, gravity tilted by ``theta``) with the block elastic: jelly, E 1e5 Pa, nu 0.3, rho 1000,
``model = "elastic"``. Known answers (Coulomb, a block on its face):

* ``tan theta > mu``: it slides with ``a = g (sin theta - mu cos theta)``, measured as in the rigid test (twice the
  leading coefficient of a parabola fitted to its centroid's travel from 0.05 s to 0.3 s). Tolerance
  ``SLIDE_TOL`` = 2.5 %, two-sided: the issue asks 10 %; every sliding case on both engines and both contacts reads
  within 0.5 % (``docs/rigid.md`` "Elastic blocks on slopes"), and an engine 5 % off must fail.
* ``tan theta < mu``: it sticks: its centroid moves less than ``STICK_MM`` = 1 mm in 1 s **after the first
  settle**: from ``SETTLE_T`` = 0.1 s (6 frames) to 1.1 s. The block is put on the ground undeformed and sags
  into its own weight and the contact's skin in the first frames (0.07-0.27 mm of its 1.1 s travel, both engines);
  the elastic settling is over by then (the centroid's travel from 0.1 s is 0.003-0.009 mm where it sticks).

**The grid contact** (both engines, rounds 33-36; ``docs/contact.md`` "Issue 67: the grid contact on a slope"): the
grid rule (taichi_elements' separate collider with Coulomb friction at the ground's node layers) held the jelly block
only where ``mu`` exceeded ``tan theta`` by a margin that grew with the slope (30 degrees at mu 0.6 crept 119.5 mm in
1 s after the settle; 45 degrees held only at mu 1.6), because the free node layer above the plane took 1/8 of the
base's shear and none of the ground's reaction (round 35). Since round 36 that layer takes the ground's rule in the
columns a body's points touch (``gasp_taichi_mpm.touch``, ``gasp_warp_mpm.touch``, on by default; its catch, the switch
off, in ``tests/test_ground_touch.py``): every case of the 3 x 3 family meets Coulomb on both engines (the slides
0.00 % off, the sticks 0.0003-0.0008 mm after the settle), so ``GRID_SLIPS`` (strict xfails) is empty, and
``test_the_grid_contact_holds_within_its_tolerance`` holds the block at ``tan theta / mu`` 0.95-0.96 on each slope
(``GRID_HOLDS``: 15 degrees at mu 0.28, 30 at 0.6, 45 at 1.05: 0.0003, 0.0008 and 0.0012 mm, the same on both
engines; before round 36 the tolerance was 0.89, 0.85 and 0.63), and fails an engine that never sticks there (the
friction halved). The particle contact holds every case (0.001-0.003 mm after the settle).

The default tier runs two cases (a slide, a stick) on each engine and contact; the full 3 x 3 grid on both engines and
contacts is slow. ``test_the_checks_catch_broken_engines`` runs the checks on engines broken on purpose: one that
ignores ``mu`` (the ground's friction 0.4 whatever the scene says), one that never sticks (the friction halved: the
15 degree block at mu 0.4 slides), one that brakes at a rest speed (its motion held while the centroid is slower
than 0.1 m/s) and one whose acceleration is 5 % high or low.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from slopes import ENGINES, G, centroids, closed_form, coulomb_figure, coulomb_problem, landing_end, slides
from test_rigid_slope import (DEFAULT_CASES, DX, FPS, GROUND, MUS, N_GRID, SIDE, SLIDE_FROM, SLIDE_T, STICK_MM,
                              THETAS, _friction, _rest_brake)

from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing.helpers import box_points, make_setup

CONTACTS = ("particle", "grid")
JELLY = Material("jelly", model="elastic", E=1.0e5, nu=0.3, rho=1000.0)
SLIDE_TOL = 0.025
SETTLE_T = 0.1
STICK_T = 1.0
#: Where the grid contact does not hold the block (module docstring): (theta, mu) -> the measured figure. Empty since
#: round 36 (the touched layer; before it, 30 degrees at mu 0.6 moved 119.5 mm in 1 s after the settle).
GRID_SLIPS: dict = {}


def block_setup(theta: float, mu: float, contact: str, side=None, n_grid: int = N_GRID):
    """The jelly block of the module docstring on a ground of friction ``mu``, gravity tilted ``theta`` degrees;
    ``side`` (m, 3): another block's sides (round 77's cube); ``n_grid``: another grid (the fill's spacing half
    its ``dx``)."""
    dx = SIDE / n_grid
    side = np.array([6 * DX, 6 * DX, 2 * DX] if side is None else side, float)
    lo = np.array([4.3 * DX, SIDE / 2 - side[1] / 2 + 0.2 * dx, GROUND])
    x, p_vol = box_points(lo, lo + side, dx / 2)
    t = math.radians(theta)
    s = make_setup(x, p_vol, JELLY, gravity=(G * math.sin(t), 0.0, -G * math.cos(t)), lo=np.zeros(3),
                   hi=np.full(3, SIDE), n_grid=n_grid, frame_dt=1.0 / FPS,
                   boundaries=[Boundary("ground", height=GROUND, friction=mu)], options={"contact": contact})
    s.n_render = 0
    return s


def measure(engine: str, theta: float, mu: float, contact: str, spoil=None, output=None, side=None) -> float:
    """The acceleration along the slope (m/s^2) where it slides, the centroid's travel (mm) from ``SETTLE_T`` over
    ``STICK_T`` where it sticks. ``spoil(setup)`` and ``output(centroids)`` break the engine on purpose; ``side``:
    :func:`block_setup`'s."""
    s = block_setup(theta, mu, contact, side)
    if spoil is not None:
        spoil(s)
    c = centroids(engine, s, round((SLIDE_T if slides(theta, mu) else SETTLE_T + STICK_T) * FPS))
    if c is None:   # it slid out of the box
        return math.inf
    return coulomb_figure(c if output is None else output(c), theta, mu, FPS, SLIDE_FROM,
                          settle=round(SETTLE_T * FPS))


def check(theta: float, mu: float, figure: float) -> str | None:
    """None when the figure meets Coulomb, else what is wrong (two-sided)."""
    return coulomb_problem(theta, mu, figure, SLIDE_TOL, STICK_MM, STICK_T, after=" after the settle")


@pytest.mark.parametrize("contact", CONTACTS)
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("theta,mu", DEFAULT_CASES)
def test_elastic_block_on_a_slope(engine, contact, theta, mu):
    problem = check(theta, mu, measure(engine, theta, mu, contact))
    assert problem is None, f"{engine}, contact {contact}: {problem}"


def _grid_cases():
    for theta in THETAS:
        for mu in MUS:
            for contact in CONTACTS:
                why = GRID_SLIPS.get((theta, mu)) if contact == "grid" else None
                marks = [pytest.mark.xfail(strict=True, reason=f"the grid contact slips: {why}")] if why else []
                yield pytest.param(theta, mu, contact, marks=marks, id=f"{theta}-{mu}-{contact}")


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("theta,mu,contact", list(_grid_cases()))
def test_elastic_block_on_a_slope_grid(engine, theta, mu, contact):
    problem = check(theta, mu, measure(engine, theta, mu, contact))
    assert problem is None, f"{engine}, contact {contact}: {problem}"


#: Round 77: a neighbour of the flat block, a 10 cm cube (4 cells a side at n_grid 24; on a 30 degree slope its
#: weight's line passes 0.58 of the way from its centre to the downhill edge, so it does not tip).
CUBE = (0.1, 0.1, 0.1)
#: Round 78: the cube's landing. Released unstressed, it sags 0.3-0.4 mm into its own weight (``rho g h^2 / 3 E``
#: is 0.33 mm); while its base's normal force builds, gravity's pull along the slope is not yet held, and the speed
#: it gains is taken off at ``g (mu cos - sin)`` = 0.197 m/s^2 (30 degrees, mu 0.6): 3.6-7.0 mm over its first
#: 0.22-0.33 s (n_grid 24-48, both contacts), past the flat block's 0.1 s settle. Round 77 read that slide as a
#: walk. The stick is read over ``STICK_T`` from the landing's end (:func:`slopes.landing_end`, the first frame from
#: the settle on slower than 1 mm/s); a cube not landed by ``LANDING_T`` fails.
LANDING_T = 0.5


def cube_travel(engine: str, theta: float, mu: float, contact: str, n_grid: int = N_GRID, spoil=None,
                output=None) -> float:
    """The jelly cube's travel (mm) over ``STICK_T`` from the end of its landing (``LANDING_T``'s note); inf where it
    has not landed by ``LANDING_T`` or left the box. ``spoil(setup)`` and ``output(centroids)`` break the engine."""
    s = block_setup(theta, mu, contact, CUBE, n_grid)
    if spoil is not None:
        spoil(s)
    c = centroids(engine, s, round((LANDING_T + STICK_T) * FPS))
    if c is None:
        return math.inf
    c = c if output is None else output(c)
    end = landing_end(c, FPS, round(SETTLE_T * FPS))
    if end is None or end > round(LANDING_T * FPS):
        return math.inf
    return 1000.0 * float(np.linalg.norm(c[end + round(STICK_T * FPS)] - c[end]))


def _cube_problem(engine, theta, mu, contact, n_grid, **kw):
    return check(theta, mu, cube_travel(engine, theta, mu, contact, n_grid, **kw))


@pytest.mark.slow
@pytest.mark.parametrize("n_grid", (24, 48))
@pytest.mark.parametrize("engine", ENGINES)
def test_a_jelly_cube_sticks_on_the_grid_contact(engine, n_grid):
    """The cube (:data:`CUBE`) on 30 degrees at mu 0.6 and 0.7 (``tan / mu`` 0.96 and 0.82; at 45 degrees a cube is
    on its tipping edge) moves under 1 mm in 1 s after its landing on the grid contact (round 78: 0.000-0.010 mm)."""
    problems = [f"mu {mu}: {p}" for mu in (0.6, 0.7) if (p := _cube_problem(engine, 30, mu, "grid", n_grid))]
    assert not problems, problems


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="rounds 78-79: on the particle contact the undamped jelly cube at 30 degrees, "
                                       "mu 0.6 rings along the ground's normal (its centroid 0.1-0.26 mm peak to peak at "
                                       "1.0-1.6 s, a normal-force swing of about 17-45 % against the 4 % margin of tan / mu "
                                       "0.96) and walks: at n_grid 32 it is still faster than 1 mm/s at 0.5 s on both "
                                       "engines (no landing end), and from 0.5 to 1.5 s it moves 6.0 mm; 1.7 mm at "
                                       "n_grid 24, 3.7 at 48. The slips feed the ring (at mu 10 it decays to 0.008 mm; at "
                                       "mu 0.7 it grows, the same at 4x the substeps); the balance's torque take-back is "
                                       "not its cause (off: 7.9 mm at n_grid 48). Round 80: explicit finite elements "
                                       "(benchmarks/studies/cube_fem.py) walk the lightly damped cube 3.0-5.5 mm too "
                                       "and hold it once its ring is damped (docs/contact.md 'Round 79', 'Round 80')")
@pytest.mark.parametrize("engine", ENGINES)
def test_a_jelly_cube_sticks_on_the_particle_contact(engine):
    """The cube on 30 degrees at mu 0.6 on the particle contact at n_grid 32: under 1 mm in 1 s after its landing."""
    problem = _cube_problem(engine, 30, 0.6, "particle", 32)
    assert problem is None, problem


#: Round 79: a Kelvin-Voigt viscosity (Pa s) that damps the cube's ring (a loss factor ``omega eta / G`` of 0.12 at
#: the ring's quarter-wave 25 Hz, estimated, not measured). 10 Pa s (0.04) does not: the cube walks 1.5-2.8 mm at
#: n_grid 32-64, mu 0.6 (docs/contact.md "Round 79").
RING_DAMPING = 30.0


def _damped(s):
    """The cube's jelly with :data:`RING_DAMPING`."""
    s.materials = [dataclasses.replace(s.materials[0], viscosity=RING_DAMPING)]


@pytest.mark.slow
@pytest.mark.parametrize("n_grid", (24, 48))
@pytest.mark.parametrize("engine", ENGINES)
def test_a_damped_jelly_cube_sticks_on_the_particle_contact(engine, n_grid):
    """With its ring damped (:data:`RING_DAMPING`) the cube holds on the particle contact at 30 degrees, mu 0.6 and
    0.7: under 1 mm in 1 s after its landing (round 79: 0.000-0.083 mm over n_grid 24-64, warp_mpm; taichi_mpm the
    same at 48). What the undamped cube lacks is the loss, not the contact's Coulomb law; its catch is the friction
    halved (:func:`test_the_damped_cube_check_catches_a_cube_that_never_sticks`)."""
    problems = [f"mu {mu}: {p}" for mu in (0.6, 0.7)
                if (p := _cube_problem(engine, 30, mu, "particle", n_grid, spoil=_damped))]
    assert not problems, problems


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_damped_cube_check_catches_a_cube_that_never_sticks(engine):
    """The damped cube with its friction halved (mu 0.3 at 30 degrees) slides on and fails the stick."""
    def spoil(s):
        _damped(s)
        _friction(factor=0.5)(s)
    assert _cube_problem(engine, 30, 0.6, "particle", N_GRID, spoil=spoil) is not None


def _walk(c, step_mm=0.5, every=15):
    """The centroids of an engine whose cube walks: ``step_mm`` down the slope in one frame every ``every`` frames,
    still between (still frames end a landing, as the real walker's slow frames do)."""
    out = c.copy()
    out[:, 0] += 1e-3 * step_mm * (np.arange(len(c)) // every)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_cube_check_catches_a_cube_that_never_sticks_or_walks(engine):
    """The landing window hides neither a cube that never sticks (the friction halved: it slides on, its landing
    never ends) nor one that walks after it (0.5 mm every 0.25 s: 2 mm in 1 s)."""
    assert cube_travel(engine, 30, 0.6, "grid", spoil=_friction(factor=0.5)) == math.inf
    assert _cube_problem(engine, 30, 0.6, "grid", N_GRID, output=_walk) is not None


#: The grid contact's tolerance (module docstring, docs/contact.md "Round 36"): per slope, a ``mu`` that holds the
#: block at ``tan theta / mu`` 0.96, 0.96 and 0.95 at 15, 30 and 45 degrees (0.89, 0.85 and 0.63 before round 36).
GRID_HOLDS = [(15, 0.28), (30, 0.6), (45, 1.05)]


@pytest.mark.parametrize("theta,mu", GRID_HOLDS)
@pytest.mark.parametrize("engine", ENGINES)
def test_the_grid_contact_holds_within_its_tolerance(engine, theta, mu):
    """The grid contact sticks where ``tan theta / mu`` is within its measured tolerance (``GRID_HOLDS``), and the
    check fails an engine that never sticks there (the friction halved: the block slides off)."""
    problem = check(theta, mu, measure(engine, theta, mu, "grid"))
    assert problem is None, f"{engine}, contact grid: {problem}"
    if (theta, mu) == GRID_HOLDS[1]:
        assert check(theta, mu, measure(engine, theta, mu, "grid", spoil=_friction(factor=0.5))) is not None


@pytest.mark.parametrize("engine", ENGINES)
def test_the_checks_catch_broken_engines(engine):
    # the real engine passes both default cases (test_elastic_block_on_a_slope); each broken one fails one of them
    slide, stick = DEFAULT_CASES
    caught = {
        "ignores mu (0.4 always)": check(*slide, measure(engine, *slide, "particle", spoil=_friction(value=0.4))),
        "never sticks (friction halved)": check(*stick, measure(engine, *stick, "particle",
                                                                spoil=_friction(factor=0.5))),
        "brakes at a rest speed (0.1 m/s)": check(*slide, measure(engine, *slide, "particle", output=_rest_brake)),
        "5 % high": check(*slide, 1.05 * closed_form(*slide)),
        "5 % low": check(*slide, 0.95 * closed_form(*slide)),
    }
    missed = [k for k, v in caught.items() if v is None]
    assert not missed, f"{engine}: the checks miss {missed}"
