"""Issue 67 items 1-2, body on body (round 90, ``docs/rigid.md`` "Round 90: a round body on another rigid body"): a rigid
ball or solid cylinder rolls and slips on another rigid body (a slab lying on the tilted ground) as the closed forms
of its own inertia say, on both MPM engines (``benchmarks/studies/roll_pair90.py``).

The pair law (``gasp_core.mpm.rigid_friction.pair_contact``) took the contact midway between the two bodies' support
planes, read from tables of their points (round 65). Round 90's family found a round body on it off by up to 8 %: a
5 cm cylinder at n_grid 32 spun up 5.28 % fast slipping and rolled with ``omega R / v`` 0.91, a sparse one spun up
35.6 % short. Now a round body's table is its exact shape's (``gasp_core.mpm.rigid_support.round_table``) and the
contact is taken on its surface (``gasp_core.mpm.rigid_pairs.ROUND_PAIR``).

- **The family** (slow, both engines): balls and cylinders of R 0.05 and 0.1 m at n_grid 24, 32 and 48 (a 0.48 m
  box), the 5 cm body at n_grid 48 with ``roll_family88``'s other samplings, mu 0.5 (rolls) and 0.05 (slips), each
  judged by ``test_rolling``'s two-sided 5 % check.
- **The default tier**: the 5 cm cylinder at n_grid 32, rolling and slipping, on both engines.
- **Catch**: round 65's tables and midway plane (``ROUND_PAIR`` 0) fail the 5 cm cylinder (warp_mpm).
- The exact tables (NumPy): a sphere's support and curvature, a cylinder's side and end, ``support_data``'s round
  bodies, and ``rigid_support.contact_plane``'s round rule.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))

import roll_family88 as RF  # noqa: E402
import roll_pair90 as RP  # noqa: E402
from slopes import ENGINES  # noqa: E402

from gasp_core.mpm import rigid_pairs  # noqa: E402
from gasp_core.mpm.rigid_support import contact_plane, flatness, round_table, table_directions  # noqa: E402


def _problem(engine: str, shape: str, radius: float, n_grid: int, sampling: str, mu: float) -> str | None:
    return RP.row(engine, shape, radius, n_grid, sampling, mu)["problem"]


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("mu", RF.MUS)
def test_a_5_cm_cylinder_rolls_and_slips_on_a_rigid_slab(engine, mu):
    pytest.importorskip(f"gasp_{engine}")
    problem = _problem(engine, "cylinder", 0.05, 32, "fibonacci", mu)
    assert problem is None, f"{engine} mu {mu}: {problem}"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("shape", ("ball", "cylinder"))
def test_a_round_body_rolls_or_slips_on_a_rigid_slab_across_the_family(engine, shape):
    pytest.importorskip(f"gasp_{engine}")
    bad = [f"R {r} n_grid {n} {s} mu {mu}: {p}" for r, n, s in RP.family() for mu in RF.MUS
           if (p := _problem(engine, shape, r, n, s, mu)) is not None]
    assert not bad, f"{engine} {shape}: {bad}"


def test_the_pair_check_catches_the_midway_plane(monkeypatch):
    """Round 65's tables of the points and the contact midway between the supports: the 5 cm cylinder rolls with
    ``omega R / v`` 0.91 (warp_mpm)."""
    pytest.importorskip("gasp_warp_mpm")
    monkeypatch.setattr(rigid_pairs, "ROUND_PAIR", 0)
    assert _problem("warp_mpm", "cylinder", 0.05, 32, "fibonacci", RF.MUS[0]) is not None


def test_a_round_table_is_the_exact_shape():
    d = table_directions(np.random.default_rng(0).normal(size=(50, 3)))
    h, C = round_table(d, np.array([0.05, 0.0, 0.0, 0.0, 0.0]))
    assert np.allclose(h, 0.05)
    K = C[:, [0, 1, 2, 1, 3, 4, 2, 4, 5]].reshape(-1, 3, 3)
    t = np.cross(d, [0.3, 0.5, 0.8])
    t /= np.linalg.norm(t, axis=1)[:, None]
    kappa = np.einsum("ni,nij,nj->n", t, K, t)
    assert np.allclose(kappa, 20.0)                                          # 1 / R along any tangent
    assert all(flatness(k, hh) == 0.0 for k, hh in zip(kappa, h))            # round: no face
    e = np.array([0.0, 1.0, 0.0])
    h, C = round_table(np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [np.cos(0.07), np.sin(0.07), 0.0]]),
                       np.array([0.05, 0.2, *e]))
    assert h[0] == pytest.approx(0.05) and h[1] == pytest.approx(0.2)          # its side, its end
    assert h[2] == pytest.approx(0.05 * np.cos(0.07))                          # a side direction 4 degrees off


def test_support_data_marks_the_round_bodies(monkeypatch):
    s, _, _ = RP.setup("ball", 0.05, 32, "fibonacci", 0.5)
    *_, nd, rnd = rigid_pairs.support_data(s)
    assert list(rnd) == [1.0, 0.0]
    monkeypatch.setattr(rigid_pairs, "ROUND_PAIR", 0)
    assert list(rigid_pairs.support_data(s)[-1]) == [0.0, 0.0]


def test_the_contact_plane_is_on_the_round_bodys_surface():
    """The NumPy rule the engines' pair laws follow: midway between two supports, on a round body's own (A or B)."""
    d = table_directions(np.zeros((1, 3)))
    ball = (d, *round_table(d, np.array([0.05, 0.0, 0.0, 0.0, 0.0])))
    face = (d, np.full(len(d), 0.02), np.zeros((len(d), 6)))
    n, I = np.array([0.0, 0.0, -1.0]), np.eye(3)
    cA, cB = np.array([0.0, 0.0, 0.053]), np.array([0.0, 0.0, -0.02])   # the ball 3 mm over the face (its top z 0)
    assert contact_plane(ball, I, cA, face, I, cB, n) == pytest.approx(-0.0015)          # midway: z = 1.5 mm
    assert contact_plane(ball, I, cA, face, I, cB, n, round_a=True) == pytest.approx(-0.003)  # the ball's surface
    assert contact_plane(face, I, cB, ball, I, cA, -n, round_b=True) == pytest.approx(0.003)
