"""Issue 67 item 4, body on body (round 91, ``docs/rigid.md`` "Round 91: the normal of a round body's contact"): two
rigid balls in an oblique frictionless impact meet along their line of centres, on both MPM engines
(``benchmarks/studies/roll_impact91.py``).

The pair law took its normal from the touching nodes and acted as soon as the nodes touched: the struck ball left
24.5 degrees off the path where the line of centres is 30 (-18 %). Now two spheres take their line of centres
(``gasp_core.mpm.rigid_support.pair_normal``) and keep the approach that only closes their gap
(``gasp_core.mpm.rigid_friction.allowed_approach``, speculative contact).

- **Default tier**: ``b / R`` 1 (phi 30 degrees) at n_grid 32 on both engines, the struck ball's direction and speed
  within ``roll_impact91.TOL`` (4 %, two-sided) of the closed forms, momentum kept.
- **Slow**: the family (``b / R`` 0.5, 1, 1.5; n_grid 24-48; R 5 and 10 cm; a struck ball three times as dense).
- **Catch**: the nodes' normal (``ROUND_NORMAL`` 0, warp_mpm) fails the default case.
- The NumPy rules: the line of centres, the gap known only where a sphere's support is exact, the approach kept.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))

import roll_impact91 as RI  # noqa: E402
from slopes import ENGINES  # noqa: E402

from gasp_core.mpm import rigid_pairs  # noqa: E402
from gasp_core.mpm.rigid_friction import allowed_approach, pair_contact  # noqa: E402
from gasp_core.mpm.rigid_support import pair_gap, pair_normal, round_table, table_directions  # noqa: E402


@pytest.mark.parametrize("engine", ENGINES)
def test_a_struck_ball_leaves_along_the_line_of_centres(engine):
    pytest.importorskip(f"gasp_{engine}")
    r = RI.row(engine, 0.05, 32, 1.0, 1.0)
    assert r["problem"] is None, f"{engine}: {r['problem']}"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_oblique_impacts_across_the_family(engine):
    pytest.importorskip(f"gasp_{engine}")
    bad = [f"R {c[0]} n_grid {c[1]} b/R {c[2]} rho x{c[3]}: {p}" for c in RI.family()
           if (p := RI.row(engine, *c)["problem"]) is not None]
    assert not bad, f"{engine}: {bad}"


def test_the_impact_check_catches_the_nodes_normal(monkeypatch):
    pytest.importorskip("gasp_warp_mpm")
    monkeypatch.setattr(rigid_pairs, "ROUND_NORMAL", 0)
    r = RI.row("warp_mpm", 0.05, 32, 1.0, 1.0)
    assert r["problem"] is not None and "angle" in r["problem"], r


def test_the_pair_rules_for_two_spheres_and_the_gap():
    d = table_directions(np.zeros((1, 3)))
    ball = (d, *round_table(d, np.array([0.05, 0.0, 0.0, 0.0, 0.0])))
    cyl = (d, *round_table(d, np.array([0.05, 0.1, 0.0, 1.0, 0.0])))
    I, cone, lean = np.eye(3), np.cos(np.radians(rigid_pairs.NORMAL_CONE)), np.array([1.0, 0.0, 0.0])
    ca, cb = np.zeros(3), np.array([0.09, 0.05, 0.0])
    n = pair_normal(ball, I, ca, 1.0, ball, I, cb, 1.0, lean, cone)
    assert np.allclose(n, cb / np.linalg.norm(cb))                                       # the line of centres
    assert pair_gap(ball, I, ca, 1.0, ball, I, cb, 1.0, n, cone) == pytest.approx(np.linalg.norm(cb) - 0.1)
    assert np.allclose(pair_normal(ball, I, ca, 1.0, ball, I, cb, 1.0, lean, 2.0), lean)    # off: the nodes'
    assert pair_gap(ball, I, ca, 1.0, cyl, I, cb, 2.0, n, cone) == -1.0e30                 # a cylinder: none known
    assert allowed_approach(0.002, 0.5, 0.001) == pytest.approx(2.5)                       # closes 2 mm and keeps 0.5
    assert allowed_approach(-0.001, 0.5, 0.001) == 0.0 and allowed_approach(-1.0e30, 0.5, 0.001) == 0.0
    A = (np.array([1.0, 0.0, 0.0]), np.zeros(3), np.eye(3) * 1e-3, 1.0, np.zeros(3))
    B = (np.zeros(3), np.zeros(3), np.eye(3) * 1e-3, 1.0, np.array([0.1, 0.0, 0.0]))
    x_c, nx = np.array([0.05, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])
    assert pair_contact(A, B, x_c, nx, 0.0)[2] == pytest.approx(0.5)                      # inelastic: half each
    assert pair_contact(A, B, x_c, nx, 0.0, allow=0.4)[2] == pytest.approx(0.3)           # keeps 0.4 m/s of it
