"""Two soft bodies meet at their surfaces (issue 53 item 5, ``docs/contact.md`` "Two jelly balls stacked").

- Which scenes take a velocity field per body (:func:`gasp_core.mpm.fields.soft_pair`: two soft bodies on the
  particle contact, neither rigid nor flowing) and their touch threshold (``SOFT_TOUCH_FRACTION``, the sand's
  ``TOUCH_FRACTION`` otherwise).
- Both engines (taichi_mpm in the slow tier: its kernels compile in about 40 s): the conformance scene ``stacked_gap``
  (two jelly balls stacked in a frictionless tube) passes its check, the gap between the lattices' surfaces over the
  last 0.5 s within ``STACK_GAP_TOL`` = 0.25 dx of 0 (measured -0.181 dx on warp_mpm, -0.193 on taichi_mpm since round 22: the
  lattices' surfaces a little inside each other).
- The check fails on broken engines (:func:`test_the_gap_check_fails_on_a_broken_contact`, warp_mpm): one velocity
  field (``contact_fields = false``: +0.84 dx, held a cell apart), the contact acting wherever the two fields share
  a node, across a gap (the rule before round 60 with touch threshold 0: +0.83 dx), and the contact acting only once
  the volumes fill the cell (the sand's threshold 0.9: -0.29 dx, the top ball inside the bottom one; -0.40 before
  round 22); round 60's touch by geometry (``gasp_core.mpm.gap_touch``) at zero separation (``SEPARATION`` 0: the
  convex surfaces' smoothing makes it late, -0.27 dx).
- Round 60: the two bodies touch by geometry (``GAP_TOUCH``): the gap at rest -0.009 dx on warp_mpm (the rule
  before, the volumes filling ``SOFT_TOUCH_FRACTION`` of a cell: -0.22).
- Round 61 (``gasp_core.mpm.gap_touch.CURVATURE``, off by default): a ball, a cube and a cylinder dropped on a box
  rest within 0.05 dx (two rows measured outside: strict xfails), round 60's rule caught (+0.224); the stacked balls
  under it rest -0.058 dx (a strict xfail: why it is off). Round 70: under the trapezoid (``stress_at``'s default)
  the cylinder at n_grid 32 rests within 0.05 dx on both engines (a plain test); under "start" a strict xfail.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import gasp_core.mpm.fields as F
from gasp_core.seam.plugins import get_engine
from gasp_core.seam.setup import Material
from gasp_core.testing.kit import run_trace
from gasp_core.testing.scenes_pairs import _build_stack, _eval_stack, STACK_T
from gasp_core.mpm.fields import field_bodies, soft_pair, touch_fraction, uses_fields
from gasp_core.mpm.shared_fields import shared_field_bodies

FRAMES = round(STACK_T * 30)


def _stack(**options):
    s = _build_stack(None)
    return dataclasses.replace(s, options={"threads": 1, **options})


def test_two_soft_bodies_take_a_field_each():
    s = _stack()
    assert soft_pair(s) and uses_fields(s)
    assert field_bodies(s).tolist() == [False, True]
    assert touch_fraction(s) == F.SOFT_TOUCH_FRACTION
    assert not uses_fields(_stack(contact_fields=False))
    assert not uses_fields(_stack(contact="grid"))                       # the grid contact by hand: one field
    one = dataclasses.replace(s, x=s.x[s.body_id == 0], v=0.0, p_vol=s.p_vol[s.body_id == 0], body_id=0,
                              materials=s.materials[:1])
    assert not uses_fields(one)                                           # one body: one field, as before
    rigid = dataclasses.replace(s, materials=[s.materials[0], Material("jelly", model="rigid", E=1e10, rho=700.0)])
    assert not soft_pair(rigid)
    three = dataclasses.replace(s, body_id=np.where(np.arange(len(s.x)) % 7 == 0, 2, s.body_id),
                                materials=[*s.materials, s.materials[0]])
    # round 61 (gasp_core.mpm.colouring): three soft bodies coloured into the two fields; these three (body 2 every
    # 7th point of both balls) touch each other, an odd cycle: one pair still shares, named
    assert uses_fields(three) and len(shared_field_bodies(three)) == 2
    sand = dataclasses.replace(s, materials=[s.materials[0], Material("sand", E=3.5e5, rho=1600.0)])
    assert not soft_pair(sand) and touch_fraction(sand) == F.TOUCH_FRACTION   # mixed: the sand's contact


#: Within this (dx) of 0 the two balls' lattices' surfaces meet.
GAP_TOL = 0.05


def _gap(engine: str, balance: bool = False) -> tuple[bool, float]:
    """The conformance check's outcome and the signed gap (dx). Round 86: on the raw per-point ground contact
    (``contact_balance = false``) unless ``balance``. The stack is unstable (the top ball leans 4-7 mm on the bottom
    one in the tube) and the ground balance's take-back changes how it rocks: the gap over the last 0.5 s was -0.023
    dx under round 85's take-back, -0.066 under round 86's (the balls' centres 1.2 mm nearer), -0.007 on the raw
    contact (warp_mpm). These tests are about the two fields' touch, so they read it on the raw ground contact; the
    default's figure is :func:`test_the_stacked_balls_meet_with_the_ground_balance` (a strict xfail)."""
    s = _stack(**({} if balance else {"contact_balance": False}))
    (c,) = _eval_stack(None, run_trace(get_engine(engine), s, FRAMES))
    return c.passed, c.figures["signed"]


@pytest.mark.parametrize("engine", ["warp_mpm", pytest.param("taichi_mpm", marks=pytest.mark.slow)])
def test_the_stacked_balls_meet_at_their_surfaces(engine):
    ok, gap = _gap(engine)
    # round 60 (the touch by geometry): measured -0.009 on both engines; the rule before -0.219 on both (round 59's
    # main), -0.181 / -0.193 in round 22; round 86, on the raw ground contact: -0.007 (warp_mpm)
    assert ok and gap == pytest.approx(0.0, abs=GAP_TOL), gap


@pytest.mark.xfail(strict=True, reason="round 86: -0.066 dx with the ground balance's take-back bounded by its "
                   "patch's flatness (the unstable stack rocks otherwise; -0.023 under round 85's take-back)")
def test_the_stacked_balls_meet_with_the_ground_balance():
    pytest.importorskip("gasp_warp_mpm")
    ok, gap = _gap("warp_mpm", balance=True)
    assert ok and gap == pytest.approx(0.0, abs=GAP_TOL), gap


@pytest.mark.parametrize("broken, expect", [("one_field", 0.84), ("across_gap", 0.80), ("late_touch", -0.25),
                                            ("zero_separation", -0.26)])
def test_the_gap_check_fails_on_a_broken_contact(monkeypatch, broken, expect):
    """Each broken touch fails the check above (its gap outside ``GAP_TOL``), at its measured figure (round 86, on
    the raw ground contact, warp_mpm: 0.841, 0.801, -0.248, -0.259 dx; the conformance limit of 0.25 dx passes the
    late touch, -0.248)."""
    if broken == "one_field":
        monkeypatch.setattr(F, "body_pair", lambda setup: False)          # one velocity field, the rule before
    elif broken == "zero_separation":
        import gasp_core.mpm.gap_touch as G
        monkeypatch.setattr(G, "SEPARATION", 0.0)                        # round 60's touch at the surfaces' meeting
    else:
        monkeypatch.setattr(F, "GAP_TOUCH", False)                        # the volume-fraction touch (before round 60)
        monkeypatch.setattr(F, "SOFT_TOUCH_FRACTION", 0.0 if broken == "across_gap" else 0.9)
    ok, gap = _gap("warp_mpm")
    assert abs(gap) > GAP_TOL and gap == pytest.approx(expect, abs=0.05), gap


def _landed(engine: str, shape: str, n_grid: int, frames: int = 40, stress_at: str | None = None) -> float:
    """A jelly ``shape`` dropped 1.5 dx onto the jelly box (``gasp_core.testing.helpers.body_over_box``; the ball at
    n_grid 48 bounces for about 25 frames): the gap at rest, the mean of the last 5 of ``frames`` frames, dx
    (``benchmarks/studies/gap_fall.py``'s ``landed``)."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))
    from gap_fall import landed
    return landed(engine, shape, 0.06, n_grid, 1.5, frames, stress_at)[0]


#: Round 61's rows measured outside 0.05 dx (warp_mpm; docs/contact.md "Round 61"): strict xfails. Round 70: under the
#: trapezoid (``stress_at``'s default since then) the cylinder at n_grid 32 rests within (docs/fracture.md "Round
#: 70"); under "start" it does not (:func:`test_the_curved_touch_cylinder_under_the_start_stress`).
_CURVE_OUT = {("ball", 48): "+0.090 dx (round 60 at separation 0 the same)"}


@pytest.mark.parametrize("engine,shape,n_grid", [
    pytest.param(e, sh, ng, id=f"{e}-{sh}-{ng}", marks=(
        [pytest.mark.slow]) + (   # the switch is off by default: its checks in the slow tier (round 61)
        [pytest.mark.xfail(strict=True, reason=_CURVE_OUT[sh, ng])] if (sh, ng) in _CURVE_OUT else []))
    for e in ("warp_mpm", "taichi_mpm") for sh in ("ball", "cube", "cylinder") for ng in (32, 48)])
def test_the_curved_touch_rests_on_the_box(engine, shape, n_grid, monkeypatch):
    """Round 61 (``gasp_core.mpm.gap_touch.CURVATURE``, off by default): a ball, a cube and a cylinder on its side
    dropped on the box rest with their lattices' surfaces within 0.05 dx (round 60's rule: +0.22 to +0.27)."""
    import gasp_core.mpm.gap_touch as G
    monkeypatch.setattr(G, "CURVATURE", True)
    gap = _landed(engine, shape, n_grid)
    assert gap == pytest.approx(0.0, abs=0.05), gap


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["warp_mpm", "taichi_mpm"])
def test_the_curved_touch_cylinder_under_the_start_stress(engine, monkeypatch):
    """Round 70: the row the trapezoid brought within 0.05 dx, under ``stress_at = "start"`` (still selectable): round
    61's figure, outside (+0.051 dx, taichi_mpm +0.053), a strict xfail until round 86. Since round 86 (the box's ground
    take-back bounded by its base's flatness, ``gasp_core.mpm.take_back``) +0.046 dx on both engines: inside, by
    0.004."""
    import gasp_core.mpm.gap_touch as G
    monkeypatch.setattr(G, "CURVATURE", True)
    gap = _landed(engine, "cylinder", 32, stress_at="start")
    assert gap == pytest.approx(0.0, abs=0.05), gap


@pytest.mark.slow
def test_the_curved_touch_check_catches_round_60():
    """Round 60's rule (the default: half a spacing's separation) fails the check above: the ball on the box at
    n_grid 32 rests +0.224 dx apart (warp_mpm)."""
    gap = _landed("warp_mpm", "ball", 32)
    assert gap == pytest.approx(0.224, abs=0.05) and abs(gap) > 0.05, gap


@pytest.mark.xfail(strict=True, reason="round 61: the stacked balls rest -0.058 dx under CURVATURE (a sink after the "
                                       "first touch, docs/contact.md 'Round 61'); round 60's default -0.009")
def test_the_curved_touch_stacks_the_balls(monkeypatch):
    """Round 61's rule on ``stacked_gap`` (warp_mpm): measured -0.058 dx, outside 0.05 (why the switch is off)."""
    import gasp_core.mpm.gap_touch as G
    monkeypatch.setattr(G, "CURVATURE", True)
    ok, gap = _gap("warp_mpm", balance=True)   # round 61 measured it with the ground balance
    assert gap == pytest.approx(0.0, abs=0.05), gap
