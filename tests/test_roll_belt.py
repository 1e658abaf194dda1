"""Issue 67 items 2 and 3 on a sliding ``[[collider]]`` (round 90, ``docs/rigid.md`` "Round 90: round bodies on moving
colliders"): a rigid ball or solid cylinder at rest on a flat mesh plate that moves at ``U`` = 0.3 m/s from ``t = 0``
(``[[collider]] velocity``; ``benchmarks/studies/roll_belt90.py``), on both MPM engines.

Coulomb's closed form, of the body's own ``k = I / (M R^2)``: while it slips the centre accelerates at ``mu g`` along
the belt; the slip ends at ``t* = k U / ((1 + k) mu g)``; after it the body rolls at ``v = k U / (1 + k)`` (2/7 U for
a solid sphere, U/3 for a solid cylinder) with ``omega R = U - v``. Checked within ``test_rolling.TOL`` (5 %,
two-sided): the slipping acceleration (where the slip lasts six frames or more: mu 0.05), and ``v`` and ``omega R``
at 0.5 s.

- **The family** (slow, both engines): balls and cylinders of R 0.05 and 0.1 m at n_grid 32 and 48 (a 0.6 m box), the
  5 cm body at n_grid 48 with ``roll_family88``'s other samplings of its Gaussians, mu 0.05 and 0.5.
- **Blocks on the belt** (issue 67 items 1 and 3 on a moving collider): ``tests/test_elastic_slope.py``'s jelly (E
  1e5 Pa) as its flat block (15 x 15 x 5 cm) and round 77's 10 cm cube, at rest on the belt, on the particle and the
  grid contact, and the same blocks rigid (``tests/test_rigid_slope.py``'s hardwood). Coulomb: the centre accelerates
  at ``mu g`` until it rides the belt at ``t* = U / (mu g)``; then it keeps ``U``. The family (slow): both shapes,
  the three kinds, n_grid 24 and 48, mu 0.1 and 0.4.
- **The default tier**: the 10 cm ball slipping (mu 0.05) on the belt and the flat block (mu 0.1, n_grid 24) of each
  kind, on both engines; the belt's and the block's catches. Colliders that turn: ``tests/test_roll_spin.py``.
- **Catches**: a belt without friction (the body stays put), an engine that ignores ``mu`` (the collider's friction
  0.4 whatever the scene says), one that holds a body still while it is slower than 0.1 m/s
  (``slopes.rest_brake``), round 88's contact on the points (``ROUND_COLLIDER`` 0: the 5 cm ball at n_grid 48 rolls
  15 % fast, warp_mpm), and figures 6 % off; for the block of each kind a frictionless belt, one that ignores
  ``mu``, the rest brake and figures 6 % off.
"""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

pytest.importorskip("trimesh", reason="mesh colliders need trimesh (the [mesh] extra)")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))

import roll_belt90 as RB  # noqa: E402
from slopes import ENGINES, rest_brake  # noqa: E402

SLIP_MU = 0.05


def _problem(engine: str, shape: str, radius: float, n_grid: int, mu: float, sampling: str = "fibonacci", **spoil):
    _, fig, want = RB.measure(engine, shape, radius, n_grid, mu, sampling, **spoil)
    return RB.problem(want, fig)


@pytest.mark.parametrize("engine", ENGINES)
def test_a_ball_on_a_moving_belt_slips_then_rolls_at_two_sevenths_of_its_speed(engine):
    pytest.importorskip(f"gasp_{engine}")
    problem = _problem(engine, "ball", 0.1, 32, SLIP_MU)
    assert problem is None, f"{engine}: {problem}"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("shape", ("ball", "cylinder"))
def test_a_round_body_on_a_moving_belt_across_the_family(engine, shape):
    pytest.importorskip(f"gasp_{engine}")
    bad = [f"R {r} n_grid {n} {s} mu {mu}: {p}" for r, n, s in RB.family() for mu in RB.MUS
           if (p := _problem(engine, shape, r, n, mu, s)) is not None]
    assert not bad, f"{engine} {shape}: {bad}"


def test_the_belt_check_catches_broken_engines():
    """warp_mpm, the default tier's case: a belt without friction, and figures 6 % high or low, fail the check."""
    pytest.importorskip("gasp_warp_mpm")
    case = ("warp_mpm", "ball", 0.1, 32, SLIP_MU)
    _, fig, want = RB.measure(*case)
    caught = {"frictionless": _problem(*case, friction=0.0),
              "6 % high": RB.problem(want, {key: (None if val is None else 1.06 * val) for key, val in fig.items()}),
              "6 % low": RB.problem(want, {key: (None if val is None else 0.94 * val) for key, val in fig.items()})}
    missed = [k for k, v in caught.items() if v is None]
    assert not missed, f"the belt's check misses {missed}"


@pytest.mark.slow
def test_the_belt_check_catches_the_slower_broken_engines(monkeypatch):
    """warp_mpm (slow since round 91, 25 s): a belt whose friction ignores the ball's mu, a rest brake, and the 5 cm
    ball on its points fail the check."""
    pytest.importorskip("gasp_warp_mpm")
    import gasp_core.mpm.round_ground as rg
    case = ("warp_mpm", "ball", 0.1, 32, SLIP_MU)
    caught = {"ignores mu": _problem(*case, friction=0.4),
              "rest brake": _problem(*case, output=lambda c: rest_brake(c, RB.FPS))}
    monkeypatch.setattr(rg, "ROUND_COLLIDER", 0)
    caught["on its points"] = _problem("warp_mpm", "ball", 0.05, 48, SLIP_MU)
    missed = [k for k, v in caught.items() if v is None]
    assert not missed, f"the belt's check misses {missed}"


# --------------------------------------------------------------------------- blocks on the belt
KINDS = [pytest.param(m, c, id=f"{m}-{c or 'own'}") for m, c in RB.BLOCK_KINDS]


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("model,contact", KINDS)
def test_a_block_on_a_moving_belt_slips_at_mu_g_then_rides_it(engine, model, contact):
    pytest.importorskip(f"gasp_{engine}")
    r = RB.block(engine, "block", contact, 24, 0.1, model=model)
    assert r["problem"] is None, f"{engine} {model} {contact}: {r['problem']}"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("model,contact", KINDS)
def test_blocks_on_a_moving_belt_across_the_family(engine, model, contact):
    pytest.importorskip(f"gasp_{engine}")
    bad = [f"{shape} n_grid {n} mu {mu}: {p}" for shape in RB.BLOCKS for n in RB.BLOCK_GRIDS for mu in RB.BLOCK_MUS
           if (p := RB.block(engine, shape, contact, n, mu, model=model)["problem"]) is not None]
    assert not bad, f"{engine} {model} {contact}: {bad}"


@pytest.mark.parametrize("model,contact", KINDS)
def test_the_block_check_catches_broken_engines(model, contact):
    pytest.importorskip("gasp_warp_mpm")
    case = ("warp_mpm", "block", contact, 24, 0.1)
    r = RB.block(*case, model=model)
    want = {"a": r["a_want"], "v": r["v_want"]}
    caught = {"frictionless": RB.block(*case, friction=0.0, model=model)["problem"],
              "ignores mu": RB.block(*case, friction=0.4, model=model)["problem"],
              "rest brake": RB.block(*case, output=lambda c: rest_brake(c, RB.FPS), model=model)["problem"],
              **{name: RB.problem(want, {"a": f * r["a"], "v": f * r["v"]}) for name, f in (("6 % high", 1.06),
                                                                                           ("6 % low", 0.94))}}
    missed = [k for k, v in caught.items() if v is None]
    assert not missed, f"{model} {contact}: the block's check misses {missed}"
