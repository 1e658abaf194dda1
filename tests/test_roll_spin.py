"""Issue 67 item 2 on a turning ``[[collider]]`` (round 90, ``docs/rigid.md`` "Round 90: round bodies on moving
colliders"): a rigid ball set at rest on a collider that turns (``[[collider]] angular_velocity``;
``benchmarks/studies/roll_spin90.py``), on both MPM engines.

- **The turntable**: a plate turning at 3 rad/s about the vertical, the ball 0.1 m off its axis. Rolling, its centre
  circles the axis at ``k Omega / (1 + k)`` (2/7 of the table's for a solid sphere) at the radius it started at
  (Ehrlich & Tuszynski 1995, Am. J. Phys. 63, 351): the rate over 1 s and the mean radius within 5 %, two-sided.
- **The drum**: a drum of radius 0.25 m turning at 5 rad/s about its horizontal axis, the ball at its bottom. The slip
  throws it up the wall; then it swings as the bowl's pendulum. Its first peak and half period against the rigid-body
  equations (``roll_spin90.drum_reference``, scipy's ``solve_ivp``) within 5 %, two-sided. The wall's speed is taken
  at the contact (``Omega R_drum``); taken at the centre's radius the reference's peak is 20 % lower for the 5 cm ball
  and 40 % for the 10 cm one, so the check tells the two apart.
- **Families** (slow, both engines): R 0.05 and 0.1 m, n_grid 32 and 48; mu 0.05 and 0.5 on the turntable, 0.5 and 1
  in the drum.
- **The default tier**: the 10 cm ball on the turntable (warp_mpm; taichi_mpm slow) and the 5 cm ball in the drum
  (both engines), with the drum's catches.
- **Catches**: a frictionless table or drum, an engine that leaves the collider's spin out of its surface velocity
  (its field still turns), the rest brake (``slopes.rest_brake``: the turntable) and figures 6 % off; in the drum an
  engine that reads the wall's speed at the centre's radius (the spin scaled by ``(R_drum - r) / R_drum`` in the
  collider's surface velocity: the same speed there), and the engines' swing against the reference with that speed.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))

import roll_spin90 as RS  # noqa: E402
from slopes import ENGINE_NAMES, ENGINES, engine_param, rest_brake  # noqa: E402


def _scaled_spin(f: float):
    """A collider whose surface velocity takes ``f`` times its spin: in the drum, with ``f = (R_drum - r) / R_drum``,
    an engine that reads the wall's speed at the centre's radius, not at the contact (the field is round, so its
    turn does not matter)."""
    from gasp_core.colliders.model import Collider

    class ScaledSpin(Collider):
        def pose(self, t):
            R, T, v, w = super().pose(t)
            return R, T, v, f * np.asarray(w)
    return ScaledSpin


def _no_spin():
    """A collider whose surface velocity leaves out its spin (``w x r``), though its field turns: the broken variant."""
    from gasp_core.colliders.model import Collider

    class NoSpin(Collider):
        def pose(self, t):
            R, T, v, _ = super().pose(t)
            return R, T, v, np.zeros(3)
    return NoSpin


# --------------------------------------------------------------------------- the turntable
@pytest.mark.parametrize("engine", [engine_param(e, [pytest.mark.slow] if e == "taichi_mpm" else [])
                                    for e in ENGINE_NAMES])
def test_a_ball_on_a_turntable_circles_its_axis_at_two_sevenths_of_its_spin(engine):
    pytest.importorskip(f"gasp_{engine}")
    r = RS.turntable(engine, 0.1, 32, 0.5)
    assert r["problem"] is None, f"{engine}: {r['problem']}"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_a_ball_on_a_turntable_across_the_family(engine):
    pytest.importorskip(f"gasp_{engine}")
    bad = [f"R {r} n_grid {n} mu {mu}: {p}" for r in RS.RADII for n in RS.GRIDS for mu in RS.MUS
           if (p := RS.turntable(engine, r, n, mu)["problem"]) is not None]
    assert not bad, f"{engine}: {bad}"


@pytest.mark.slow
def test_the_turntable_check_catches_broken_engines():
    pytest.importorskip("gasp_warp_mpm")
    case = ("warp_mpm", 0.1, 32, 0.5)
    fig = RS.turntable(*case)
    caught = {"frictionless": RS.turntable(*case, friction=0.0)["problem"],
              "drops the spin": RS.turntable(*case, cls=_no_spin())["problem"],
              "rest brake": RS.turntable(*case, output=lambda c: rest_brake(c, RS.FPS))["problem"],
              **{name: RS.turntable_problem({**fig, "rate": f * fig["rate"], "r": f * fig["r"]})
                 for name, f in (("6 % high", 1.06), ("6 % low", 0.94))}}
    missed = [k for k, v in caught.items() if v is None]
    assert not missed, f"the turntable's check misses {missed}"


# --------------------------------------------------------------------------- the drum
@pytest.mark.parametrize("engine", ENGINES)
def test_a_ball_in_a_turning_drum_swings_as_the_rigid_body_equations_say(engine):
    pytest.importorskip(f"gasp_{engine}")
    r = RS.drum(engine)
    assert r["problem"] is None, f"{engine}: {r['problem']}"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_a_ball_in_a_turning_drum_across_the_family(engine):
    pytest.importorskip(f"gasp_{engine}")
    bad = [f"R {r} n_grid {n} mu {mu}: {p}" for r in RS.DRUM_RADII for n in RS.DRUM_GRIDS for mu in RS.DRUM_MUS
           if (p := RS.drum(engine, mu, n, r)["problem"]) is not None]
    assert not bad, f"{engine}: {bad}"


def test_the_drum_check_catches_broken_engines_and_the_centres_speed():
    pytest.importorskip("gasp_warp_mpm")
    r = RS.drum("warp_mpm")
    want = {"peak": r["peak_want"], "half": r["half_want"]}
    caught = {"frictionless": RS.drum("warp_mpm", friction=0.0)["problem"],
              "drops the spin": RS.drum("warp_mpm", cls=_no_spin())["problem"],
              "the wall's speed at the centre's radius": RS.drum(
                  "warp_mpm", cls=_scaled_spin((RS.DRUM_R - RS.DRUM_BALL) / RS.DRUM_R))["problem"],
              "checked against the centre's rule": RS.drum_problem(r, {**want, "peak": r["peak_centre"]}),
              **{name: RS.drum_problem({"peak": f * r["peak"], "half": f * r["half"]}, want)
                 for name, f in (("6 % high", 1.06), ("6 % low", 0.94))}}
    missed = [k for k, v in caught.items() if v is None]
    assert not missed, f"the drum's check misses {missed}"
