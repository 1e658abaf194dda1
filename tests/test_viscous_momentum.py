"""Round 49 (issue 67): the implicit viscous step conserves total momentum, both MPM engines (docs/contact.md
"Round 49: the viscous step's momentum, a uniform correction").

The step solves ``(M + dt K) v = M v*`` by CG to ``TOL`` (1e-2); ``K`` sums to zero, so the exact solution keeps
``sum m v*``, but the CG's iterate ``u`` lacks the residual's sum. Round 49's rule adds one uniform velocity
``du = sum r / sum m`` over the solved nodes (``ImplicitViscosity.conserve``). The scene: a free jelly cube (no
gravity, no boundary in reach, ``viscosity`` 200 Pa s) given a sheared, stretched velocity field, so ``K v*`` is
large; every viscous step of its first frame is wrapped and the grid's momentum compared before and after. Checks:
the change under ``MOMENTUM_TOL`` of the body's momentum scale ``M |v|_max`` (round-off of f32 sums over the grid:
1.5e-8 measured, both engines), and the catch: ``conserve`` False (the rule before round 49) changes it by more than
ten times that (1.43e-4 measured, both engines). About 3-8 s an engine once the kernels are cached.
"""
from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from gasp_core.seam.build import build_engine
from gasp_core.seam.setup import Material
from gasp_core.testing.helpers import box_points, make_setup

ENGINES = [e for e, mod in (("taichi_mpm", "gasp_taichi_mpm"), ("warp_mpm", "gasp_warp_mpm"))
           if importlib.util.find_spec(mod) is not None]
#: Both schedules of each engine (the gpu schedule's fixed-tree sums run on this CPU too).
SCHEDULES = ["cpu", "gpu"]
#: The largest change of the grid's total momentum a viscous step may make, over ``M |v|_max``.
MOMENTUM_TOL = 1e-6


def _setup(schedule: str = "cpu"):
    x, p_vol = box_points((0.35, 0.35, 0.35), (0.65, 0.6, 0.55), 1.0 / 48)
    c = x.mean(axis=0)
    d = x - c
    v = np.stack([2.0 * d[:, 2] + 0.3, 1.5 * d[:, 1] ** 2 * 40.0, 1.0 * d[:, 0] - 0.8 * d[:, 2]], axis=1)
    mat = Material("jelly", E=1e5, nu=0.3, rho=1000.0, viscosity=200.0)
    return make_setup(x, p_vol, mat, v=v, gravity=(0.0, 0.0, 0.0), n_grid=24, frame_dt=0.01,
                      options={"threads": 1, "schedule": schedule}), v


def _grid_momentum(eng, engine: str) -> np.ndarray:
    if engine == "taichi_mpm":
        g = eng.solver.grid_mv.to_numpy()[0]
        return g[..., :3].astype(np.float64).reshape(-1, 3).sum(axis=0)
    return eng.grid_mv.numpy()[:, :3].astype(np.float64).sum(axis=0)


def _viscous_cls(engine: str):
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.viscosity import ImplicitViscosity as cls
    else:
        from gasp_warp_mpm.viscosity import ImplicitViscosity as cls
    return cls


def viscous_momentum_change(engine: str, schedule: str = "cpu") -> float:
    """The largest change of the grid's total momentum (kg m/s) a viscous step of the free sheared cube's first
    frame made on ``schedule``, over ``M |v|_max`` (float)."""
    from gasp_core.seam.plugins import engines
    s, v = _setup(schedule)
    eng = build_engine(engines()[engine], s)
    visc = eng.solver.visc if engine == "taichi_mpm" else eng.visc
    changes = []
    solve = visc.solve

    def wrapped(*a, **k):
        before = _grid_momentum(eng, engine)
        solve(*a, **k)
        changes.append(np.abs(_grid_momentum(eng, engine) - before).max())

    visc.solve = wrapped
    try:
        eng.step_frame()
    finally:
        eng.close()
    mass = float((s.p_vol * 1000.0).sum())
    assert changes, "no viscous step ran"
    return max(changes) / (mass * float(np.abs(v).max()))


@pytest.mark.parametrize("schedule", SCHEDULES)
@pytest.mark.parametrize("engine", ENGINES)
def test_the_viscous_step_conserves_total_momentum(engine, schedule):
    err = viscous_momentum_change(engine, schedule)
    assert err < MOMENTUM_TOL, f"{engine} ({schedule}): a viscous step changed the momentum by {err:.3g} of M |v|"


@pytest.mark.parametrize("schedule", SCHEDULES)
@pytest.mark.parametrize("engine", ENGINES)
def test_the_momentum_check_catches_the_leaking_iterate(engine, schedule, monkeypatch):
    monkeypatch.setattr(_viscous_cls(engine), "conserve", False)   # the CG's iterate m u, the rule before round 49
    err = viscous_momentum_change(engine, schedule)
    assert err > 10 * MOMENTUM_TOL, f"{engine} ({schedule}): conserve False changed the momentum by only {err:.3g} of M |v|"
