"""Round 50 (issue 67; docs/contact.md "Round 50: a slide after a landing"): the jelly block of
``tests/test_grid_hold.py`` thrown at the slope's plane, then sliding, on the grid contact, both MPM engines
(``gasp_core.testing.grid_hold.landed_slide_error``).

Round 50 credits the touch dashpot's signed push, times ``mu``, to its column's Coulomb bound and keeps the credit
while the column stays touched (``touch_credit``): a landing's push kept as credit could give extra friction later, so
a block that lands and then should slide might slide slow. Measured (``benchmarks/studies/landed_slide.py``): the
undamped jelly (E 1e5 Pa) started on the plane with a normal speed of 0.5, 1 or 2 m/s does not bounce (the held
layers and the dashpot take the landing: its centroid sinks 0.05-0.19 mm) and then slides at Coulomb's acceleration
``g (sin - mu cos)`` (fitted over ``LAND_FIT`` = 0.2-0.45 s) within 0.5 % on n_grid 32 at 45 degrees (mu 0.95,
``tan theta / mu`` 1.05) and 30 degrees (mu 0.4), and on n_grid 48 at 30 degrees, with the credit on or off; the
credit's trace is a start about one frame late (16 ms at 0.5 m/s, n_grid 32, 45 degrees), not a slower slide.
Checks: those slides within ``SLIDE_TOL`` (2.5 %, either way: a 5 % bias fails); on n_grid 48 at 45 degrees the
slide runs fast (+16 to +34 %, the released block too from 0.1 s on: its base climbs off the plane, 0.4 mm by 0.6 s;
round 50's released check fits 0.05-0.3 s), a strict xfail. The catch: the engine's ground friction 1 % high (a
contact 1 % too sticky) must fail the n_grid 32 slide at 45 degrees (-19.07 / -19.08 %, warp_mpm / taichi_mpm;
``touch_credit`` False is not caught: +0.35 % at most). The block of ``tests/test_ground_slide_coulomb.py`` thrown
down onto the ground takes more friction in its landing than Coulomb's impulse law allows (+77 / +94 % of ``mu``, the
limit biting at the impact): strict xfails, not fixed. 1-10 s a case (slow).

Round 51 (docs/contact.md "Round 51: the landing's friction"): the column's bound ``touch_bound = "debt"`` (the whole
column's friction under its held layers' stops and the two dashpots' signed push, a pull's debt kept until paid)
makes the released block at n_grid 48, 45 degrees slide at Coulomb's rate over ``LAND_FIT`` (+0.2 %, both engines;
round 50's credit +44.7 %): a pass, and its catch, round 50's ``"credit"`` selected, must fail it. The landed block
there at 1 m/s reads +7.3 % (round 50: +16.2 %) and the throw down onto the ground +9.1 / +18.4 % (round 50: +77.0 /
+93.7 %): strict xfails still (the debt of the columns the sliding block leaves is forgiven, and what it gave before a
pull is not taken back).

Round 52 (docs/contact.md "Round 52: one balance carried with the body"): ``touch_bound = "body"`` (the debt's
balance per body, not per column), the default since round 52 (lead: better than "debt" on every case measured):
the landed block at n_grid 48, 45 degrees, 1 m/s and the throw down onto the ground now pass (+0.0 %; -0.08 / -0.52
%), and the slope landing family (``LANDING``) passes at n_grid 32 (n_grid 48: strict xfails, +4.8 to +11.7 %: the
body's debt still owed at the landing frame's end, paid by frame 3); the catches select round 51's "debt": it fails
the slope landing (+4.16 %), the throw (+18.40 %) and the n_grid 48 landed slide (+7.3 %).

Round 53 (docs/contact.md "Round 53: a pull's debt refunded at once"): ``touch_pull = "refund"`` (the default) returns
the body's debt along the slip in the substep it arises: the n_grid 48 slope landings pass (within 1.25 %); the
catch selects round 52's ``"both"`` (+4.81 % at n_grid 48, 30 degrees, 0.5 m/s).
"""
from __future__ import annotations

import pytest

from gasp_core.testing.grid_hold import landed_slide_error

ENGINES = ["warp_mpm", "taichi_mpm"]
SLIDE_TOL = 0.025
#: (n_grid, theta degrees, mu, landing speed m/s)
LANDED = ([(32, theta, mu, v) for theta, mu in ((45, 0.95), (30, 0.4)) for v in (0.5, 1.0, 2.0)]
          + [(48, 30, 0.4, v) for v in (0.5, 1.0, 2.0)])
#: The released block (0 m/s) at n_grid 48, 45 degrees, over the same window (``benchmarks/studies/slide_windows.py``):
#: round 48's rule (``touch_share`` False) +1.5 %, round 49's (``touch_credit`` False) +25.5 %, round 50's +44.7 %,
#: round 51's (``touch_bound`` "debt") +0.2 %, both engines: a pass since round 51.
RELEASED_48 = (48, 45, 0.95, 0.0)
#: The landed block at n_grid 48, 45 degrees, 1 m/s: round 50 +16.2 %, round 51's "debt" +7.3 % (its catch below),
#: round 52's "body" +0.0 %, both engines.
LANDED_48 = (48, 45, 0.95, 1.0)


def _cases():
    for case in LANDED + [RELEASED_48, LANDED_48]:
        yield pytest.param(*case)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("n_grid,theta,mu,v_land", list(_cases()))
def test_a_landed_jelly_slides_at_coulombs_rate(engine, n_grid, theta, mu, v_land):
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    err = landed_slide_error(engine, n_grid, theta, mu, v_land)
    assert abs(err) < SLIDE_TOL, f"{engine}, n_grid {n_grid}, {theta} deg, mu {mu}, {v_land} m/s: {100 * err:+.2f} %"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_landed_slide_check_catches_a_sticky_contact(engine):
    # the engine's ground friction 1 % high: Coulomb's acceleration at 45 degrees, mu 0.95, about -19 %
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    err = landed_slide_error(engine, 32, 45, 0.95, 1.0, factor=1.01)
    assert abs(err) >= SLIDE_TOL, f"{engine}: the friction 1 % high slid at {100 * err:+.2f} % off Coulomb"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_released_slide_check_catches_round_50s_credit(engine, monkeypatch):
    # round 50's bound (touch_bound "credit": a pull never takes back the held layers' friction) on the released
    # block at n_grid 48, 45 degrees: +44.7 % over LAND_FIT (docs/contact.md "Round 51")
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    _bound(engine, monkeypatch, "credit")
    err = landed_slide_error(engine, *RELEASED_48)
    assert abs(err) >= SLIDE_TOL, f"{engine}: round 50's credit slid at {100 * err:+.2f} % off Coulomb"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_landed_slide_check_catches_round_51s_column_debt(engine, monkeypatch):
    # round 51's bound ("debt", a column's balance) on the landed block at n_grid 48, 45 degrees, 1 m/s: +7.3 %
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    _bound(engine, monkeypatch, "debt")
    err = landed_slide_error(engine, *LANDED_48)
    assert abs(err) >= SLIDE_TOL, f"{engine}: round 51's debt slid at {100 * err:+.2f} % off Coulomb"


def throw_error(engine: str, vz: float) -> float:
    """The jelly block of ``tests/test_ground_slide_coulomb.py`` thrown along the ground at 1.6 m/s with a downward
    speed ``vz`` (m/s; n_grid 32, the grid contact): the horizontal momentum it loses in its landing's frame over
    ``mu`` times the normal impulse the ground gives it, less 1 (Coulomb's impulse law; 0.01 = 1 %)."""
    import numpy as np

    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing import sand_ball as S
    from gasp_core.testing.kit import run_trace
    s = S.slide_setup(1.6, {"threads": 1, "contact": "grid"}, ground=True, solid=True)
    s.v = np.asarray(s.v, float) + np.array([0.0, 0.0, -vz])
    tr = run_trace(get_engine(engine), s, 1)
    return S.coulomb_ratio(tr.v, s, 0, 1) / float(s.boundaries[0].friction) - 1.0


#: The throw down onto the ground (``throw_error``): round 50's credit +77.0 / +93.7 % at vz 0.5 / 1 m/s, round 49's
#: rule +33.3 / +47.8 %, round 51's debt +9.1 / +18.4 %, round 52's body (the default) -0.08 / -0.52 %, both engines.
@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("vz", [0.5, 1.0])
def test_a_block_thrown_down_onto_the_ground_lands_by_coulombs_impulse_law(engine, vz):
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    err = throw_error(engine, vz)
    assert abs(err) < SLIDE_TOL, f"{engine}, vz {vz} m/s: the landing's friction over mu times its normal impulse " \
                                 f"{100 * err:+.2f} % off"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_throw_check_catches_round_51s_column_debt(engine, monkeypatch):
    # round 51's "debt" at vz 1 m/s: +18.40 %
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    _bound(engine, monkeypatch, "debt")
    err = throw_error(engine, 1.0)
    assert abs(err) >= SLIDE_TOL, f"{engine}: round 51's debt landed at {100 * err:+.2f} % off"


#: Round 52: a block thrown along the slope at 1.6 m/s and ``vz`` down at it (``landing_error``): n_grid 32 within
#: 1.1 % (both engines, the same digits); n_grid 48 +4.8 / +11.3 % at 30 degrees, +8.3 / +11.7 % at 45: the body's
#: debt still owed at the frame's end. Round 53 (``touch_pull = "refund"``, docs/contact.md "Round 53"): the debt
#: refunded at once, n_grid 32 -0.03 / -0.16, -0.06 / -0.80 %, n_grid 48 -0.07 / -0.29, -0.11 / -1.25 % (both engines,
#: the same digits): passes. Round 51's "debt" reads +4.2 to +33.7 % on the family, round 52's pull (``"both"``) +4.8
#: to +11.7 % at n_grid 48: the catches.
LANDING = [(n, theta, mu, vz) for n in (32, 48) for theta, mu in ((30, 0.4), (45, 0.95)) for vz in (0.5, 1.0)]


def _bound(engine, monkeypatch, bound, attr="touch_bound"):
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.grid import GridUpdate as cls
    else:
        from gasp_warp_mpm.engine import WarpMPMEngine as cls
    monkeypatch.setattr(cls, attr, bound)


def _landing_cases():
    for n, theta, mu, vz in LANDING:
        yield pytest.param(n, theta, mu, vz)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("n_grid,theta,mu,vz", list(_landing_cases()))
def test_a_block_lands_on_a_slope_by_coulombs_impulse_law(engine, n_grid, theta, mu, vz):
    from gasp_core.testing.grid_hold import landing_error
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    err = landing_error(engine, n_grid, theta, mu, vz)
    assert abs(err) < SLIDE_TOL, f"{engine}, n_grid {n_grid}, {theta} deg, {vz} m/s: {100 * err:+.2f} % off"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_slope_landing_check_catches_round_51s_column_debt(engine, monkeypatch):
    # round 51's "debt" (a column's balance, forgiven when the block leaves the column): +4.16 % at n_grid 32,
    # 30 degrees, 0.5 m/s, the family's smallest
    from gasp_core.testing.grid_hold import landing_error
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    _bound(engine, monkeypatch, "debt")
    err = landing_error(engine, 32, 30, 0.4, 0.5)
    assert abs(err) >= SLIDE_TOL, f"{engine}: round 51's debt landed at {100 * err:+.2f} % off Coulomb"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_slope_landing_check_catches_round_52s_pull(engine, monkeypatch):
    # round 52's rule (touch_pull "both": a pull's debt paid by the next stops, after the landing's frame): +4.81 % at
    # n_grid 48, 30 degrees, 0.5 m/s, the smallest of its n_grid 48 misses (docs/contact.md "Round 53")
    from gasp_core.testing.grid_hold import landing_error
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    _bound(engine, monkeypatch, "both", "touch_pull")
    err = landing_error(engine, 48, 30, 0.4, 0.5)
    assert abs(err) >= SLIDE_TOL, f"{engine}: round 52's pull landed at {100 * err:+.2f} % off Coulomb"
