"""Round 50 (issue 67): the implicit viscous step's momentum correction is each body's own, both MPM engines and
both schedules (docs/dissipation.md "Round 50: the viscous correction per body").

Round 49's rule restored the CG residual's momentum as ONE uniform velocity ``du = sum r / sum m`` over all solved
nodes, so two viscous bodies on one grid shared it: a resting cube beside a sheared one moved. Round 50 sums
``r`` and ``m`` per node label (the least body id whose points reach the node) and gives each label its own
``du``; the labels partition the nodes, so the total momentum is still conserved to round-off.

The scenes (a family): a viscous block given a sheared, stretched velocity field (as tests/test_viscous_momentum.py)
and a resting viscous cube beside it, no gravity, no boundary in reach, on two grids and two gaps (4 and 6 node
spacings: no node is shared, so the two solves do not couple; and 3, where the two bodies' outer nodes are
neighbours). Checks over the first frames:

- the resting cube's largest point speed under ``REST_TOL`` of the sheared block's ``|v|_max``. The physics bound is
  0: no node is shared, so no force reaches the cube (its elastic stress is zero at rest); 1e-6 is the f32
  round-off scale the momentum check uses. The catch: round 49's one correction (``per_body`` False) moves it by
  more than ten times that (figures in the docs page and the test's message);
- the same at a gap of 3 node spacings, where the cells between the bodies have all 8 corners with mass: round 50's
  operator counts only the cells whose 8 corners share one body label (``same_label``); the catch: the rule before,
  every cell whose corners have mass, bridges the empty cells and moves the cube by over 1e4 times ``REST_TOL``;
- each viscous step's change of the grid's total momentum under ``MOMENTUM_TOL`` of ``M |v|_max`` (as
  tests/test_viscous_momentum.py), also with the two bodies touching (gap 0 and 1: nodes shared, the shared nodes'
  residual given to the lesser body id), where the catch is ``conserve`` False (the CG's leaking iterate).
"""
from __future__ import annotations

import importlib.util

import numpy as np
import pytest
from test_viscous_momentum import _grid_momentum, _viscous_cls

from gasp_core.seam.build import build_engine
from gasp_core.seam.setup import Material, SimSetup
from gasp_core.testing.helpers import box_points

ENGINES = [e for e, mod in (("taichi_mpm", "gasp_taichi_mpm"), ("warp_mpm", "gasp_warp_mpm"))
           if importlib.util.find_spec(mod) is not None]
SCHEDULES = ["cpu", "gpu"]
#: (n_grid, gap in node spacings, resting cube's side in node spacings)
SCENES = [(24, 4, 4), (32, 6, 6)]
#: Touching: the two bodies share nodes.
TOUCHING = [(24, 0, 4), (32, 1, 6)]
#: Apart by one empty node: the bodies' outermost nodes are neighbours (a gap of 2 shares a node: the grid couples).
NEIGHBOURS = [(24, 3, 4), (32, 3, 6)]
#: The resting cube's largest speed over the sheared block's |v|_max (physics: 0; f32 round-off scale).
REST_TOL = 1e-6
#: The largest change of the grid's total momentum a viscous step may make, over M |v|_max.
MOMENTUM_TOL = 1e-6
FRAMES = 3


def two_bodies(n_grid: int, gap: int, side: int, schedule: str):
    """A sheared viscous block (body 0) and a resting viscous cube (body 1) ``gap`` node spacings apart on
    ``n_grid``; returns ``(setup, v, body_id)``."""
    dx = 1.0 / n_grid
    spacing = dx / 2
    lo0 = np.array([0.5, 0.35, 0.35])
    hi0 = lo0 + np.array([8, 8, 6]) * dx
    xa, vol = box_points(tuple(lo0), tuple(hi0), spacing)
    lo1 = np.array([lo0[0] - (gap + side) * dx, 0.4, 0.4])   # on the side the block drifts away from
    xb, _ = box_points(tuple(lo1), tuple(lo1 + side * dx), spacing)
    c = xa.mean(axis=0)
    d = xa - c
    va = np.stack([2.0 * d[:, 2] + 0.3, 1.5 * d[:, 1] ** 2 * 40.0, 1.0 * d[:, 0] - 0.8 * d[:, 2]], axis=1)
    x = np.concatenate([xa, xb])
    v = np.concatenate([va, np.zeros_like(xb)])
    body = np.concatenate([np.zeros(len(xa), np.int32), np.ones(len(xb), np.int32)])
    mats = [Material("jelly", E=1e5, nu=0.3, rho=1000.0, viscosity=200.0) for _ in range(2)]
    s = SimSetup(x=x, v=v, p_vol=np.full(len(x), vol), body_id=body, materials=mats,
                 gravity=np.zeros(3), domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=n_grid, boundaries=[],
                 frame_dt=0.01, options={"threads": 1, "schedule": schedule})
    return s, v, body


def resting_speed(engine: str, schedule: str, n_grid: int, gap: int, side: int) -> tuple[float, float]:
    """``(the resting cube's largest speed, the largest momentum change of a viscous step)`` over ``FRAMES``
    frames, each over the sheared block's ``|v|_max`` (and ``M |v|_max``)."""
    from gasp_core.seam.plugins import engines
    s, v, body = two_bodies(n_grid, gap, side, schedule)
    eng = build_engine(engines()[engine], s)
    visc = eng.solver.visc if engine == "taichi_mpm" else eng.visc
    changes, solve = [], visc.solve

    def wrapped(*a, **k):
        before = _grid_momentum(eng, engine)
        solve(*a, **k)
        changes.append(np.abs(_grid_momentum(eng, engine) - before).max())

    visc.solve = wrapped
    speed = 0.0
    try:
        for _ in range(FRAMES):
            eng.step_frame()
            vel = np.asarray(eng.velocities(), dtype=np.float64)
            speed = max(speed, float(np.linalg.norm(vel[body == 1], axis=1).max()))
    finally:
        eng.close()
    vmax = float(np.abs(v).max())
    mass = float((s.p_vol * 1000.0).sum())
    assert changes, "no viscous step ran"
    return speed / vmax, max(changes) / (mass * vmax)


def _assert_at_rest(engine: str, schedule: str, scene: tuple) -> None:
    """The resting cube within ``REST_TOL`` of the block's ``|v|_max`` and each viscous step's momentum change within
    ``MOMENTUM_TOL`` (:func:`resting_speed`)."""
    rest, mom = resting_speed(engine, schedule, *scene)
    assert rest < REST_TOL, f"{engine} ({schedule}, {scene}): the resting cube reached {rest:.3g} of |v|_max"
    assert mom < MOMENTUM_TOL, f"{engine} ({schedule}, {scene}): a viscous step changed the momentum by {mom:.3g}"


@pytest.mark.parametrize("scene", SCENES, ids=lambda c: f"ng{c[0]}-gap{c[1]}-side{c[2]}")
@pytest.mark.parametrize("schedule", SCHEDULES)
@pytest.mark.parametrize("engine", ENGINES)
def test_a_resting_body_stays_at_rest_beside_a_sheared_one(engine, schedule, scene):
    _assert_at_rest(engine, schedule, scene)


@pytest.mark.parametrize("scene", SCENES, ids=lambda c: f"ng{c[0]}-gap{c[1]}-side{c[2]}")
@pytest.mark.parametrize("engine", ENGINES)
def test_the_rest_check_catches_one_correction_for_all(engine, scene, monkeypatch):
    monkeypatch.setattr(_viscous_cls(engine), "per_body", False)   # round 49's one du over the grid
    rest, mom = resting_speed(engine, "cpu", *scene)
    assert rest > 10 * REST_TOL, f"{engine} ({scene}): one correction moved the resting cube only {rest:.3g}"
    assert mom < MOMENTUM_TOL, f"{engine} ({scene}): one correction changed the momentum by {mom:.3g}"


@pytest.mark.parametrize("scene", NEIGHBOURS, ids=lambda c: f"ng{c[0]}-gap{c[1]}-side{c[2]}")
@pytest.mark.parametrize("schedule", SCHEDULES)
@pytest.mark.parametrize("engine", ENGINES)
def test_no_viscous_bridge_across_empty_cells(engine, schedule, scene):
    _assert_at_rest(engine, schedule, scene)


@pytest.mark.parametrize("scene", NEIGHBOURS, ids=lambda c: f"ng{c[0]}-gap{c[1]}-side{c[2]}")
@pytest.mark.parametrize("engine", ENGINES)
def test_the_bridge_check_catches_cells_valid_by_mass(engine, scene, monkeypatch):
    monkeypatch.setattr(_viscous_cls(engine), "same_label", False)   # every cell whose 8 corners have mass
    rest, _ = resting_speed(engine, "cpu", *scene)
    assert rest > 10 * REST_TOL, f"{engine} ({scene}): cells valid by mass moved the resting cube only {rest:.3g}"


@pytest.mark.parametrize("scene", TOUCHING, ids=lambda c: f"ng{c[0]}-gap{c[1]}-side{c[2]}")
@pytest.mark.parametrize("schedule", SCHEDULES)
@pytest.mark.parametrize("engine", ENGINES)
def test_touching_bodies_conserve_total_momentum(engine, schedule, scene):
    _, mom = resting_speed(engine, schedule, *scene)
    assert mom < MOMENTUM_TOL, f"{engine} ({schedule}, {scene}): a viscous step changed the momentum by {mom:.3g}"


@pytest.mark.parametrize("scene", TOUCHING, ids=lambda c: f"ng{c[0]}-gap{c[1]}-side{c[2]}")
@pytest.mark.parametrize("engine", ENGINES)
def test_the_touching_check_catches_the_leaking_iterate(engine, scene, monkeypatch):
    monkeypatch.setattr(_viscous_cls(engine), "conserve", False)   # the CG's iterate m u, the rule before round 49
    _, mom = resting_speed(engine, "cpu", *scene)
    assert mom > 10 * MOMENTUM_TOL, f"{engine} ({scene}): conserve False changed the momentum by only {mom:.3g}"
