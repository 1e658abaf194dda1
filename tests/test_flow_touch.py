"""The flowing body's touch in the two-field contact (issue 67 round 37, ``gasp_core.mpm.fields.flow_touch``,
docs/contact.md "Round 37: the flowing body's touch"), both grid engines.

- The level: B's gathered volume fraction a quarter cell outside a flat face, 0.35-0.39 over the face's place in
  its cell (0.5 on the face, 0.24 half a cell out): :func:`gasp_core.mpm.fields.flow_touch_level`.
- A sand block thrown at 0.4, 0.6 and 0.8 m/s along a jelly slab (``sand_ball.slide_setup``) travels as the same
  block thrown along the ground of the same friction (the scene ``sand_slide``'s answer) over a family (slow tier):
  n_grid 32 and 48, the sand's friction angle 35 degrees: the mean effective coefficient within ``MU_TOL`` = 4 % of
  the ground's and each speed's travel within ``SLIDE_TOL`` = 5 %. Measured (mean, warp_mpm; taichi_mpm within
  0.1 %): +1.95 % at n_grid 32 (+0.07 % since round 41), -1.81 % at 48 (+3.92 % under round 54's step,
  a strict xfail: :data:`N48_STEP`), +2.27 % at 35 degrees; before round 37
  -22.1, -13.3, -22.3 %. The slab 10 times stiffer (E 2e6 Pa) read +6.0 % (before -9.7 %), a strict xfail until
  round 41 (the thin support's rub, docs/contact.md "Round 41": B's mass mirrored in the ground's layers for the
  normal, the slab's ground friction to its own field); now ``stiff`` passes (+1.21 % warp_mpm, +1.22 %
  taichi_mpm: the ground's own +1.0 % at the stiff slab's substep); the same slab 4.5 cm thick (3 cells) reads
  +1.05 %, ``stiff_thick``.
  The catch (the rule off
  fails the check) is ``tests/test_contact_fields.py::test_the_slide_check_fails_without_friction_or_with_one_field``.
- A sand block resting on the slab (the same block, thrown at 0) stays on it: its lowest point between 0 and
  ``REST_GAP`` = 0.5 dx above the slab's face (measured +0.27 dx on both engines; -0.25 dx inside it before), and
  it does not move (under 0.5 mm).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from gasp_core.testing import sand_ball as S
from gasp_core.mpm.fields import flow_touch_level

MU_TOL, SLIDE_TOL, SPEEDS, FRAMES = 0.04, 0.05, (0.4, 0.6, 0.8), 6
REST_GAP, REST_MOVE = 0.5, 5e-4
ENGINES = ["warp_mpm", "taichi_mpm"]
#: (n_grid, the sand's friction angle in degrees, the slab's E in Pa, the slab's thickness in m)
#: Round 55: at n_grid 48 the check fails under the default cfl_rule "sum" (round 54), both engines alike: the mean
#: +3.92 % (limit 4) and the worst speed's travel 5.18 % (limit 5), where it read -1.81 % under "max"; the grid
#: contact's friction at a frictional base moves with the step (docs/contact.md "Round 55: the sand's slump against the
#: step" and "the touched layer as a rate": sand_slide's ratio +1.6-1.8 % a halving), the slab's and the ground's apart.
N48_STEP = ("round 55: n_grid 48 under cfl_rule 'sum': mean +3.92 % (limit 4), worst speed 5.18 % (limit 5), both "
            "engines; -1.81 % under 'max': the frictional base's step dependence (docs/contact.md 'Round 55')")
FAMILY = [(32, 30.0, 2e5, 0.03),
          pytest.param((48, 30.0, 2e5, 0.03), marks=pytest.mark.xfail(strict=True, raises=AssertionError,
                                                                       reason=N48_STEP)),
          (32, 35.0, 2e5, 0.03),
          (32, 30.0, 2e6, 0.03),
          (32, 30.0, 2e6, S.COULOMB_SLAB_H)]


def test_the_level_is_a_quarter_cell_outside_a_face():
    assert 0.35 <= flow_touch_level(0.25) <= 0.39
    assert abs(flow_touch_level(0.0) - 0.5) < 0.01
    assert flow_touch_level(0.5) < flow_touch_level(0.25) < flow_touch_level(0.0)


def _run(engine: str, monkeypatch, v0: float, ground: bool, n_grid: int, phi: float, E: float, slab_h: float = 0.03):
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.kit import run_trace
    monkeypatch.setattr(S, "N_GRID", n_grid)
    monkeypatch.setattr(S, "SAND", dataclasses.replace(S.SAND, friction_angle=phi))
    monkeypatch.setattr(S, "SLAB", dataclasses.replace(S.SLAB, E=E))
    setup = S.slide_setup(v0, {"threads": 1}, ground=ground, slab_h=slab_h)
    return run_trace(get_engine(engine), setup, FRAMES), setup


@pytest.mark.slow
@pytest.mark.parametrize("case", FAMILY, ids=["n32", "n48", "phi35", "stiff", "stiff_thick"])
@pytest.mark.parametrize("engine", ENGINES)
def test_sand_slides_on_a_slab_as_on_the_ground(engine, case, monkeypatch):
    travel = {}
    for v0 in SPEEDS:
        for ground in (False, True):
            tr, setup = _run(engine, monkeypatch, v0, ground, *case)
            travel[v0, ground] = S.slide_travel(tr.x[0], tr.x[-1], setup)
    ratio = {v0: travel[v0, True] / travel[v0, False] for v0 in SPEEDS}   # mu_eff on the slab / on the ground
    bias = float(np.mean(list(ratio.values()))) - 1.0
    worst = max(abs(travel[v0, False] / travel[v0, True] - 1.0) for v0 in SPEEDS)
    assert abs(bias) <= MU_TOL and worst <= SLIDE_TOL, (case, bias, worst, travel)


@pytest.mark.parametrize("engine", ENGINES)
def test_a_sand_block_rests_on_the_slab(engine, monkeypatch):
    tr, setup = _run(engine, monkeypatch, 0.0, False, S.N_GRID, S.SAND.friction_angle, S.SLAB.E)
    sel = np.asarray(setup.body_id) == 0
    dx = (setup.domain_hi[0] - setup.domain_lo[0]) / setup.n_grid
    gap = (tr.x[-1][sel, 2].min() - 0.03) / dx   # the slab's face at 3 cm
    assert 0.0 <= gap <= REST_GAP, gap
    assert abs(S.slide_travel(tr.x[0], tr.x[-1], setup)) < REST_MOVE
    assert math.isfinite(gap)
