"""Issue 67 item 2 on a ``[[collider]]`` (round 89, ``docs/rigid.md`` "Round 89"): a rigid ball or solid cylinder
rolls and slips on a mesh as on the tilted ground, and rolls in a curved bowl as the closed form says, on both MPM
engines. A round body meets a collider on its exact shape: each point reads the collider's field at the body's centre
(a cylinder: at its slice of the axis), ``gasp_core.mpm.round_ground.collider_reach``.

- **The mesh ramp's family** (``benchmarks/studies/roll_collider89.py``: ``tests/test_ramp_collider.py``'s 20 degree
  ramp, a closed box of 12 triangles, gravity straight down): balls and cylinders of R 0.05 and 0.1 m at n_grid 32,
  48 and 64 (a 0.8 m box), with four samplings of their Gaussians, at mu 0.5 (rolls) and 0.05 (slips), judged by
  ``test_rolling``'s two-sided 5 % check against the closed forms of each body's own inertia. Slow; the default tier
  runs round 88's miss, the 5 cm ball at n_grid 64 slipping (it spun up 10.9 % short on its points).
- **The bowl**: a 5 cm ball released at rest 20 degrees up a spherical bowl of radius 0.25 m (the signed distance of
  the space outside a sphere, exact), mu 0.5. Rolling without slip, its centre swings on a circle of radius ``L =
  Rb - r`` as a pendulum of length ``(1 + k) L`` (``k = I / (M r^2)``): half period ``2 sqrt((1 + k) L / g)
  K(sin^2(theta0 / 2))`` (``K`` the complete elliptic integral, scipy's ``ellipk``), 0.535 s; sliding without
  friction it would swing in ``1 / sqrt(1 + k)`` of it (15 % shorter). Measured: the time between the centre's first
  two passes under the bowl's centre, within 5 % (two-sided).
- **Catches**: round 88's contact on the points (``ROUND_COLLIDER`` 0) fails the 5 cm ball; a frictionless bowl and
  figures 6 % off fail the bowl's check.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("trimesh", reason="mesh colliders need trimesh (the [mesh] extra)")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))

import roll_collider89 as RC  # noqa: E402
import roll_family88 as RF  # noqa: E402
import test_rolling as rl  # noqa: E402
from slopes import ENGINES  # noqa: E402

#: The bowl: its radius (m), the ball's (m), the release angle (degrees), the box (m) and grid, frames a second.
BOWL_R, BALL_R, THETA0, BOX, BOWL_GRID, FPS = 0.25, 0.05, 20.0, 0.6, 32, 60
#: The bowl's centre (m): its bottom 5 cm over the box's floor.
BOWL_C = np.array([BOX / 2, BOX / 2, 0.05 + BOWL_R])
#: Seconds run: past the centre's second pass under the bowl's centre.
BOWL_T = 1.05


def family_ids(case):
    return f"R{case[0]}-n{case[1]}-{case[2]}"


def ramp_problem(engine: str, shape: str, radius: float, n_grid: int, sampling: str, mu: float) -> str | None:
    r = RC.row(engine, shape, radius, n_grid, sampling, mu)
    return r["problem"]


@pytest.mark.parametrize("engine", ENGINES)
def test_a_5_cm_ball_slips_on_the_mesh_ramp_as_on_the_slope(engine):
    """Round 88's miss: the 5 cm ball (the cell of n_grid 64 in the 0.8 m box) slipping at mu 0.05 on the mesh ramp:
    Coulomb's acceleration and the spin-up within ``test_rolling``'s check, as on the tilted ground."""
    pytest.importorskip(f"gasp_{engine}")
    problem = ramp_problem(engine, "ball", 0.05, 64, "fibonacci", 0.05)
    assert problem is None, f"{engine}: {problem}"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("shape", ("ball", "cylinder"))
@pytest.mark.parametrize("case", RC.family(), ids=family_ids)
@pytest.mark.parametrize("mu", RF.MUS)
def test_a_round_body_rolls_or_slips_on_the_mesh_ramp_across_the_family(engine, shape, case, mu):
    pytest.importorskip(f"gasp_{engine}")
    problem = ramp_problem(engine, shape, *case, mu)
    assert problem is None, f"{engine} {shape} {case} mu {mu}: {problem}"


def _catch_points(engine: str, monkeypatch) -> str | None:
    import gasp_core.mpm.round_ground as rg
    monkeypatch.setattr(rg, "ROUND_COLLIDER", 0)
    return ramp_problem(engine, "ball", 0.05, 64, "fibonacci", 0.05)


def test_the_ramp_check_catches_a_ball_on_its_points(monkeypatch):
    """Round 88's collider contact on the ball's Gaussians (``ROUND_COLLIDER`` 0): the 5 cm ball's spin-up falls short
    (warp_mpm; taichi_mpm in the slow tier)."""
    pytest.importorskip("gasp_warp_mpm")
    assert _catch_points("warp_mpm", monkeypatch) is not None


@pytest.mark.slow
def test_the_ramp_check_catches_a_ball_on_its_points_taichi(monkeypatch):
    pytest.importorskip("gasp_taichi_mpm")
    assert _catch_points("taichi_mpm", monkeypatch) is not None


# --------------------------------------------------------------------------- the bowl
def bowl_collider(mu: float):
    """The bowl: the space outside a sphere of radius ``BOWL_R`` about ``BOWL_C`` (signed distance ``BOWL_R - |x -
    C|``, exact), sampled at half the cell over the box, friction ``mu``."""
    from gasp_core.colliders.sdf import SDF_PAD, SDF_SPACING, _finish
    h = SDF_SPACING * BOX / BOWL_GRID
    origin = np.full(3, -SDF_PAD * h)
    n = int(round(BOX / h)) + 2 * SDF_PAD + 1
    g = origin + h * np.stack(np.meshgrid(*(np.arange(n),) * 3, indexing="ij"), axis=-1)
    phi = BOWL_R - np.linalg.norm(g - BOWL_C, axis=-1)
    return _finish("bowl", phi, origin, h, friction=mu)


def bowl_half_period(k: float) -> float:
    """The closed form's time (s) between the centre's passes under the bowl's centre, rolling without slip."""
    from scipy.special import ellipk
    L = (1.0 + k) * (BOWL_R - BALL_R)
    return 2.0 * math.sqrt(L / rl.G) * float(ellipk(math.sin(math.radians(THETA0) / 2.0) ** 2))


def bowl_figure(engine: str, mu: float = rl.ROLL_MU) -> tuple[float, float]:
    """``(measured, closed form)``: the time (s) between the ball's centre's first two passes under the bowl's centre
    (linear between frames), and :func:`bowl_half_period` of the ball's own inertia."""
    from gasp_core.seam.setup import Material
    from gasp_core.testing.helpers import make_setup
    x, vol, n_render = RF.ball(BALL_R, BOWL_GRID, "fibonacci")   # RF's box is the bowl's (0.6 m)
    k = RF.inertia_share(x, vol, BALL_R)
    x = x - (vol[:, None] * x).sum(0) / vol.sum()
    t0 = math.radians(THETA0)
    centre = BOWL_C + (BOWL_R - BALL_R) * np.array([math.sin(t0), 0.0, -math.cos(t0)])
    st = make_setup(x + centre, vol, Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0), lo=np.zeros(3),
                    hi=np.full(3, BOX), n_grid=BOWL_GRID, frame_dt=1.0 / FPS)
    st.n_render = n_render
    st.colliders = [bowl_collider(mu)]
    c = rl.trace(engine, st, BOWL_T)[0][:, 0] - BOWL_C[0]
    t = np.arange(len(c)) / FPS
    cross = [t[i] + (t[i + 1] - t[i]) * c[i] / (c[i] - c[i + 1]) for i in range(len(c) - 1)
             if c[i] != 0.0 and np.sign(c[i]) != np.sign(c[i + 1])]
    measured = cross[1] - cross[0] if len(cross) >= 2 else math.inf
    return measured, bowl_half_period(k)


def bowl_problem(measured: float, want: float) -> str | None:
    err = measured / want - 1.0
    return None if abs(err) <= rl.TOL else f"half period {measured:.4f} s against {want:.4f} ({100 * err:+.2f} %)"


@pytest.mark.parametrize("engine", ENGINES)
def test_a_ball_rolls_in_a_bowl_with_the_pendulums_period(engine):
    pytest.importorskip(f"gasp_{engine}")
    problem = bowl_problem(*bowl_figure(engine))
    assert problem is None, f"{engine}: {problem}"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_bowl_check_catches_broken_engines(engine):
    pytest.importorskip(f"gasp_{engine}")
    measured, want = bowl_figure(engine, mu=0.0)
    caught = {"never sticks (frictionless)": bowl_problem(measured, want),
              "6 % high": bowl_problem(1.06 * want, want), "6 % low": bowl_problem(0.94 * want, want)}
    missed = [k for k, v in caught.items() if v is None]
    assert not missed, f"{engine}: the bowl's check misses {missed}"
