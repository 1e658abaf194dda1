"""Round 46 (issue 67 item 3): the grid contact's hold near the stick limit on the finer grids, both MPM engines
(``gasp_core.testing.grid_hold``; docs/contact.md "Round 46: the grid contact's hold near the limit").

The block of ``tests/test_snow_contact.py``'s slopes (15 x 15 x 5 cm; 6 x 6 x 2 cells at n_grid 24, 12 x 12 x 4 at 48)
on ``contact = "grid"``. Round 45 found the undamped jelly (E 1e5 Pa) creeping at ``tan theta / mu`` 0.96 on n_grid 48
(98.4 mm in 1 s at 30 degrees, mu 0.6) while it holds on n_grid 24. Measured (``benchmarks/grid_hold.py``): what
creeps is the **release's ringing**. Put on the ground undeformed and let go, the block rings: with its base held
(friction 5) the ground's normal load on it swings between 0.44 and 1.52 of ``M g cos theta`` over its first 0.12 s
on n_grid 48 (0.78-1.20 on n_grid 24, where the held node layers span most of its 2 cells), and the tangential load
over the normal exceeds 0.6 (the friction at 0.96) for 40 % of that time (10 % on n_grid 24), so Coulomb's law itself
lets the base slip during the release; on the grid contact an undamped jelly's slip, once started, does not stop
(its base climbs off the plane on the rule's one-sided normal, and round 36's touched layer, whose threshold 0.25 dx
is the fill's own lowest height, falls unmarked; on n_grid 32 that layer never acts: the lowest points sit at 0.267
dx).
A jelly damped enough that the release rings down (``viscosity`` 200 Pa s, a damping ratio about 0.4 of its first
compression mode) holds at 0.96 and 0.95 on n_grid 32 and 48 on both engines. Round 47 (docs/contact.md "Round 47: the
touch test tied to the point's extent"): a point touches the plane when its lowest extent (its height less half its own
spacing ``h``) lies under ``touch_margin h`` (1) above it, so the touched layer acts on n_grid 32 too: the undamped
jelly released there holds (157 / 384 mm before at 30 / 45 degrees, now under 0.02 mm). On n_grid 48 it still crept
(63.6 mm at 30 degrees, mu 0.6): a steady slide of its base from the first frame (0.28 mm a frame, 1.1 mm once it
climbs), the friction's budget spent on the ringing's pulses. Round 48 (docs/contact.md "Round 48: a dashpot above the
held layers"): a dashpot on the normal velocity of the node layer just above the held ones, in the columns a body that
does not flow touches (the particle contact's damping ratio ``DAMPING`` on the cell's oscillator, ``touch_damping``),
takes the ringing out: the released jelly holds on n_grid 48 too (0.0010 / 0.047 mm at 30 / 45 degrees, both engines).

Checks: the damped jelly's travel and the released undamped jelly's on n_grid 24, 32 and 48 under ``STICK_MM`` = 1 mm
in 1 s after its settle (Coulomb's stick); the catches: the engine's ground friction 0.95 times the scene's (``tan
theta / mu`` 1.01: Coulomb slides it about 37 mm in that second at 30 degrees) must fail the damped hold,
``touch_margin`` 0 (the knife-edge at the plane) the released one on n_grid 32, ``touch_damping`` 0 (the dashpot off,
round 47's rule) the released one on n_grid 48 under ``cfl_rule = "max"`` (round 54: under the default "sum" it
holds without the dashpot, 0.799 mm, so the catch pins "max", beside its twin that holds with the dashpot there). The released jelly just past the limit (``tan theta / mu`` 1.05)
slides at Coulomb's acceleration within ``SLIDE_TOL`` = 2.5 % on n_grid 24, 32 and 48 (15, 30, 45 degrees; round
49's n_grid 32 and 48 at 45 degrees, +2.87 / +48.5 %, met since round 50, docs/contact.md "Round 50: the dashpot's
push in the column's Coulomb bound": +0.75 / +0.89 %); the catches: the engine's ground friction 1 % high, and
``touch_credit`` False (round 49's rule) on n_grid 48 at 45 degrees, must fail the slide check. The cases take 5-25 s
(n_grid 24, 32) and 30-90 s (48) each (slow). Round 49 (docs/contact.md "Round 49: the viscous step's momentum, a
uniform correction"): the damped jelly (``viscosity`` 200 Pa s) just past the limit slides at Coulomb's
acceleration within ``DAMPED_SLIDE_TOL`` (4 %, either way: a 5 % bias fails) on n_grid 24, 32 and 48 (15, 30, 45
degrees) once the viscous step adds the CG residual's sum back as one uniform velocity (measured, both engines: n_grid
24 +2.20 to +2.81 %, the 2-cell block's grid error: the CG to TOL 1e-6 read +2.86 % at 15 degrees; 32 and 48 within
0.61 %); the catch: ``ImplicitViscosity.conserve`` False (the CG's iterate ``m u``, the rule before) must fail n_grid 48 (+23.45 %
at 30 degrees, both engines). 0.6-6.5 s a case (slow).
"""
from __future__ import annotations

import pytest

from gasp_core.testing.grid_hold import hold_travel, slide_error

ENGINES = ["warp_mpm", "taichi_mpm"]
STICK_MM = 1.0
SLIDE_TOL = 0.025
#: (n_grid, theta, mu): the damped jelly's hold near the limit (tan theta / mu 0.96, 0.95) on n_grid 32 and 48.
DAMPED = [(32, 30, 0.6), (32, 45, 1.05), (48, 30, 0.6), (48, 45, 1.05)]
#: Round 47: the undamped jelly released at 0.96 / 0.95 on n_grid 32, which crept 157 / 384 mm before the touch
#: test was tied to the point's extent (the touched layer never acted there), and on n_grid 24; round 48: on n_grid
#: 48, which crept 63.6 / 199 mm before the dashpot above the held layers.
RELEASED = [(24, 30, 0.6), (24, 45, 1.05), (32, 30, 0.6), (32, 45, 1.05), (48, 30, 0.6), (48, 45, 1.05)]
#: (n_grid, theta, mu) at tan theta / mu 1.05: the released jelly's slide against Coulomb's acceleration.
SLIDES = [(n, theta, mu) for n in (24, 32, 48) for theta, mu in ((15, 0.255), (30, 0.55), (45, 0.95))]
#: The slides at 1.05 the grid contact does not meet (none since round 50: round 49's n_grid 32 and 48 at 45 degrees,
#: +2.87 / +48.5 %, read +0.75 / +0.89 % with the dashpot's push credited, docs/contact.md "Round 50").
SLIDE_MISSES: dict = {}
#: The damped jelly's slide (round 49): two-sided, so a 5 % bias either way fails.
DAMPED_SLIDE_TOL = 0.04
DAMPED_SLIDES = [(n, theta, mu) for n in (24, 32, 48) for theta, mu in ((15, 0.255), (30, 0.55), (45, 0.95))]


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("n_grid,theta,mu", DAMPED)
def test_a_damped_jelly_released_near_the_limit_holds(engine, n_grid, theta, mu):
    f = hold_travel(engine, "jelly", "damped", n_grid, theta, mu)
    assert 0.0 <= f < STICK_MM, f"{engine}, n_grid {n_grid}, {theta} deg, mu {mu}: {f:.3f} mm in 1 s after the settle"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_hold_check_catches_the_friction_5pct_low(engine):
    f = hold_travel(engine, "jelly", "damped", 48, 30, 0.6, factor=0.95)
    assert f >= STICK_MM, f"{engine}: the friction 0.95 times (tan theta / mu 1.01) held ({f:.3f} mm)"


def _margin(monkeypatch, engine: str, margin: float) -> None:
    """Engine ``engine``'s ``touch_margin`` set to ``margin`` (the catches)."""
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.grid import GridUpdate as cls
    else:
        from gasp_warp_mpm.engine import WarpMPMEngine as cls
    monkeypatch.setattr(cls, "touch_margin", float(margin))


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("n_grid,theta,mu", RELEASED)
def test_the_released_jelly_near_the_limit_holds(engine, n_grid, theta, mu):
    f = hold_travel(engine, "jelly", "release", n_grid, theta, mu)
    assert 0.0 <= f < STICK_MM, f"{engine}, n_grid {n_grid}, {theta} deg, mu {mu}: {f:.3f} mm in 1 s"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_released_hold_check_catches_the_knife_edge_touch(engine, monkeypatch):
    # touch_margin 0: a point touches only once its extent reaches the plane, the knife-edge round 46 found (the
    # n_grid 32 fill's lowest extent sits 0.01 dx above it): the touched layer never acts and the block creeps
    _margin(monkeypatch, engine, 0.0)
    f = hold_travel(engine, "jelly", "release", 32, 30, 0.6)
    assert f >= STICK_MM, f"{engine}: touch_margin 0 held ({f:.3f} mm)"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_released_hold_check_catches_the_dashpot_off(engine, monkeypatch):
    # touch_damping 0: round 47's rule, whose ringing base slides from the first frame on n_grid 48 (63.6 mm) under
    # cfl_rule "max". Under round 54's default "sum" the shorter step rings the release down without the dashpot
    # (0.799 mm in 1 s, both engines), so the catch pins "max" (an engine option users may still choose), where the
    # dashpot is what holds the block (test_the_released_jelly_holds_under_the_max_rule)
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.grid import GridUpdate as cls
    else:
        from gasp_warp_mpm.engine import WarpMPMEngine as cls
    monkeypatch.setattr(cls, "touch_damping", 0.0)
    f = hold_travel(engine, "jelly", "release", 48, 30, 0.6, options={"cfl_rule": "max"})
    assert f >= STICK_MM, f"{engine}: touch_damping 0 held ({f:.3f} mm)"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_released_jelly_holds_under_the_max_rule(engine):
    """The catch's twin: with the dashpot (the engines' rule) the released jelly on n_grid 48 holds under
    ``cfl_rule = "max"`` too, so the catch above fails for the dashpot, not for the step rule."""
    f = hold_travel(engine, "jelly", "release", 48, 30, 0.6, options={"cfl_rule": "max"})
    assert 0.0 <= f < STICK_MM, f"{engine}: {f:.3f} mm in 1 s under cfl_rule max"


def _slide_cases():
    for case in SLIDES:
        yield pytest.param(*case)
    for case, why in SLIDE_MISSES.items():
        why = f"the grid's slide near the limit: {why}"
        yield pytest.param(*case, marks=pytest.mark.xfail(strict=True, reason=why))


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("n_grid,theta,mu", list(_slide_cases()))
def test_the_released_jelly_just_past_the_limit_slides_at_coulombs_rate(engine, n_grid, theta, mu):
    err = slide_error(engine, "jelly", n_grid, theta, mu)
    assert abs(err) < SLIDE_TOL, f"{engine}, n_grid {n_grid}, {theta} deg, mu {mu}: a {100 * err:+.2f} % off Coulomb"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_slide_check_catches_round_49s_frictionless_dashpot(engine, monkeypatch):
    # touch_credit False: round 49's rule, the dashpot's push on the touched layers gives no friction (+48.5 % on
    # n_grid 48 at 45 degrees, both engines; docs/contact.md "Round 50")
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.grid import GridUpdate as cls
    else:
        from gasp_warp_mpm.engine import WarpMPMEngine as cls
    monkeypatch.setattr(cls, "touch_bound", "credit")   # round 51: touch_credit is read under round 50's bound
    monkeypatch.setattr(cls, "touch_credit", False)
    err = slide_error(engine, "jelly", 48, 45, 0.95)
    assert abs(err) >= SLIDE_TOL, f"{engine}: round 49's rule slid at {100 * err:+.2f} % off Coulomb"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_slide_check_catches_a_sticky_contact(engine):
    # the engine's ground friction 1 % high (a contact 1 % too sticky): near the limit that is a fifth of the
    # acceleration (Coulomb's: -20 % at 30 degrees, mu 0.55); every column touched (touch_margin 1e9) does not change
    # the n_grid 32 slide (+0.02 %: the block's base columns are all touched anyway), so it is no catch here
    err = slide_error(engine, "jelly", 32, 30, 0.55, factor=1.01)
    assert abs(err) >= SLIDE_TOL, f"{engine}: the friction 1 % high slid at {100 * err:+.2f} % off Coulomb"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("n_grid,theta,mu", DAMPED_SLIDES)
def test_the_damped_jelly_just_past_the_limit_slides_at_coulombs_rate(engine, n_grid, theta, mu):
    err = slide_error(engine, "jelly", n_grid, theta, mu, damped=True)
    assert abs(err) < DAMPED_SLIDE_TOL, f"{engine}, n_grid {n_grid}, {theta} deg, mu {mu}: a {100 * err:+.2f} % off"


def _viscous_cls(engine: str):
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.viscosity import ImplicitViscosity as cls
    else:
        from gasp_warp_mpm.viscosity import ImplicitViscosity as cls
    return cls


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_damped_slide_check_catches_the_viscous_step_leaking_momentum(engine, monkeypatch):
    # conserve False: the viscous step returns the CG's iterate m u, whose momentum lacks the residual's sum (the CG
    # stops at TOL 1e-2); it sits at the base, where the friction shears the held layers, and gives back part of the
    # friction's impulse (round 48: +23.45 % on n_grid 48, 30 degrees)
    monkeypatch.setattr(_viscous_cls(engine), "conserve", False)
    err = slide_error(engine, "jelly", 48, 30, 0.55, damped=True)
    assert abs(err) >= DAMPED_SLIDE_TOL, f"{engine}: the leaking viscous step slid at {100 * err:+.2f} % off Coulomb"
