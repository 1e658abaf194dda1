"""Coulomb's law read on the sand block thrown along the GROUND, on finer grids (issue 67 round 41, docs/contact.md
"Round 41: the finer grid on the ground"), both grid engines.

The block of ``sand_ball.slide_setup(v0, ground=True)`` (6 x 6 x 3 cm of the sand, tan phi on a ground of the same
friction, the grid contact's boundary rule with round 36's touched layer) read by ``sand_ball.coulomb_ratio``: its
horizontal momentum lost over the normal impulse the ground gave it, from the throw to frame 3, at 1.2 and 1.6 m/s
(``RATIO_SPEEDS``: all of its base still slides forward). Only the ground pushes on the block besides gravity, so
Coulomb's law makes it the ground's ``friction`` (the answer, read from the setup) however the sand slumps.

Why: the same block's travel figure, ``v0^2 / (2 g travel)`` at 0.4-0.8 m/s, reads 0.563-0.569 at n_grid 32 but
0.516-0.539 at 48 and 0.461-0.513 at 64 against tan 30 deg = 0.577. The ratio reads within 0.4 % of the ground's
friction on every grid (measured, both engines the same to 0.01 %: n32 -0.04 / -0.02 %, n48 -0.17 / -0.08 %, n64
-0.31 / -0.15 %), and a block that keeps its shape stops within 0.6 % of Coulomb's travel on the same grids, so the
finer grid's deficit is not the contact's: the finer sand block slumps and spreads (at 0.6 m/s its outermost points
along y reach 29, 37 and 44 mm from its axis in 6 frames at n_grid 32, 48, 64, from 26-28; its base's back slips
backwards and sideways once it slows, where the ground's friction does not act against x).

- The family: n_grid 32, 48, 64 at 30 degrees and 48 at 35, each speed within ``RATIO_TOL`` = 2.5 %, either side
  (warp_mpm n_grid 32 in the default tier, the rest slow).
- A block that keeps its shape (the slab's jelly, ``contact = "grid"``: the same boundary rule) thrown along the same
  ground at 0.4 / 0.6 / 0.8 m/s stops at Coulomb's ``v0^2 / (2 mu g)`` within ``RATIO_TOL`` at each speed, n_grid 32,
  48, 64 (warp_mpm n_grid 32 in the default tier; measured, both engines: -0.53 to -0.26 %, -0.32 to -0.18 %, -0.36
  to +0.38 %; round 49 +4.0 / +2.7 / +2.0 % at n_grid 32, +4.4 / +3.0 / +2.3 % at 48, +3.6 / +2.4 / +1.8 % at 64;
  round 50, the dashpot's push credited to the column's Coulomb bound, docs/contact.md "Round 50": -1.26 / -0.85 /
  -0.64 %, -1.22 / -0.82 / -0.63 %, -1.63 / -1.11 / -0.87 %); its catches, the engine's ground friction 0.95 / 1.05
  times at n_grid 64: +5.0 to +5.8 % / -4.4 to -5.1 %, and round 49's rule (``touch_credit`` False) at n_grid 32.
- The catches: the engine's ground friction (its grid rule's, the box hold's kept) 0.95 and 1.05 times the ground's
  fail it on both engines (measured about -5 and +5 %). Round 36's touched layer off does NOT fail it (-1.2 / -0.5 %
  at n_grid 32, warp_mpm): without the layer the friction still meets mu times the normal load; the load is what
  falls (the block sinks and slumps), which ``tests/test_ground_touch.py`` (the rest height, the held slope) catches.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gasp_core.testing import sand_ball as S
from gasp_core.testing.scenes_flow_pairs import RATIO_FRAMES, RATIO_SPEEDS, RATIO_TOL, SLIDE_FRAMES, SPEEDS

#: (n_grid, the sand's friction angle in degrees: the ground's friction its tan)
FAMILY = [(32, 30.0), (48, 30.0), (64, 30.0), (48, 35.0)]


def _engine(engine: str):
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    from gasp_core.seam.plugins import get_engine
    return get_engine(engine)


def ratio_errors(engine: str, n_grid: int, phi: float, monkeypatch) -> dict:
    """``coulomb_ratio`` over the ground's friction, less 1, at each of ``RATIO_SPEEDS`` (dimensionless), for the block
    on the ground at ``n_grid`` with the sand's friction angle ``phi`` (degrees)."""
    from gasp_core.testing.kit import run_trace
    info = _engine(engine)
    monkeypatch.setattr(S, "N_GRID", n_grid)
    monkeypatch.setattr(S, "SAND", dataclasses.replace(S.SAND, friction_angle=phi))
    err = {}
    for v0 in RATIO_SPEEDS:
        setup = S.slide_setup(v0, {"threads": 1}, ground=True)
        mu = float(setup.boundaries[0].friction)
        assert np.isclose(mu, np.tan(np.radians(phi)))
        tr = run_trace(info, setup, RATIO_FRAMES)
        err[v0] = S.coulomb_ratio(tr.v, setup, 0, RATIO_FRAMES) / mu - 1.0
    return err


def jelly_errors(engine: str, n_grid: int) -> dict:
    """A block that keeps its shape (``slide_setup(..., solid=True, ground=True)``: the slab's jelly, ``contact =
    "grid"``) thrown along the ground at each of ``SPEEDS``: its travel over Coulomb's ``v0^2 / (2 mu g)``, less 1."""
    from gasp_core.testing.kit import run_trace
    info = _engine(engine)
    err = {}
    for v0 in SPEEDS:
        setup = S.slide_setup(v0, {"threads": 1, "contact": "grid"}, ground=True, solid=True)
        assert setup.n_grid == n_grid
        mu, g = float(setup.boundaries[0].friction), -float(setup.gravity[2])
        tr = run_trace(info, setup, SLIDE_FRAMES)
        err[v0] = S.slide_travel(tr.x[0], tr.x[-1], setup) / (v0 ** 2 / (2.0 * mu * g)) - 1.0
    return err


def bias_ground_friction(monkeypatch, engine: str, factor: float) -> None:
    """A broken engine: its grid rule's ground friction (and the touched layer's, which reads it) ``factor`` times the
    ground's; the setup, hence the answer, keeps it."""
    if engine == "taichi_mpm":   # the engine reads its grounds from node_ranges when it builds the solver
        import gasp_taichi_mpm.grid as tg
        real = tg.node_ranges

        def biased(setup, dx, contact="particle"):
            walls, grounds, regions = real(setup, dx, contact)
            return walls, [(factor * g[0],) + tuple(g[1:]) for g in grounds], regions
        monkeypatch.setattr(tg, "node_ranges", biased)
    else:   # the grounds' (top layer, friction, full layer) array, uploaded before the kernels are recorded
        from gasp_warp_mpm.engine import WarpMPMEngine
        real = WarpMPMEngine._upload_boundaries

        def upload(self, Ft):
            real(self, Ft)
            g = self.ground.numpy().copy()
            g[:, 1] *= factor
            self.ground = self._array(g.astype(self._np_dtype), self.k.vec3)
        monkeypatch.setattr(WarpMPMEngine, "_upload_boundaries", upload)


def _case(engine: str, case: tuple):
    marks = [] if (engine, case) == ("warp_mpm", FAMILY[0]) else [pytest.mark.slow]
    return pytest.param(engine, case, marks=marks, id=f"{engine}-n{case[0]}-phi{case[1]:g}")


@pytest.mark.parametrize("engine, case", [_case(e, c) for e in ("warp_mpm", "taichi_mpm") for c in FAMILY])
def test_the_block_on_the_ground_slides_by_coulombs_law_on_finer_grids(engine, case, monkeypatch):
    err = ratio_errors(engine, *case, monkeypatch)
    assert all(abs(e) <= RATIO_TOL for e in err.values()), (engine, case, err)


@pytest.mark.parametrize("factor", [0.95, 1.05])
@pytest.mark.parametrize("engine, n_grid", [("warp_mpm", 32), pytest.param("warp_mpm", 64, marks=pytest.mark.slow),
                                            pytest.param("taichi_mpm", 32, marks=pytest.mark.slow),
                                            pytest.param("taichi_mpm", 64, marks=pytest.mark.slow)])
def test_the_ground_check_catches_the_ground_friction_5pct_off(engine, n_grid, factor, monkeypatch):
    bias_ground_friction(monkeypatch, engine, factor)
    err = ratio_errors(engine, n_grid, 30.0, monkeypatch)
    assert any(abs(e) > RATIO_TOL for e in err.values()), (engine, n_grid, factor, err)
    assert all((e < 0) == (factor < 1) for e in err.values()), err


@pytest.mark.parametrize("engine, n_grid", [pytest.param(e, n, marks=[] if (e, n) == ("warp_mpm", 32) else [
    pytest.mark.slow], id=f"{e}-n{n}") for e in ("warp_mpm", "taichi_mpm") for n in (32, 48, 64)])
def test_a_block_that_keeps_its_shape_stops_at_coulombs_travel_on_finer_grids(engine, n_grid, monkeypatch):
    monkeypatch.setattr(S, "SOLID_N_GRID", n_grid)
    err = jelly_errors(engine, n_grid)
    assert all(abs(e) <= RATIO_TOL for e in err.values()), (engine, n_grid, err)


@pytest.mark.slow
@pytest.mark.parametrize("factor", [0.95, 1.05])
@pytest.mark.parametrize("engine", ["warp_mpm", "taichi_mpm"])
def test_the_travel_check_catches_the_ground_friction_5pct_off(engine, factor, monkeypatch):
    monkeypatch.setattr(S, "SOLID_N_GRID", 64)
    bias_ground_friction(monkeypatch, engine, factor)
    err = jelly_errors(engine, 64)
    assert any(abs(e) > RATIO_TOL for e in err.values()), (engine, factor, err)
    assert all((e > 0) == (factor < 1) for e in err.values()), err   # less friction, longer travel


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["warp_mpm", "taichi_mpm"])
def test_the_travel_check_catches_round_49s_frictionless_dashpot(engine, monkeypatch):
    # touch_credit False: round 49's rule, whose dashpot on the touched layers carries part of the sliding block's
    # load with no friction (+4.0 / +2.7 / +2.0 % at n_grid 32, both engines; docs/contact.md "Round 50")
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.grid import GridUpdate as cls
    else:
        from gasp_warp_mpm.engine import WarpMPMEngine as cls
    monkeypatch.setattr(cls, "touch_bound", "credit")   # round 51: touch_credit is read under round 50's bound
    monkeypatch.setattr(cls, "touch_credit", False)
    monkeypatch.setattr(S, "SOLID_N_GRID", 32)
    err = jelly_errors(engine, 32)
    assert any(abs(e) > RATIO_TOL for e in err.values()), (engine, err)
