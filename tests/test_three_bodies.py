"""Three soft bodies, a grid velocity field each against the bodies they touch (round 61, issue 67 item 4,
``docs/contact.md`` "Round 61: a field per body by colouring"; ``gasp_core.mpm.colouring``).

Before round 61 three or more solids on the particle contact shared one grid velocity field and were welded where
they touched. Now the bodies within reach of each other (``colouring.reach``: 3 cells plus what a pair can close in a
frame) are the edges of a graph, 2-coloured into the two fields (``in_a``). The families, both MPM engines (warp_mpm's
first cases in the default tier, taichi_mpm's kernels compile in about 40 s: slow), each with its catch (the rule
before, ``colouring.COLOUR = False``: one shared field):

- **three stacked**: three jelly balls (R 5 cm) or cubes (10 cm) stacked in a frictionless tube
  (``scenes_three.stack3``), n_grid 24 and 32: each interface's gap at rest (the ``stacked_gap`` measure, the last
  0.5 s of 1 s) within :data:`GAP_TOL` = ``STACK_GAP_TOL`` (0.25 dx, the conformance scene's limit) of 0; the rule
  before holds them +0.75 to +1.18 dx apart. Round 60's tighter 0.05 dx (``tests/test_stacked_balls.py``, two balls)
  is NOT met: the three balls' upper interface rests -0.099 dx at n_grid 24 (two balls -0.015), both +0.05 at 32
  (two +0.007); flat faces rest +0.09 to +0.18 dx apart (two cubes +0.15 to +0.20: round 60's separation).
- **a block on a block on a block**: the top block thrown at 0.5 m/s (``scenes_three.slide3``) slides over
  ``V0^2 / (2 mu g (1 + m1 / (m2 + m3)))`` within :data:`SLIDE_TOL` and the lower two end at ``V0 m1 / M`` within
  :data:`MOMENTUM_TOL`; the rule before glues it (-100 %).
- **three falling apart**: a box on the ground, a cube over it and a ball over the cube, each 0.3 or 1.0 dx plus the
  frame's fall apart (``scenes_three.fall3``): the upper two's mean v_z after the frame within 5 % of ``-g t``; the
  rule before: -89 % and -26 % at 0.3 dx.
- **a body that meets another later** (the colouring made again per frame, ``colouring.RECOLOUR``): a jelly ball
  dropped from out of reach onto a slab a cube rests on (``scenes_three.land3``, n_grid 32, 2 s): its rest gap over
  the slab within :data:`LAND_TOL` of the same ball's on the slab alone (two bodies): +0.205 against +0.193 dx on
  warp_mpm. The catch: the colouring made once at build (the ball, alone at the start, in the slab's field): +1.185.
  Round 73: a strict xfail under the trapezoid (the reference ball rolled off the slab); it passes since round 86's
  take-back (round 87: +0.201 against +0.194 dx, warp_mpm).
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from gasp_core.mpm import colouring, fields
from gasp_core.mpm.shared_fields import shared_field_bodies
from gasp_core.testing import scenes_three as S
from gasp_core.testing.scenes_pairs import STACK_GAP_TOL

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))
import three_bodies as B  # noqa: E402

ENGINES = [e for e in ("warp_mpm", "taichi_mpm") if importlib.util.find_spec(f"gasp_{e}") is not None]
#: The stack's interfaces' gap at rest (dx), two-sided about 0: the ``stacked_gap`` conformance limit.
GAP_TOL = STACK_GAP_TOL
#: The slide (relative), two-sided: the issue's 10 %, a pair coefficient 5 % off fails at 3.5 % (the two-body test's).
SLIDE_TOL = 0.035
MOMENTUM_TOL = 0.05
#: The ball landed beside the cube against the ball on the slab alone, dx, two-sided (the stacked balls' 0.05).
LAND_TOL = 0.05
#: The free fall: mean v_z within this of ``-g t``.
FALL_TOL = 0.05


def _slow(engine, default=False):
    return [] if (engine == "warp_mpm" and default) else [pytest.mark.slow]


def test_the_colouring_puts_touching_bodies_in_different_fields():
    in_a, shared, edges = colouring.colour_scene(S.stack3("ball"))
    assert in_a.tolist() == [False, True, False] and shared == [] and sorted(edges) == [(0, 1), (1, 2)]
    in_a, shared, edges = colouring.colour_scene(S.slide3(32))
    assert in_a.tolist() == [True, False, True] and sorted(edges) == [(0, 1), (1, 2)]   # the sliding pair: the larger in B
    in_a, shared, edges = colouring.colour_scene(S.fall3(0.3))
    assert in_a.tolist() == [False, True, False] and sorted(edges) == [(0, 1), (1, 2)]
    assert fields.field_bodies(S.stack3("ball")).tolist() == [False, True, False]
    assert shared_field_bodies(S.stack3("ball")) == []


def test_an_odd_cycle_keeps_sharing_and_is_named():
    """Three balls side by side, each touching the other two: one pair keeps a shared field, named."""
    s = S.stack3("ball")
    x = np.asarray(s.x).copy()
    n = len(x) // 3
    for k, ang in enumerate((0.0, 2.1, 4.2)):
        x[k * n:(k + 1) * n] = np.asarray(s.x)[:n] + 0.1 * np.array([np.cos(ang), np.sin(ang), 0.0]) / np.sqrt(3)
    s.x = x
    in_a, shared, edges = colouring.colour_scene(s)
    assert len(edges) == 3 and len(shared) == 1
    assert shared_field_bodies(s) == sorted(shared[0])


def test_two_bodies_and_rigid_ones_keep_the_rule_before(monkeypatch):
    from gasp_core.seam.setup import Material
    two = S.stack3("ball", n=2)
    assert not colouring.coloured(two) and fields.field_bodies(two).tolist() == [False, True]   # as before
    rigid = S.stack3("ball")
    rigid.materials = [*rigid.materials[:2], Material("jelly", model="rigid", E=1e5, rho=1000.0)]
    assert colouring.coloured(rigid) and shared_field_bodies(rigid) == []   # round 62 (rigid_pairs): coloured too
    with monkeypatch.context() as m:   # the rule before round 62: one field for them all
        m.setattr(colouring, "RIGID_PAIRS", False)
        assert not colouring.coloured(rigid) and fields.field_bodies(rigid) is None
        assert shared_field_bodies(rigid) == [0, 1, 2]
    monkeypatch.setattr(colouring, "COLOUR", False)
    assert fields.field_bodies(S.stack3("ball")) is None
    assert shared_field_bodies(S.stack3("ball")) == [0, 1, 2]


def _stack_ok(engine, shape, n_grid):
    three, _ = B.stack_gaps(engine, shape, n_grid, 3)
    return all(abs(g) <= GAP_TOL for g in three), three


STACK = [pytest.param(e, sh, ng, id=f"{e}-{sh}-{ng}", marks=_slow(e, (sh, ng) == ("ball", 24)))
         for e in ENGINES for sh in ("ball", "cube") for ng in (24, 32)]


@pytest.mark.parametrize("engine,shape,n_grid", STACK)
def test_three_stacked_meet_at_their_surfaces(engine, shape, n_grid):
    """Measured (both engines alike): balls -0.030 / -0.099 dx (n_grid 24), +0.047 / +0.050 (32); cubes +0.183 /
    +0.158 (24), +0.088 / +0.158 (32); one field: +0.75 to +1.18."""
    ok, fig = _stack_ok(engine, shape, n_grid)
    print(f"FIG stack {engine} {shape} {n_grid}: {fig}")
    assert ok, fig


def _slide_ok(engine, n_grid, mu):
    d, v, mid, _ = B.slide(engine, n_grid, mu)
    return abs(d) <= SLIDE_TOL and abs(v) <= MOMENTUM_TOL, (d, v, mid)


SLIDE = [pytest.param(e, ng, mu, id=f"{e}-{ng}-{mu}", marks=_slow(e, (ng, mu) == (32, 0.3)))
         for e in ENGINES for ng, mu in ((32, 0.3), (48, None))]


@pytest.mark.parametrize("engine,n_grid,mu", SLIDE)
def test_a_block_slides_on_a_block_on_a_block(engine, n_grid, mu):
    ok, fig = _slide_ok(engine, n_grid, mu)
    print(f"FIG slide {engine} {n_grid} {mu}: {fig}")
    assert ok, fig


def _fall_ok(engine, gap, n_grid):
    v1, v2, _ = B.fall(engine, gap, n_grid)
    return abs(v1) <= FALL_TOL and abs(v2) <= FALL_TOL, (v1, v2)


FALL = [pytest.param(e, gap, ng, id=f"{e}-{gap}dx-{ng}", marks=_slow(e, (gap, ng) == (0.3, 32)))
        for e in ENGINES for gap in (0.3, 1.0) for ng in (32, 48)]


@pytest.mark.parametrize("engine,gap,n_grid", FALL)
def test_three_bodies_apart_fall_freely(engine, gap, n_grid):
    ok, fig = _fall_ok(engine, gap, n_grid)
    print(f"FIG fall {engine} {gap} {n_grid}: {fig}")
    assert ok, fig


@pytest.mark.parametrize("engine", [pytest.param(e, marks=_slow(e, True)) for e in ENGINES])
@pytest.mark.parametrize("case", ["fall", pytest.param("slide", marks=pytest.mark.slow),
                                  pytest.param("stack", marks=pytest.mark.slow)])
def test_the_rule_before_is_caught(engine, case, monkeypatch):
    """One shared field (the rule before, ``COLOUR`` False) fails each family's check: the fall at 0.3 dx (n_grid
    32), the slide (n_grid 32, mu 0.3), the three balls' stack (n_grid 24)."""
    monkeypatch.setattr(colouring, "COLOUR", False)
    ok, fig = (_fall_ok(engine, 0.3, 32) if case == "fall" else _slide_ok(engine, 32, 0.3) if case == "slide"
               else _stack_ok(engine, "ball", 24))
    print(f"FIG before {case} {engine}: {fig}")
    assert not ok, fig


def _land_ok(engine):
    three = B.land(engine)[0]
    two = B.land(engine, pair=True)[0]
    return abs(three - two) <= LAND_TOL, (three, two)


# Round 73 (verify73 found it; the lead measured why, warp_mpm, ``scenes_three.land3`` at n_grid 32): under the
# trapezoidal stress (the default since round 70) the reference, the ball landed on the slab *alone*, rolled off the
# slab's end (0.431 dx against the ball beside the cube's 0.205), a strict xfail until round 87. Round 87 found it
# passing: since round 86 the balance no longer takes back the torque of a flat patch (``gasp_core.mpm.take_back``),
# and the ball alone rests on the slab (0.194 dx against 0.201 beside the cube, warp_mpm; taichi_mpm 0.195 / 0.200).
# With ``PLANE_BOUND`` off (round 85's take-back) it reads 0.431 dx again (warp_mpm, a probe).
@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("recolour", [pytest.param(True, id="per-frame"), pytest.param(False, id="once-caught")])
def test_a_body_that_meets_another_later_lands_as_alone(engine, recolour, monkeypatch):
    """Per frame: the ball rests on the slab as it does without the cube; made once at build (the catch): it shares
    the slab's field and is held about a cell over it."""
    monkeypatch.setattr(colouring, "RECOLOUR", recolour)
    ok, fig = _land_ok(engine)
    print(f"FIG land {engine} recolour {recolour}: {fig}")
    assert ok == recolour, fig


def test_a_resumed_coloured_run_continues_bit_for_bit():
    """``get_state`` carries a coloured scene's last fields (``colour_prev``, ``colouring.colour_state``) and
    ``set_state`` restores them, so a run resumed after frame 3 of the landing ball (``land3``, warp_mpm) ends where
    the uninterrupted run does, bit for bit. The catch: a saved record with the fields swapped is read (the next frame
    keeps the swapped fields: other bits)."""
    from gasp_core.seam import build_engine, get_engine
    pytest.importorskip("gasp_warp_mpm")
    s = S.land3(24)
    e = build_engine(get_engine("warp_mpm"), s)
    for _ in range(3):
        e.step_frame()
    st = e.get_state()
    assert "colour_prev" in st and st["colour_prev"].shape == (3,)
    for _ in range(2):
        e.step_frame()
    ref = e.positions().copy()
    e.close()
    out = {}
    for name, rec in (("resumed", st), ("swapped", {**st, "colour_prev": 1 - st["colour_prev"]})):
        r = build_engine(get_engine("warp_mpm"), S.land3(24))
        r.set_state(rec)
        for _ in range(2):
            r.step_frame()
        out[name] = r.positions().copy()
        r.close()
    np.testing.assert_array_equal(out["resumed"], ref)
    assert not np.array_equal(out["swapped"], ref)
